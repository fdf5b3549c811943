"""Barr's bend: the paper's spines are cones bent by 30 degrees (Section 3.2)."""

from __future__ import annotations

import math
from functools import cached_property

import numpy as np

from .. import geometry as geo
from ..checks import AXES, Number, positive
from ..runtime.jit import kernel
from . import kernel_math
from .kernels import WarpKernels
from .layout import Layout
from .node import register
from .params import Param
from .warp import PERM_END, Warp

LAYOUT = Layout(PERM_END, k=1, length=1, end_sin=1, end_cos=1)
#: The smallest bend, in degrees: below it the circle's centre is so far away that its maths
#: loses all precision (and the bend does nothing visible).
MIN_DEGREES = 1e-3
K, LENGTH, END_SIN, END_COS = LAYOUT.offsets


@kernel(inline="always")
def bend_frame(p, o):
    """The bend's numbers for many points: curvature k, 1 / k, the end angle theta = k length
    and its sine and cosine (parameters)."""
    k = p[o + K]
    return k, 1.0 / k, k * p[o + LENGTH], p[o + END_SIN], p[o + END_COS]


@kernel(inline="always")
def _bent(w, X, Y):
    """Canonical bend along x toward +y with curvature k over [0, length] (w: :func:`bend_frame`).
    On the arc a point at angle phi and distance rho from the centre of curvature (0, 1/k) maps
    to (phi / k, 1/k - rho) (no sine or cosine: sin phi = u / rho, cos phi = v / rho); before it
    (phi <= 0) it stays; past its end angle theta it continues straight along the end tangent.
    All three are computed and one is selected, without branches, so that a loop over many
    points vectorises (``kernel_math.atan2`` likewise).  Returns (qx, qy, on the arc, past it,
    u, v, rho^2, rho)."""
    _, ik, end, sn, cs = w
    u, v = X, ik - Y
    phi = kernel_math.atan2(u, v)
    rho2 = u * u + v * v
    rho = math.sqrt(rho2)
    arc = (phi > 0.0) & (phi < end)
    past = phi >= end
    dx, dy = X - sn * ik, Y - (1.0 - cs) * ik
    qx = phi * ik if arc else (end * ik + dx * cs + dy * sn if past else X)
    qy = ik - rho if arc else (-dx * sn + dy * cs if past else Y)
    return qx, qy, arc, past, u, v, rho2, rho


@kernel(inline="always")
def bend_apply(w, X, Y, Z):
    """The bend's query map (:func:`_bent`) without its Jacobian."""
    qx, qy, _, _, _, _, _, _ = _bent(w, X, Y)
    return qx, qy, Z


@kernel
def bend_stretch(p, o, lox, loy, loz, hix, hiy, hiz):
    """The norm of the query map's Jacobian over the canonical box, at most: 1 before and past
    the arc (a turn), max(1, 1 / (k rho)) on it at distance rho from the centre of curvature
    (its rows have norms 1 / (k rho) and 1: :func:`bend_map`), so 1 / (k rho) at the box's
    nearest point; inf where the box reaches the centre's side (v = 1/k - Y <= 0)."""
    _, ik, _, _, _ = bend_frame(p, o)
    vlo = ik - hiy
    if not vlo > 0.0:
        return np.inf
    uc = min(max(0.0, lox), hix)
    return max(1.0, ik / math.sqrt(uc * uc + vlo * vlo))


@kernel
def bend_map(p, o, X, Y, Z):
    """The bend's query map (:func:`_bent`) and its Jacobian."""
    w = bend_frame(p, o)
    k, _, _, sn, cs = w
    qx, qy, arc, past, u, v, rho2, rho = _bent(w, X, Y)
    j00 = v / (k * rho2) if arc else (cs if past else 1.0)
    j01 = u / (k * rho2) if arc else (sn if past else 0.0)
    j10 = -u / rho if arc else (-sn if past else 0.0)
    j11 = v / rho if arc else (cs if past else 1.0)
    return qx, qy, Z, j00, j01, 0.0, j10, j11, 0.0, 0.0, 0.0, 1.0


