"""Barr's twist about an axis."""

from __future__ import annotations

import math
from functools import cached_property

import numpy as np

from ..checks import AXES, angle
from ..runtime.jit import kernel
from .kernels import WarpKernels
from .layout import Layout
from .node import register
from .params import Param
from .warp import PERM_END, AxialWarp

LAYOUT = Layout(PERM_END, k=1)
(K,) = LAYOUT.offsets


@kernel
def twist_map(p, o, X, Y, Z):
    """Canonical twist about z: the point turns by k * Z radians."""
    k = p[o + K]
    th = k * Z
    cs, sn = math.cos(th), math.sin(th)
    qx, qy = cs * X + sn * Y, -sn * X + cs * Y
    return qx, qy, Z, cs, sn, k * qy, -sn, cs, -k * qx, 0.0, 0.0, 1.0


@register
class Twist(AxialWarp):
    """Barr twist about ``axis``: at height t along the axis the child is turned by
    ``degrees_per_unit * t`` degrees (right-hand rule)."""

    TYPE = "twist"
    METHOD = "twist"
    PARAMS = (
        Param("degrees_per_unit", angle(sample=(-90.0, 90.0))),
        Param("axis", AXES, "y"),
    )
    LAYOUT = LAYOUT
    KERNELS = WarpKernels(map=twist_map)

    @cached_property
    def k(self) -> float:
        """The twist rate in radians per unit length."""
        return math.radians(self.degrees_per_unit)

    def pack(self):
        return LAYOUT.pack(k=self.k)

    def warp_points(self, P):
        a, i, j = self.index
        th = self.k * P[:, a]
        cs, sn = np.cos(th), np.sin(th)
        Q = P.copy()
        Q[:, i] = cs * P[:, i] + sn * P[:, j]
        Q[:, j] = -sn * P[:, i] + cs * P[:, j]
        J = np.zeros((len(P), 3, 3))
        J[:, a, a] = 1.0
        J[:, i, i], J[:, i, j], J[:, i, a] = cs, sn, self.k * Q[:, j]
        J[:, j, i], J[:, j, j], J[:, j, a] = -sn, cs, -self.k * Q[:, i]
        return Q, J

    def _deformed_box(self):
        lo, hi = (b.copy() for b in self.child_box)
        _, i, j = self.index
        lo[[i, j]], hi[[i, j]] = -self.reach, self.reach
        return lo, hi

    @cached_property
    def stretch(self) -> float:
        return 1.0 + abs(self.k) * self.reach
