"""Union: B_1 U ... U B_n, the maximum of the fields (CSG)."""

from __future__ import annotations

from ..jit import kernel
from . import kmath
from .base import Node, Operator, OperatorKernels, pick, register, winner


@kernel
def union_combine(vs, b, k, p, o, mode):
    kmath.select(vs, b, k, True)


@kernel
def union_bound(vs, b, k, p, o, reach):
    return kmath.select_bound(vs, b, k, reach, True)


@kernel
def union_rows(vs, b, k, p, o, nb):
    for j in range(b + 1, b + k):
        for m in range(nb):
            vs[b, m] = max(vs[b, m], vs[j, m])


@register
class Union(Operator):
    """B_1 U ... U B_n: max of the fields; colour and gradient of the winner."""

    TYPE = "union"
    LIPSCHITZ = "max"
    ASSOCIATIVE = True
    IDEMPOTENT = True
    MONOTONE = (1, 1)  # a max
    KERNELS = OperatorKernels(combine=union_combine, rows=union_rows,
                              bound=union_bound)

    def _ref(self, P, look=None):
        f, g, c = self._refs(P, look)
        i = winner(f, True)
        return f.max(axis=0), pick(i, g), pick(i, c)


def union(*nodes: Node) -> Union:
    """B_1 U B_2 U ... (max)."""
    return Union(*nodes)
