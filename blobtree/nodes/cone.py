"""Cone and segment primitives: the paper's spines (Section 3.2) and canal (Section 3.1)."""

from __future__ import annotations

import math

import numpy as np

from .. import geometry as geo
from ..checks import Vec3, positive
from ..fields import SLOPE
from ..runtime.jit import kernel
from ..texture import mapping as tex
from . import kernel_math
from .kernels import PrimitiveKernels
from .kinds import FALLOFF_PARAM, Primitive
from .layout import FALLOFF, GEOMETRY, Layout
from .node import register
from .params import Param

LAYOUT = Layout(GEOMETRY, a=3, b=3, radius_a=1, radius_b=1, frame=6)
A, B, RA, RB, FRAME = LAYOUT.offsets


@kernel
def cone_s(p, o, qx, qy, qz):
    """s = r^2 / R(t)^2, t the clamped projection of q on a-b and R(t) linear in t; ds/dq
    includes R's change where t is not clamped."""
    a = o + A
    ax, ay, az = p[a], p[a + 1], p[a + 2]
    ux, uy, uz = p[o + B] - ax, p[o + B + 1] - ay, p[o + B + 2] - az
    l2 = ux * ux + uy * uy + uz * uz
    t_raw = ((qx - ax) * ux + (qy - ay) * uy + (qz - az) * uz) / l2
    t = min(max(t_raw, 0.0), 1.0)
    dx, dy, dz = qx - ax - t * ux, qy - ay - t * uy, qz - az - t * uz
    ra, dr = p[o + RA], p[o + RB] - p[o + RA]
    rt = ra + t * dr
    d2 = dx * dx + dy * dy + dz * dz
    k = 2.0 / (rt * rt)
    if 0.0 < t_raw < 1.0:
        c = 2.0 * d2 / (rt * rt * rt) * dr / l2
        return d2 / (rt * rt), k * dx - c * ux, k * dy - c * uy, k * dz - c * uz
    return d2 / (rt * rt), k * dx, k * dy, k * dz


@kernel
def cone_uv(p, o, qx, qy, qz):
    return kernel_math.axis_uv(p, o + A, o + FRAME, qx, qy, qz, True)


@kernel(inline="always")
def _cone_reach(p, o, cx, cy, cz, hx, hy, hz, r):
    """Over the region (within the box and the ball of radius r about its centre): the least
    and most distance from the axis segment over R(t), and the least R(t), for the t it can
    reach (the clamped projection moves by at most the region's radius over the length)."""
    a = o + A
    ax, ay, az = p[a], p[a + 1], p[a + 2]
    ux, uy, uz = p[o + B] - ax, p[o + B + 1] - ay, p[o + B + 2] - az
    length = math.sqrt(ux * ux + uy * uy + uz * uz)
    rho = min(math.sqrt(hx * hx + hy * hy + hz * hz), r)
    tc = ((cx - ax) * ux + (cy - ay) * uy + (cz - az) * uz) / (length * length)
    t = min(max(tc, 0.0), 1.0)
    dx, dy, dz = cx - ax - t * ux, cy - ay - t * uy, cz - az - t * uz
    d = math.sqrt(dx * dx + dy * dy + dz * dz)
    ra, rb = p[o + RA], p[o + RB]
    t0 = min(max(tc - rho / length, 0.0), 1.0)
    t1 = min(max(tc + rho / length, 0.0), 1.0)
    r0, r1 = ra + t0 * (rb - ra), ra + t1 * (rb - ra)
    rlo, rhi = min(r0, r1), max(r0, r1)
    return max(d - rho, 0.0) / rhi, (d + rho) / rlo, rlo


@kernel(inline="always")
def cone_span(p, o, cx, cy, cz, hx, hy, hz, r):
    """Least and most of r / R(t) over the region (:func:`_cone_reach`)."""
    rmin, rmax, _ = _cone_reach(p, o, cx, cy, cz, hx, hy, hz, r)
    return rmin, rmax


