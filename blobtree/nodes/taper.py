"""Barr's taper along an axis."""

from __future__ import annotations

from functools import cached_property

import numpy as np

from ..checks import AXES, MAX_SIZE, Number
from ..runtime.jit import kernel
from .kernels import WarpKernels
from .layout import Layout
from .node import register
from .params import Param
from .warp import PERM_END, AxialWarp

LAYOUT = Layout(PERM_END, rate=1, t0=1, t1=1)
RATE, T0, T1 = LAYOUT.offsets


@kernel
def taper_map(p, o, X, Y, Z):
    """Canonical taper along z: the cross-section is divided by s = 1 + rate * clamp(Z)."""
    rate, t0, t1 = p[o + RATE], p[o + T0], p[o + T1]
    s = 1.0 + rate * min(max(Z, t0), t1)
    qx, qy = X / s, Y / s
    if t0 < Z < t1:
        return qx, qy, Z, 1.0 / s, 0.0, -qx * rate / s, 0.0, 1.0 / s, -qy * rate / s, \
            0.0, 0.0, 1.0
    return qx, qy, Z, 1.0 / s, 0.0, 0.0, 0.0, 1.0 / s, 0.0, 0.0, 0.0, 1.0


@register
class Taper(AxialWarp):
    """Barr taper along ``axis``: the cross-section at t is scaled by s(t) = 1 + rate * t, with t
    clamped to the child's extent along the axis (s must stay > 0 there)."""

    TYPE = "taper"
    METHOD = "taper"
    PARAMS = (
        Param("rate", Number(lo=-MAX_SIZE, hi=MAX_SIZE, sample=(-0.25, 0.25))),
        Param("axis", AXES, "y"),
    )
    LAYOUT = LAYOUT
    KERNELS = WarpKernels(map=taper_map)

    def _check(self):
        if self.s_range[0] <= 0.0:
            raise ValueError(
                f"taper rate {self.rate!r} makes the scale 1 + rate*t <= 0 within the child's "
                f"extent {self.t_range} along '{self.axis}'")

    @cached_property
    def t_range(self) -> tuple[float, float]:
        """The child's extent along the axis: the taper is clamped to it."""
        a = self.index[0]
        return float(self.child_box[0][a]), float(self.child_box[1][a])

    @cached_property
    def s_range(self) -> tuple[float, float]:
        """The smallest and largest scale factor 1 + rate t over :attr:`t_range`."""
        s = [1.0 + self.rate * t for t in self.t_range]
        return min(s), max(s)

    def pack(self):
        return LAYOUT.pack(rate=self.rate, t0=self.t_range[0], t1=self.t_range[1])

    def warp_points(self, P):
        a, i, j = self.index
        t = np.clip(P[:, a], *self.t_range)
        s = 1.0 + self.rate * t
        free = (P[:, a] > self.t_range[0]) & (P[:, a] < self.t_range[1])
        Q = P.copy()
        Q[:, i], Q[:, j] = P[:, i] / s, P[:, j] / s
        J = np.zeros((len(P), 3, 3))
        J[:, a, a] = 1.0
        J[:, i, i] = J[:, j, j] = 1.0 / s
        J[:, i, a] = np.where(free, -Q[:, i] * self.rate / s, 0.0)
        J[:, j, a] = np.where(free, -Q[:, j] * self.rate / s, 0.0)
        return Q, J

    def _deformed_box(self):
        lo, hi = (b.copy() for b in self.child_box)
        _, i, j = self.index
        smin, smax = self.s_range
        for ax in (i, j):
            lo[ax] = min(lo[ax] * smin, lo[ax] * smax)
            hi[ax] = max(hi[ax] * smin, hi[ax] * smax)
        return lo, hi

    @cached_property
    def stretch(self) -> float:
        smin = self.s_range[0]
        return 1.0 / smin + abs(self.rate) * self.reach / smin
