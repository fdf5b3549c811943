"""Ellipsoid primitive: a point skeleton with a field radius per axis (docs/extending.md builds
this file step by step as the worked example of adding a node type)."""

from __future__ import annotations

import math

import numpy as np

from ..checks import MAX_SIZE, MIN_SIZE, Vec3
from ..fields import SLOPE
from ..runtime.jit import kernel
from ..texture import mapping as tex
from . import kernel_math
from .kernels import PrimitiveKernels
from .kinds import FALLOFF_PARAM, Primitive
from .layout import FALLOFF, GEOMETRY, Layout
from .node import register
from .params import Param

# Where the ellipsoid's own numbers sit in the program, after the primitive header.
LAYOUT = Layout(GEOMETRY, center=3, radii=3)
CENTER, RADII = LAYOUT.offsets


@kernel
def ellipsoid_s(p, o, qx, qy, qz):
    """s = sum_i ((q_i - c_i) / R_i)^2 and ds/dq_i = 2 (q_i - c_i) / R_i^2."""
    c, r = o + CENTER, o + RADII
    ux, uy, uz = (qx - p[c]) / p[r], (qy - p[c + 1]) / p[r + 1], (qz - p[c + 2]) / p[r + 2]
    return (ux * ux + uy * uy + uz * uz,
            2.0 * ux / p[r], 2.0 * uy / p[r + 1], 2.0 * uz / p[r + 2])


@kernel
def ellipsoid_uv(p, o, qx, qy, qz):
    """The point's (u, v) of the unit sphere the ellipsoid is a stretched copy of."""
    c, r = o + CENTER, o + RADII
    ux, uy, uz = (qx - p[c]) / p[r], (qy - p[c + 1]) / p[r + 1], (qz - p[c + 2]) / p[r + 2]
    n = math.sqrt(ux * ux + uy * uy + uz * uz)
    cos_t = min(max(uy / n if n > 0.0 else 0.0, -1.0), 1.0)
    return kernel_math.turn(-uz, ux), math.acos(cos_t) / math.pi


@kernel
def ellipsoid_lipschitz(p, o, lip, cx, cy, cz, hx, hy, hz, r):
    """Over the local region (within the box of centre c, half extents h, and the ball of
    radius r about c): in the stretched coordinates u = (q - centre) / R the field is a unit
    point's, whose slope is bounded by the nearest and farthest |u| in the region (the ball
    stretches to within r / min R of u(c)); |grad_q f| <= |grad_u f| / min R, and ``lip``
    carries 1 / min R."""
    c, rr = o + CENTER, o + RADII
    near2 = far2 = uc2 = 0.0
    for k in range(3):
        off = abs((cx, cy, cz)[k] - p[c + k]) / p[rr + k]
        width = (hx, hy, hz)[k] / p[rr + k]
        gap = max(off - width, 0.0)
        near2 += gap * gap
        far2 += (off + width) * (off + width)
        uc2 += off * off
    reach = r / min(p[rr], p[rr + 1], p[rr + 2])
    uc = math.sqrt(uc2)
    return lip * kernel_math.slope_at(int(p[o + FALLOFF]), max(math.sqrt(near2), uc - reach),
                                      min(math.sqrt(far2), uc + reach))


@kernel
def ellipsoid_rise(p, o, lox, loy, loz, hix, hiy, hiz, dx, dy, dz, spread):
    """How fast the field can rise along a cone of rays (``kernel_math.quadric_rise`` with
    k_i = 1 / R_i^2)."""
    c, r = o + CENTER, o + RADII
    return kernel_math.quadric_rise(p, o, (p[c], p[c + 1], p[c + 2]),
                                    (1.0 / p[r] ** 2, 1.0 / p[r + 1] ** 2, 1.0 / p[r + 2] ** 2),
                                    (lox, loy, loz, hix, hiy, hiz), (dx, dy, dz), spread)


@register
class Ellipsoid(Primitive):
    """Ellipsoid: a point skeleton at ``center`` whose field radius is ``radii`` along x, y, z,
    f = falloff(sum ((q - center) / radii)^2).  A lone one's surface is the ellipsoid of
    semi-axes radii / 2 (soft object falloff).  Turn it with ``rotate``."""

    TYPE = "ellipsoid"
    PARAMS = (
        Param("radii", Vec3(sample=(0.3, 1.2), limit=MAX_SIZE, least=MIN_SIZE), (1.0, 1.0, 1.0),
              "field radius along x, y, z"),
        Param("center", Vec3(), (0.0, 0.0, 0.0)),
        FALLOFF_PARAM,
    )
    LAYOUT = LAYOUT
    KERNELS = PrimitiveKernels(s=ellipsoid_s, uv=ellipsoid_uv, lipschitz=ellipsoid_lipschitz,
                               rise=ellipsoid_rise)

    def _check(self):
        if np.any(self.radii <= 0.0):
            raise ValueError(f"radii must all be > 0, got {tuple(self.radii.tolist())}")

    @property
    def field_radius(self) -> float:
        return float(self.radii.max())

    def pack(self):
        return LAYOUT.pack(center=self.center, radii=self.radii)

    def _s(self, q):
        u = (q - self.center) / self.radii
        return (u * u).sum(axis=1), 2.0 * u / self.radii

    def uv(self, q):
        u = (q - self.center) / self.radii
        n = np.linalg.norm(u, axis=1)
        cos_t = np.clip(u[:, 1] / np.where(n > 0.0, n, 1.0), -1.0, 1.0)
        return tex.turn(-u[:, 2], u[:, 0]), np.arccos(cos_t) / np.pi

    def _box(self, L):
        # the image of an ellipsoid under the linear map A has half extents |A_j diag(R)|
        c = L[:, :3] @ self.center + L[:, 3]
        h = np.sqrt(((L[:, :3] * self.radii) ** 2).sum(axis=1))
        return c - h, c + h

    def _lipschitz(self):
        return SLOPE[self.falloff] / float(self.radii.min())
