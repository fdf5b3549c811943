"""Union: B_1 U ... U B_n, the maximum of the fields (CSG)."""

from __future__ import annotations

from ..runtime.jit import kernel
from . import kernel_math
from .kernels import OperatorKernels
from .kinds import Operator, operator_function
from .node import register
from .reference import pick, winner


@kernel
def union_combine(vs, b, k, p, o, mode):
    kernel_math.select(vs, b, k, True)


@kernel
def union_bound(vs, b, k, p, o, reach):
    return kernel_math.select_bound(vs, b, k, reach, True)


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


union = operator_function(
    Union,
    """B_1 U B_2 U ... (max).""")
