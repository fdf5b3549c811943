"""Ricci's super-elliptic blend (Eq. 4), n-ary (associative, as the paper notes)."""

from __future__ import annotations

import math

import numpy as np

from ..checks import Number
from ..runtime.jit import kernel
from .kernel_math import by_squaring, field_range, norm_of, power, root
from .kernels import OperatorKernels
from .kinds import Operator, operator_function
from .layout import BOUND, COLOR, FIELD, GRAD, GRADIENT
from .node import register
from .params import LARGEST_N, Param
from .reference import weighted_color


@kernel(inline="always")
def _power(r, n, tiny):
    """r^n for r in [0, 1]: 0 below ``tiny`` (``op_params``: there r^n < 1e-304)."""
    return power(r, n) if r >= tiny else 0.0


@kernel
def super_combine(vs, b, k, p, o, mode):
    """(sum f_j^n)^(1/n) as m (sum (f_j / m)^n)^(1/n), m the largest f_j: exact and finite for
    any n (f^400 would underflow); the colour weights are (f_j / m)^n, the gradient's
    (f_j / f)^(n - 1) = (f_j / m)^n (m / f_j) s^((1 - n) / n), one power per child."""
    n, tiny = p[o], p[o + 1]
    m = 0.0
    for j in range(b, b + k):
        m = max(m, vs[j, FIELD])
    if m <= 0.0:
        vs[b, FIELD] = 0.0
        vs[b, GRAD] = vs[b, GRAD + 1] = vs[b, GRAD + 2] = 0.0
        return
    s = 0.0
    for j in range(b, b + k):
        s += _power(vs[j, FIELD] / m, n, tiny)
    f = m * root(s, n)
    if mode >= GRADIENT:
        scale = m if s == 1.0 else m * s ** ((1.0 - n) / n)
        g0 = g1 = g2 = 0.0
        c0 = c1 = c2 = 0.0
        for j in range(b, b + k):
            cw = _power(vs[j, FIELD] / m, n, tiny)
            w = cw * scale / vs[j, FIELD] if cw > 0.0 else 0.0
            g0 += w * vs[j, GRAD]
            g1 += w * vs[j, GRAD + 1]
            g2 += w * vs[j, GRAD + 2]
            c0 += cw * vs[j, COLOR]
            c1 += cw * vs[j, COLOR + 1]
            c2 += cw * vs[j, COLOR + 2]
        vs[b, GRAD], vs[b, GRAD + 1], vs[b, GRAD + 2] = g0, g1, g2
        vs[b, COLOR], vs[b, COLOR + 1], vs[b, COLOR + 2] = c0 / s, c1 / s, c2 / s
    vs[b, FIELD] = f


@kernel
def super_bound(vs, b, k, p, o, reach):
    """The gradient is sum w_j grad f_j with w_j = (f_j / f)^(n - 1) <= 1; over the region f is
    at least every child's lowest, f_j at most its highest, so w_j <= (highest_j / f_low)^(n - 1):
    for large n a child that stays below another adds next to nothing to the bound.  Never more
    than the ``norm`` rule's n-norm of the children's bounds, which holds everywhere."""
    n = p[o]
    low = 0.0
    for j in range(b, b + k):
        low = max(low, field_range(vs, j, reach)[0])
    bound = 0.0
    for j in range(b, b + k):
        w = 1.0
        if low > 0.0:
            w = min(1.0, (max(field_range(vs, j, reach)[1], 0.0) / low) ** (n - 1.0))
        bound += w * vs[j, BOUND]
    return min(bound, norm_of(vs, b, b + k, BOUND, n)), 0.0, 0.0


@kernel
def super_rows(vs, b, k, p, o, nb):
    """``super_combine``'s field over a batch, each step a loop over the points that vectorises:
    the largest child m, then each child's (f_j / m)^n with the squarings of ``kmath.power``
    run for all points at once (the same products in the same order: the same values), summed
    child by child; only the n-th root, rarely needed (``kmath.root``), goes point by point."""
    n, tiny = p[o], p[o + 1]
    top, s, r = vs[-3], vs[-2], vs[-1]  # scratch (ROWS_SCRATCH)
    for m in range(nb):
        top[m] = vs[b, m]
        s[m] = 0.0
    for j in range(b + 1, b + k):
        for m in range(nb):
            top[m] = max(top[m], vs[j, m])
    whole = by_squaring(n)
    for j in range(b, b + k):
        x = vs[j]  # the child's row becomes its ratio f_j / m, then its squarings
        for m in range(nb):
            x[m] = x[m] / top[m] if top[m] > 0.0 else 0.0
            r[m] = 1.0 if x[m] >= tiny else 0.0
        if whole:
            e = int(n)
            while e:
                if e & 1:
                    for m in range(nb):
                        r[m] *= x[m]
                for m in range(nb):
                    x[m] *= x[m]
                e >>= 1
        else:
            for m in range(nb):
                r[m] *= x[m] ** n
        for m in range(nb):
            s[m] += r[m]
    for m in range(nb):
        vs[b, m] = top[m] * root(s[m], n) if top[m] > 0.0 else 0.0


@register
class SuperBlend(Operator):
    """Ricci's super-elliptic blend (Eq. 4): (sum f_i^n)^(1/n); n = 1 is the plain blend, and
    n -> infinity tends to the union (Eq. 5).  It is the n-norm of its children's fields, so its
    Lipschitz bound is the n-norm of theirs (the ``norm`` rule): their sum for n = 1, close to
    their largest for large n (the paper's n = 400 for the bumps, Figure 8)."""

    TYPE = "super_blend"
    PARAMS = (Param("n", Number(lo=1.0, hi=LARGEST_N, sample=(1.0, 400.0)), 2.0,
                    "exponent: 1 = blend, large = union"),)
    ASSOCIATIVE = True
    SMOOTH = True
    LIPSCHITZ = "norm"
    MONOTONE = (1, 1)  # an n-norm of fields >= 0
    KERNELS = OperatorKernels(combine=super_combine, rows=super_rows, bound=super_bound)

    def op_params(self):
        """n, and the ratio below which a child's (f_j / m)^n counts as 0 (it would be under
        1e-304)."""
        return [self.n, math.exp(-700.0 / self.n)]

    def _ref(self, P, look=None):
        f, g, c = self._refs(P, look)
        m = f.max(axis=0)
        safe = np.where(m > 0.0, m, 1.0)
        w = (f / safe) ** self.n  # weights f_i^n / m^n, in [0, 1]
        value = np.where(m > 0.0, m * w.sum(axis=0) ** (1.0 / self.n), 0.0)
        ratio = f / np.where(value > 0.0, value, 1.0)
        grad = (ratio[:, :, None] ** (self.n - 1.0) * g).sum(axis=0)
        return value, np.where((value > 0.0)[:, None], grad, 0.0), weighted_color(w, c)


super_blend = operator_function(
    SuperBlend,
    """Ricci super-elliptic blend, Eq. 4, n-ary.""")
