"""Controlled blend c(b_1..b_n)(B_1..B_m) (Eq. 6): only the listed pairs of children blend.

This is a reconstruction: Guy & Wyvill's blending graph (the paper's ref. [3]) expressed as a
union of pairwise blend groups: each listed pair (j, k) blends f_j + f_k, a child blends with no
one else, and the field is the max over the pairs (and over children in no pair, alone).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..jit import kernel
from .base import Node, Operator, OperatorKernels, pick, register, weighted_color
from .params import Pairs, Param


@kernel
def controlled_combine(vs, b, k, p, o, mode):
    """params: npairs, the pairs' child indices, nsingle, the single children's indices."""
    npairs = int(p[o])
    nsingle = int(p[o + 1 + 2 * npairs])
    best_f = -1.0
    bi = bj = -1
    for q in range(npairs):
        j = b + int(p[o + 1 + 2 * q])
        m = b + int(p[o + 2 + 2 * q])
        f = vs[j, 0] + vs[m, 0]
        if f > best_f:
            best_f, bi, bj = f, j, m
    for q in range(nsingle):
        j = b + int(p[o + 2 + 2 * npairs + q])
        if vs[j, 0] > best_f:
            best_f, bi, bj = vs[j, 0], j, -1
    if mode > 0:
        if bj < 0:
            g0, g1, g2 = vs[bi, 1], vs[bi, 2], vs[bi, 3]
            c0, c1, c2 = vs[bi, 4], vs[bi, 5], vs[bi, 6]
        else:
            g0, g1, g2 = vs[bi, 1] + vs[bj, 1], vs[bi, 2] + vs[bj, 2], vs[bi, 3] + vs[bj, 3]
            if best_f > 0.0:
                wi, wj = vs[bi, 0] / best_f, vs[bj, 0] / best_f
                c0 = wi * vs[bi, 4] + wj * vs[bj, 4]
                c1 = wi * vs[bi, 5] + wj * vs[bj, 5]
                c2 = wi * vs[bi, 6] + wj * vs[bj, 6]
            else:
                c0, c1, c2 = vs[bi, 4], vs[bi, 5], vs[bi, 6]
        vs[b, 1], vs[b, 2], vs[b, 3] = g0, g1, g2
        vs[b, 4], vs[b, 5], vs[b, 6] = c0, c1, c2
    vs[b, 0] = best_f


@kernel
def controlled_rows(vs, b, k, p, o, nb):
    npairs = int(p[o])
    nsingle = int(p[o + 1 + 2 * npairs])
    for m in range(nb):
        best = -1.0
        for q in range(npairs):
            best = max(best, vs[b + int(p[o + 1 + 2 * q]), m] + vs[b + int(p[o + 2 + 2 * q]), m])
        for q in range(nsingle):
            best = max(best, vs[b + int(p[o + 2 + 2 * npairs + q]), m])
        vs[b, m] = best


@register
class ControlledBlend(Operator):
    """Controlled blend (Eq. 6): each listed pair (j, k) of children blends f_j + f_k; the field
    is the max over the pairs and the unpaired children.  Zero children keep their places under
    specialisation (the pairs index them)."""

    TYPE = "controlled_blend"
    PARAMS = (Param("pairs", Pairs(), (), "pairs (j, k) of child indices that blend"),)
    ZERO_FIRST = ZERO_REST = "keep"
    KERNELS = OperatorKernels(combine=controlled_combine, rows=controlled_rows)

    def _check(self):
        m = len(self.children)
        for k, (i, j) in enumerate(self.pairs):
            if not (0 <= i < m and 0 <= j < m) or i == j:
                raise ValueError(
                    f"pairs[{k}] must be two different child indices in [0, {m}), got {[i, j]}")

    @property
    def singles(self) -> tuple[int, ...]:
        """The children in no pair."""
        paired = {i for p in self.pairs for i in p}
        return tuple(i for i in range(len(self.children)) if i not in paired)

    def op_params(self):
        flat = [v for pair in self.pairs for v in pair]
        return [len(self.pairs), *flat, len(self.singles), *self.singles]

    def _ref(self, P, look=None):
        f, g, c = self._refs(P, look)
        cand_f, cand_g, cand_c = [], [], []
        for i, j in self.pairs:
            cand_f.append(f[i] + f[j])
            cand_g.append(g[i] + g[j])
            cand_c.append(weighted_color(f[[i, j]], c[[i, j]]))
        for i in self.singles:
            cand_f.append(f[i])
            cand_g.append(g[i])
            cand_c.append(c[i])
        cf = np.stack(cand_f)
        k = np.argmax(cf, axis=0)
        return cf.max(axis=0), pick(k, np.stack(cand_g)), pick(k, np.stack(cand_c))


def controlled_blend(nodes: Sequence[Node], pairs: Sequence[Sequence[int]]) -> ControlledBlend:
    """Controlled blend, Eq. 6: only the listed pairs (i, j) of ``nodes`` blend."""
    return ControlledBlend(*nodes, pairs=pairs)
