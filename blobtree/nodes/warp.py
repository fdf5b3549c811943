"""What the warps (Barr 1984; the paper's w) share: a query-point map f(p) = f_child(w(p)),
evaluated in canonical axes.

A warp's program parameters are a signed permutation (9 numbers, frame axes to its canonical
axes) followed by its own (``Layout(PERM_END, ...)``); its kernel maps canonical points
(``WarpKernels.map``) and the engine applies the permutation and chains the Jacobians.
"""

from __future__ import annotations

from functools import cached_property
from typing import ClassVar

import numpy as np

from .. import geometry as geo
from .kinds import Unary
from .layout import Layout
from .node import DEFAULT_COLOR

#: A warp's own parameters start after its signed permutation.
PERM_END = 9


class Warp(Unary):
    """A global deformation as a query-point map.  A type supplies ``canonical`` (the signed
    permutation to its canonical axes), ``warp_points(P) -> (Q, J)`` (reference, J = dQ/dP of
    shape (N, 3, 3)), ``_deformed_box`` (the child's box under the forward deformation),
    ``stretch`` (a bound on ``|J|``), ``LAYOUT`` and ``pack``.  The field is 0 outside ``own_box``.
    """

    KIND = "warp"
    LAYOUT: ClassVar[Layout]

    @property
    def canonical(self) -> np.ndarray:
        """Signed permutation P with canonical = P @ frame point."""
        raise NotImplementedError

    def pack(self) -> list[float]:
        """The warp's own parameters, LAYOUT's order (after the permutation)."""
        raise NotImplementedError

    def warp_points(self, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The warp's query map at (N, 3) points: the points in the child's coordinates and the
        (N, 3, 3) Jacobians of the map."""
        raise NotImplementedError

    @cached_property
    def child_box(self) -> geo.Box:
        """The child's own bounding box (zeros when it is empty)."""
        lo, hi = self.child.box(geo.IDENTITY)
        if geo.is_empty((lo, hi)):
            return np.zeros(3), np.zeros(3)
        return lo, hi

    @cached_property
    def own_box(self) -> geo.Box:
        """The box of the deformed child (empty when the child's support is empty)."""
        if geo.is_empty(self.child.box(geo.IDENTITY)):
            return geo.empty_box()
        return self._deformed_box()

    def _deformed_box(self) -> geo.Box:
        raise NotImplementedError

    @cached_property
    def stretch(self) -> float:
        """A bound on the norm of the query map's Jacobian over the warp's box."""
        raise NotImplementedError

    def _ref(self, P, look=None):
        lo, hi = self.own_box
        inside = np.all((P >= lo) & (P <= hi), axis=1)
        f = np.zeros(len(P))
        g = np.zeros_like(P)
        c = np.broadcast_to(np.asarray(DEFAULT_COLOR), P.shape).copy()
        if inside.any():
            q, jac = self.warp_points(P[inside])
            fc, gc, cc = self.child._ref(q, look)
            f[inside] = fc
            g[inside] = np.einsum("nij,ni->nj", jac, gc)
            c[inside] = cc
        return f, g, c

    def _box(self, L):
        return geo.transform_box(L, self.own_box)

    def _lipschitz(self):
        return self.child.lipschitz() * self.stretch


class AxialWarp(Warp):
    """A warp about one ``axis`` (twist, taper): canonical z is the axis."""

    @cached_property
    def index(self) -> tuple[int, int, int]:
        """(axis, the next axis, the one after) as indices."""
        a = geo.AXES[self.axis]
        return a, (a + 1) % 3, (a + 2) % 3

    @property
    def canonical(self):
        a, i, j = self.index
        m = np.zeros((3, 3))
        m[0, i] = m[1, j] = m[2, a] = 1.0
        return m

    @cached_property
    def reach(self) -> float:
        """The child's largest distance from the axis (over its box corners)."""
        lo, hi = self.child_box
        _, i, j = self.index
        return float(max(np.hypot(x, y) for x in (lo[i], hi[i]) for y in (lo[j], hi[j])))