@kernel
def cone_lipschitz(p, o, lip, cx, cy, cz, hx, hy, hz, r):
    """The distance-aware bound with R(t) bounded over the t the region can reach."""
    rmin, rmax, rlo = _cone_reach(p, o, cx, cy, cz, hx, hy, hz, r)
    # lip = SLOPE (1 + |dR| / L) / min(ra, rb) * |A|: rescale its 1 / min(ra, rb) to 1 / rlo
    ra, rb = p[o + RA], p[o + RB]
    return lip * kernel_math.slope_at(int(p[o + FALLOFF]), rmin, rmax) * min(ra, rb) / rlo


KERNELS = PrimitiveKernels(s=cone_s, uv=cone_uv, lipschitz=cone_lipschitz, span=cone_span)


@register
class Cone(Primitive):
    """Segment skeleton a-b whose field radius varies linearly from radius_a to radius_b.

    r / R(t) is used in the falloff, with t the clamped projection on the axis (a scaled-distance
    cone; our choice: the paper does not define its cone).  The paper's spines are cones.
    """

    TYPE = "cone"
    PARAMS = (
        Param("a", Vec3()),
        Param("b", Vec3()),
        Param("radius_a", positive(), doc="field radius at a"),
        Param("radius_b", positive(), doc="field radius at b"),
        FALLOFF_PARAM,
    )
    LAYOUT = LAYOUT
    KERNELS = KERNELS

    def _check(self):
        if np.linalg.norm(self.b - self.a) == 0.0:
            raise ValueError(f"a and b must differ (zero-length axis at {tuple(self.a)})")

    @property
    def field_radius(self) -> float:
        return max(self.radius_a, self.radius_b)

    def pack(self):
        return LAYOUT.pack(a=self.a, b=self.b, radius_a=self.radius_a, radius_b=self.radius_b,
                           frame=np.concatenate(tex.perpendicular_frame(self.b - self.a)))

    def _s(self, q):
        ab = self.b - self.a
        l2 = ab @ ab
        t_raw = (q - self.a) @ ab / l2
        t = np.clip(t_raw, 0.0, 1.0)
        d = q - (self.a + t[:, None] * ab)
        dr = self.radius_b - self.radius_a
        rt = self.radius_a + t * dr
        d2 = (d * d).sum(axis=1)
        free = ((t_raw > 0.0) & (t_raw < 1.0))[:, None]
        ds = 2.0 * d / rt[:, None] ** 2 - np.where(
            free, (2.0 * d2 / rt**3 * dr)[:, None] * ab / l2, 0.0)
        return d2 / rt**2, ds

    def uv(self, q):
        """u = angle around the axis (from ``texture.mapping.perpendicular_frame``), v = t."""
        ab = self.b - self.a
        t = np.clip((q - self.a) @ ab / (ab @ ab), 0.0, 1.0)
        d = q - (self.a + t[:, None] * ab)
        e1, e2 = tex.perpendicular_frame(ab)
        return tex.turn(d @ e2, d @ e1), t

    def _box(self, L):
        ends = []
        for p, r in ((self.a, self.radius_a), (self.b, self.radius_b)):
            c = L[:, :3] @ p + L[:, 3]
            h = geo.ellipsoid_half(L, r)
            ends.append((c - h, c + h))
        return geo.box_union(ends)

    def _lipschitz(self):
        # |grad (r / R(t))| <= (1 + |R_b - R_a| / |b - a|) / min R
        slope = abs(self.radius_b - self.radius_a) / np.linalg.norm(self.b - self.a)
        return SLOPE[self.falloff] * (1.0 + slope) / min(self.radius_a, self.radius_b)


@register
class Segment(Cone):
    """Line-segment skeleton a-b with a constant field radius (a cone with equal radii)."""

    TYPE = "segment"
    PARAMS = (
        Param("a", Vec3()),
        Param("b", Vec3()),
        Param("radius", positive(), 1.0, "field radius R"),
        FALLOFF_PARAM,
    )

    @property
    def radius_a(self) -> float:
        """The field radius at ``a``: a segment's radius is the same at both ends."""
        return self.radius

    @property
    def radius_b(self) -> float:
        """The field radius at ``b`` (= ``radius``)."""
        return self.radius
