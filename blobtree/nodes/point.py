"""Point primitive: the paper's generating surface (Section 3.1) and its bumps (Section 3.2)."""

from __future__ import annotations

import math

import numpy as np

from .. import geometry as geo
from ..checks import Vec3, positive
from ..runtime.jit import kernel
from ..texture import mapping as tex
from . import kernel_math
from .kernels import PrimitiveKernels
from .kinds import FALLOFF_PARAM, Primitive
from .layout import FALLOFF, GEOMETRY, RADIUS, Layout
from .node import register
from .params import Param

LAYOUT = Layout(GEOMETRY, center=3)
(CENTER,) = LAYOUT.offsets


@kernel
def point_s(p, o, qx, qy, qz):
    c = o + CENTER
    return kernel_math.squared(qx - p[c], qy - p[c + 1], qz - p[c + 2], p[o + RADIUS])


@kernel
def point_uv(p, o, qx, qy, qz):
    c = o + CENTER
    dx, dy, dz = qx - p[c], qy - p[c + 1], qz - p[c + 2]
    r = math.sqrt(dx * dx + dy * dy + dz * dz)
    cos_t = min(max(dy / r if r > 0.0 else 0.0, -1.0), 1.0)
    return kernel_math.turn(-dz, dx), math.acos(cos_t) / math.pi


@kernel(inline="always")
def point_span(p, o, cx, cy, cz, hx, hy, hz, r):
    """Nearest and farthest distances from the centre to the (local) region, over R: to the
    box, per axis, and to the ball of radius r about its centre; the tighter of each."""
    c = o + CENTER
    dmin2 = dmax2 = dc2 = 0.0
    for off, half in ((cx - p[c], hx), (cy - p[c + 1], hy), (cz - p[c + 2], hz)):
        gap = max(abs(off) - half, 0.0)
        dmin2 += gap * gap
        dmax2 += (abs(off) + half) ** 2
        dc2 += off * off
    dc = math.sqrt(dc2)
    radius = p[o + RADIUS]
    return max(math.sqrt(dmin2), dc - r) / radius, min(math.sqrt(dmax2), dc + r) / radius


@kernel
def point_lipschitz(p, o, lip, cx, cy, cz, hx, hy, hz, r):
    """The falloff's steepest slope over the region's distances (:func:`point_span`)."""
    rmin, rmax = point_span(p, o, cx, cy, cz, hx, hy, hz, r)
    return lip * kernel_math.slope_at(int(p[o + FALLOFF]), rmin, rmax)


@kernel
def point_along(p, o, ox, oy, oz, dx, dy, dz, length):
    """The largest |df/dt| along the frame segment o + t d, 0 <= t <= length (segment tracing's
    directional bound, Galin et al. 2020).  In the primitive's coordinates the segment is
    q(t) = w + t e about the centre, so s = u^2 + c with u = |e| (t - t_c) / R and c the squared
    perpendicular distance over R^2, and |df/dt| = 2 |e| / R |u| |f'(s)|: a function of |u| with
    one peak (``fields.falloff_peak``), so its maximum over the segment's range of |u| is at the
    peak clamped to that range.  Never above ``|grad f|`` on the segment, and small where the
    segment passes the primitive sideways."""
    c = o + CENTER
    ex = p[o] * dx + p[o + 1] * dy + p[o + 2] * dz
    ey = p[o + 4] * dx + p[o + 5] * dy + p[o + 6] * dz
    ez = p[o + 8] * dx + p[o + 9] * dy + p[o + 10] * dz
    wx, wy, wz = kernel_math.map_point(p, o, ox, oy, oz)
    wx, wy, wz = wx - p[c], wy - p[c + 1], wz - p[c + 2]
    e2 = ex * ex + ey * ey + ez * ez
    if e2 == 0.0:
        return 0.0
    r = p[o + RADIUS]
    we = wx * ex + wy * ey + wz * ez
    cc = max(wx * wx + wy * wy + wz * wz - we * we / e2, 0.0) / (r * r)
    if cc >= 1.0:
        return 0.0
    e = math.sqrt(e2)
    u0 = we / (e * r)  # u at t = 0 and at t = length
    u1 = u0 + e * length / r
    a = 0.0 if u0 <= 0.0 <= u1 else min(abs(u0), abs(u1))  # the range [a, b] of |u|
    b = min(max(abs(u0), abs(u1)), math.sqrt(1.0 - cc))
    if a >= b:
        return 0.0
    fid = int(p[o + FALLOFF])
    u = min(max(math.sqrt(kernel_math.fo_peak(fid, cc)), a), b)
    return 2.0 * e / r * u * abs(kernel_math.fo_ds(fid, min(u * u + cc, 1.0)))


@kernel
def point_rise(p, o, lox, loy, loz, hix, hiy, hiz, dx, dy, dz, spread):
    """How fast the field can rise along a cone of rays (``kernel_math.quadric_rise``, s = |q - c|^2
    / R^2): only as fast as they approach the centre."""
    c = o + CENTER
    k = 1.0 / (p[o + RADIUS] * p[o + RADIUS])
    return kernel_math.quadric_rise(p, o, (p[c], p[c + 1], p[c + 2]), (k, k, k),
                                    (lox, loy, loz, hix, hiy, hiz), (dx, dy, dz), spread)


@register
class Point(Primitive):
    """Point skeleton; a lone one has its surface at radius R/2 (soft object falloff)."""

    TYPE = "point"
    PARAMS = (
        Param("radius", positive(), 1.0, "field radius R"),
        Param("center", Vec3(), (0.0, 0.0, 0.0)),
        FALLOFF_PARAM,
    )
    LAYOUT = LAYOUT
    KERNELS = PrimitiveKernels(s=point_s, uv=point_uv, lipschitz=point_lipschitz,
                               along=point_along, rise=point_rise, span=point_span)

    def pack(self):
        return LAYOUT.pack(center=self.center)

    def _delta(self, q):
        return q - self.center

    def uv(self, q):
        """Spherical: u = longitude about +y, v = colatitude / pi."""
        d = q - self.center
        r = np.linalg.norm(d, axis=1)
        cos_t = np.clip(d[:, 1] / np.where(r > 0.0, r, 1.0), -1.0, 1.0)
        return tex.turn(-d[:, 2], d[:, 0]), np.arccos(cos_t) / np.pi

    def _box(self, L):
        c = L[:, :3] @ self.center + L[:, 3]
        h = geo.ellipsoid_half(L, self.radius)
        return c - h, c + h
