"""Intersection: B_1 n ... n B_n, the minimum of the fields (CSG)."""

from __future__ import annotations

from .. import geometry as geo
from ..jit import kernel
from . import kmath
from .base import Node, Operator, OperatorKernels, pick, register, winner


@kernel
def intersection_combine(vs, b, k, p, o, mode):
    kmath.select(vs, b, k, False)


@kernel
def intersection_bound(vs, b, k, p, o, reach):
    return kmath.select_bound(vs, b, k, reach, False)


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


def intersection(*nodes: Node) -> Intersection:
    """B_1 n B_2 n ... (min)."""
    return Intersection(*nodes)
