"""Blend: B_1 + ... + B_n, the sum of the fields (the paper's + and the Sigma of Eq. 9)."""

from __future__ import annotations

from ..runtime.jit import kernel
from .kernels import OperatorKernels
from .kinds import Operator, operator_function
from .layout import COLOR, FIELD, GRAD, GRADIENT
from .node import register
from .reference import weighted_color


@kernel
def blend_combine(vs, b, k, p, o, mode):
    f = vs[b, FIELD]
    for m in range(b + 1, b + k):
        f += vs[m, FIELD]
    if mode >= GRADIENT:
        g0 = g1 = g2 = 0.0
        c0 = c1 = c2 = 0.0
        for m in range(b, b + k):
            g0 += vs[m, GRAD]
            g1 += vs[m, GRAD + 1]
            g2 += vs[m, GRAD + 2]
            c0 += vs[m, FIELD] * vs[m, COLOR]
            c1 += vs[m, FIELD] * vs[m, COLOR + 1]
            c2 += vs[m, FIELD] * vs[m, COLOR + 2]
        vs[b, GRAD], vs[b, GRAD + 1], vs[b, GRAD + 2] = g0, g1, g2
        if f > 0.0:
            vs[b, COLOR], vs[b, COLOR + 1], vs[b, COLOR + 2] = c0 / f, c1 / f, c2 / f
    vs[b, FIELD] = f


@kernel
def blend_rows(vs, b, k, p, o, nb):
    for j in range(b + 1, b + k):
        for m in range(nb):
            vs[b, m] += vs[j, m]


@register
class Blend(Operator):
    """B_1 + ... + B_n: the sum of the fields; colour weighted by the fields."""

    TYPE = "blend"
    ASSOCIATIVE = True
    MONOTONE = (1, 1)  # a sum
    SMOOTH = True
    KERNELS = OperatorKernels(combine=blend_combine, rows=blend_rows)

    def _ref(self, P, look=None):
        f, g, c = self._refs(P, look)
        return f.sum(axis=0), g.sum(axis=0), weighted_color(f, c)


blend = operator_function(
    Blend,
    """B_1 + B_2 + ... (sum).""")