@register
class Bend(Warp):
    """Barr bend: the child's part from 0 to ``length`` along ``axis`` is bent into a circular arc
    of ``degrees`` curving toward +``toward`` (negative degrees: toward -``toward``); beyond
    ``length`` it continues straight along the arc's end tangent; below 0 it is unchanged."""

    TYPE = "bend"
    METHOD = "bend"
    PARAMS = (
        Param("degrees", Number(lo=-180.0, hi=180.0, sample=(-60.0, 60.0)),
              doc="angle of the arc; non-zero"),
        Param("length", positive(sample=(0.5, 2.0)), doc="length of the bent part"),
        Param("axis", AXES, "x"),
        Param("toward", AXES, "y"),
    )
    LAYOUT = LAYOUT
    KERNELS = WarpKernels(map=bend_map, frame=bend_frame, apply=bend_apply,
                          stretch=bend_stretch)

    def _check(self):
        if abs(self.degrees) < MIN_DEGREES:
            raise ValueError(f"degrees must be at least {MIN_DEGREES} in magnitude (and within "
                             f"[-180, 180]), got {self.degrees!r}")
        if self.axis == self.toward:
            raise ValueError(f"axis and toward must differ, got {self.axis!r} twice")
        if self.y_hi >= 1.0 / self.k:
            raise ValueError(
                f"bend of {self.degrees} degrees over length {self.length} is too tight: the "
                f"child reaches {self.y_hi:.4g} toward '{self.toward}', past the centre of "
                f"curvature at {1 / self.k:.4g}")

    @cached_property
    def index(self) -> tuple[int, int, int]:
        """(axis, the axis bent toward, the third) as indices."""
        a, b = geo.AXES[self.axis], geo.AXES[self.toward]
        return a, b, 3 - a - b

    @cached_property
    def sign(self) -> float:
        """+1 for a bend toward +``toward``, -1 toward -``toward``."""
        return 1.0 if self.degrees > 0 else -1.0

    @cached_property
    def k(self) -> float:
        """Curvature: radians per unit length."""
        return math.radians(abs(self.degrees)) / self.length

    @cached_property
    def y_hi(self) -> float:
        """How far the child reaches toward the centre of curvature."""
        b = self.index[1]
        return self.sign * self.child_box[1][b] if self.sign > 0 else -self.child_box[0][b]

    @property
    def canonical(self):
        a, b, c = self.index
        m = np.zeros((3, 3))
        m[0, a], m[1, b], m[2, c] = 1.0, self.sign, 1.0
        return m

    def pack(self):
        end = self.k * self.length
        return LAYOUT.pack(k=self.k, length=self.length, end_sin=math.sin(end),
                           end_cos=math.cos(end))

    def warp_points(self, P):
        k, ik = self.k, 1.0 / self.k
        perm = self.canonical
        X = P @ perm.T
        u, v = X[:, 0], ik - X[:, 1]
        phi = np.arctan2(u, v)
        th = np.clip(phi, 0.0, k * self.length)
        sn, cs = np.sin(th), np.cos(th)
        dx, dy = X[:, 0] - sn * ik, X[:, 1] - (1.0 - cs) * ik
        Q = np.stack([th * ik + dx * cs + dy * sn, -dx * sn + dy * cs, X[:, 2]], axis=1)
        # Jacobian in canonical coordinates: rows d(x, y)/d(X, Y)
        rho2 = u * u + v * v
        rho = np.sqrt(rho2)
        arc = (phi > 0.0) & (phi < k * self.length)
        J = np.zeros((len(P), 3, 3))
        J[:, 0, 0] = np.where(arc, v / (k * rho2), cs)
        J[:, 0, 1] = np.where(arc, u / (k * rho2), sn)
        J[:, 1, 0] = np.where(arc, -u / rho, -sn)
        J[:, 1, 1] = np.where(arc, v / rho, cs)
        J[:, 2, 2] = 1.0
        return Q @ perm, np.einsum("ji,njk,kl->nil", perm, J, perm)

    def _deformed_box(self):
        perm = self.canonical
        clo, chi = geo.transform_box(geo.affine(perm), self.child_box)
        k, ik, length = self.k, 1.0 / self.k, self.length
        pts = []
        x0, x1 = clo[0], chi[0]
        ys = (clo[1], chi[1])
        if x0 < 0.0:  # unbent part
            for x in (x0, min(x1, 0.0)):
                pts += [(x, y) for y in ys]
        if x1 > 0.0 and x0 < length:  # arc part
            ta, tb = k * max(x0, 0.0), k * min(x1, length)
            thetas = [ta, tb] + [t for t in (math.pi / 2, math.pi) if ta < t < tb]
            for t in thetas:
                for y in ys:
                    r = ik - y
                    pts.append((r * math.sin(t), ik - r * math.cos(t)))
        if x1 > length:  # straight continuation beyond the arc
            t = k * length
            ox, oy = math.sin(t) * ik, (1 - math.cos(t)) * ik
            for x in (max(x0, length), x1):
                for y in ys:
                    s = x - length
                    pts.append((ox + s * math.cos(t) - y * math.sin(t),
                                oy + s * math.sin(t) + y * math.cos(t)))
        xy = np.array(pts)
        cbox = (np.array([xy[:, 0].min(), xy[:, 1].min(), clo[2]]),
                np.array([xy[:, 0].max(), xy[:, 1].max(), chi[2]]))
        return geo.transform_box(geo.affine(perm.T), cbox)

    @cached_property
    def stretch(self) -> float:
        return max(1.0, 1.0 / (self.k * (1.0 / self.k - self.y_hi)))
