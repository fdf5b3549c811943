"""Intersection: B_1 n ... n B_n, the minimum of the fields (CSG)."""

from __future__ import annotations

from .. import geometry as geo
from ..runtime.jit import kernel
from . import kernel_math
from .kernels import OperatorKernels
from .kinds import Operator, operator_function
from .node import register
from .reference import pick, winner


@kernel
def intersection_combine(vs, b, k, p, o, mode):
    kernel_math.select(vs, b, k, False)


@kernel
def intersection_bound(vs, b, k, p, o, reach):
    return kernel_math.select_bound(vs, b, k, reach, False)


@kernel
def intersection_rows(vs, b, k, p, o, nb):
    for j in range(b + 1, b + k):
        for m in range(nb):
            vs[b, m] = min(vs[b, m], vs[j, m])


@register
class Intersection(Operator):
    """B_1 n ... n B_n: min of the fields; colour and gradient of the winner."""

    TYPE = "intersection"
    ZERO_FIRST = ZERO_REST = "kill"
    LIPSCHITZ = "max"
    IDEMPOTENT = True
    MONOTONE = (1, 1)  # a min
    KERNELS = OperatorKernels(combine=intersection_combine, rows=intersection_rows,
                              bound=intersection_bound)

    def _ref(self, P, look=None):
        f, g, c = self._refs(P, look)
        i = winner(f, False)
        return f.min(axis=0), pick(i, g), pick(i, c)

    def combine_boxes(self, boxes):
        return geo.box_intersection(boxes)


intersection = operator_function(
    Intersection,
    """B_1 n B_2 n ... (min).""")
