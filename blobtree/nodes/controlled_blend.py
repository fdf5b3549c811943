"""Controlled blend c(b_1..b_n)(B_1..B_m) (Eq. 6): only the listed groups of children blend.

This is a reconstruction: Guy & Wyvill's blending graph (the paper's ref. [3]) expressed as a
union of blend groups.  The paper's form lists pairs (j, k), each blending f_j + f_k.  Beyond the
paper (its Section 4: "the blends can only be specified between two objects at once, and super
elliptic blends are not allowed"), a group may hold any number of children and blend them by
Ricci's super-elliptic blend of its own exponent n (Eq. 4; n = 1 is the plain sum).  The field is
the max over the groups (and over children in no group, alone).
"""

from __future__ import annotations

import math

import numpy as np

from ..checks import Number
from ..runtime.jit import kernel
from .kernel_math import field_range, power, root
from .kernels import OperatorKernels
from .kinds import Operator, operator_function
from .layout import BOUND, COLOR, FIELD, GRAD, GRADIENT
from .node import register
from .params import LARGEST_N, Groups, Pairs, Param
from .reference import pick, weighted_color


@kernel
def group_value(vs, b, p, q, size, n, col):
    """The super-elliptic blend (Eq. 4) of the children listed at p[q:q + size], on column col
    of the value stack (0: the field); n = 1 is their plain sum, in list order."""
    if n == 1.0:
        s = 0.0
        for i in range(size):
            s += vs[b + int(p[q + i]), col]
        return s
    m = 0.0
    for i in range(size):
        m = max(m, vs[b + int(p[q + i]), col])
    if m <= 0.0:
        return 0.0
    s = 0.0
    for i in range(size):
        s += power(vs[b + int(p[q + i]), col] / m, n)
    return m * root(s, n)


@kernel
def controlled_combine(vs, b, k, p, o, mode):
    """params: npairs and the pairs' child indices; ngroups and per group its exponent n, size
    and child indices; nsingle and the single children's indices.  The pairs come first, read
    directly, with no group bookkeeping (most of the shell's body is pairs).  A winning group's
    gradient is sum (f_i / F)^(n - 1) grad f_i, its colour weighted by f_i^n."""
    npairs = int(p[o])
    best_f = -1.0
    bi = bj = -1  # the winning pair, or a single child (bj = -1)
    best_q = -1  # or the winning group's offset in p
    for q in range(npairs):
        j = b + int(p[o + 1 + 2 * q])
        m = b + int(p[o + 2 + 2 * q])
        f = vs[j, FIELD] + vs[m, FIELD]
        if f > best_f:
            best_f, bi, bj = f, j, m
    q = o + 1 + 2 * npairs
    ngroups = int(p[q])
    q += 1
    for _ in range(ngroups):
        size = int(p[q + 1])
        f = group_value(vs, b, p, q + 2, size, p[q], 0)
        if f > best_f:
            best_f, best_q = f, q
        q += 2 + size
    for i in range(int(p[q])):
        j = b + int(p[q + 1 + i])
        if vs[j, FIELD] > best_f:
            best_f, bi, bj, best_q = vs[j, FIELD], j, -1, -1
    if mode >= GRADIENT:
        if best_q >= 0:
            _group_gradient_colour(vs, b, p, best_q, best_f)
        elif bj < 0:
            for c in range(1, 7):
                vs[b, c] = vs[bi, c]
        else:
            vs[b, GRAD] = vs[bi, GRAD] + vs[bj, GRAD]
            vs[b, GRAD + 1] = vs[bi, GRAD + 1] + vs[bj, GRAD + 1]
            vs[b, GRAD + 2] = vs[bi, GRAD + 2] + vs[bj, GRAD + 2]
            if best_f > 0.0:
                wi, wj = vs[bi, FIELD] / best_f, vs[bj, FIELD] / best_f
                for c in range(COLOR, COLOR + 3):
                    vs[b, c] = wi * vs[bi, c] + wj * vs[bj, c]
            else:
                for c in range(COLOR, COLOR + 3):
                    vs[b, c] = vs[bi, c]
    vs[b, FIELD] = best_f


@kernel
def _group_gradient_colour(vs, b, p, q, f):
    """Gradient and colour of the group at p[q] (exponent, size, members) whose field is f."""
    n = p[q]
    size = int(p[q + 1])
    g0 = g1 = g2 = c0 = c1 = c2 = 0.0
    wsum = 0.0
    for i in range(size):
        j = b + int(p[q + 2 + i])
        w = 1.0 if n == 1.0 or f <= 0.0 else (vs[j, FIELD] / f) ** (n - 1.0)
        g0 += w * vs[j, GRAD]
        g1 += w * vs[j, GRAD + 1]
        g2 += w * vs[j, GRAD + 2]
        cw = vs[j, FIELD] * w
        c0 += cw * vs[j, COLOR]
        c1 += cw * vs[j, COLOR + 1]
        c2 += cw * vs[j, COLOR + 2]
        wsum += cw
    if wsum > 0.0:
        c0, c1, c2 = c0 / wsum, c1 / wsum, c2 / wsum
    else:
        j = b + int(p[q + 2])
        c0, c1, c2 = vs[j, COLOR], vs[j, COLOR + 1], vs[j, COLOR + 2]
    vs[b, GRAD], vs[b, GRAD + 1], vs[b, GRAD + 2] = g0, g1, g2
    vs[b, COLOR], vs[b, COLOR + 1], vs[b, COLOR + 2] = c0, c1, c2


@kernel
def _candidate(vs, b, p, q, size, n, reach, kind):
    """One candidate of the max over the region (kind 0: pair at p[q:q + 2], 1: group with its
    exponent n, size and members at p[q:q + size], 2: the single child at p[q]): its lowest
    and highest field there (from each member's range, :func:`field_range`) and its
    gradient bound."""
    low = high = bound = top = 0.0
    for i in range(size):
        j = b + int(p[q + i])
        lo_j, hi_j = field_range(vs, j, reach)
        top = max(top, lo_j)
        low += lo_j
        high += max(hi_j, 0.0)
        bound += vs[j, BOUND]
    if kind == 1 and n != 1.0:  # super-elliptic: at least its largest member, weights as Eq. 4's
        low = top
        if top > 0.0:
            bound = 0.0
            for i in range(size):
                j = b + int(p[q + i])
                hi_j = max(field_range(vs, j, reach)[1], 0.0)
                bound += min(1.0, (hi_j / top) ** (n - 1.0)) * vs[j, BOUND]
    return low, high, bound


@kernel
def controlled_bound(vs, b, k, p, o, reach):
    """The field is a max over candidates (pairs, groups, single children): a candidate whose
    highest stays below another's lowest over the region never wins there, and the bound is
    the largest of the others' (each the sum of its members', Eq. 4's weights for a group)."""
    best_low = -math.inf
    for rnd in range(2):  # first the best lowest, then the bound over the candidates left
        bound = 0.0
        npairs = int(p[o])
        for q in range(npairs):
            lo, hi, lip = _candidate(vs, b, p, o + 1 + 2 * q, 2, 1.0, reach, 0)
            best_low = max(best_low, lo)
            if rnd == 1 and hi >= best_low:
                bound = max(bound, lip)
        q = o + 1 + 2 * npairs
        ngroups = int(p[q])
        q += 1
        for _ in range(ngroups):
            size = int(p[q + 1])
            lo, hi, lip = _candidate(vs, b, p, q + 2, size, p[q], reach, 1)
            best_low = max(best_low, lo)
            if rnd == 1 and hi >= best_low:
                bound = max(bound, lip)
            q += 2 + size
        for i in range(int(p[q])):
            lo, hi, lip = _candidate(vs, b, p, q + 1 + i, 1, 1.0, reach, 2)
            best_low = max(best_low, lo)
            if rnd == 1 and hi >= best_low:
                bound = max(bound, lip)
    return bound, 0.0, 0.0


@kernel
def controlled_rows(vs, b, k, p, o, nb):
    """``controlled_combine``'s field over a batch, each step a loop over the points that
    vectorises: the best so far in a scratch row, each pair's sum and each plain-sum group's
    (n = 1, in list order: the values of ``group_value``) taken for all points at once; a group
    of another exponent goes point by point."""
    best, acc = vs[-2], vs[-1]  # scratch (ROWS_SCRATCH)
    npairs = int(p[o])
    for m in range(nb):
        best[m] = -1.0
    for q in range(npairs):
        x, y = vs[b + int(p[o + 1 + 2 * q])], vs[b + int(p[o + 2 + 2 * q])]
        for m in range(nb):
            best[m] = max(best[m], x[m] + y[m])
    q = o + 1 + 2 * npairs
    ngroups = int(p[q])
    q += 1
    for _ in range(ngroups):
        n, size = p[q], int(p[q + 1])
        if n == 1.0:
            for m in range(nb):
                acc[m] = 0.0
            for i in range(size):
                x = vs[b + int(p[q + 2 + i])]
                for m in range(nb):
                    acc[m] += x[m]
            for m in range(nb):
                best[m] = max(best[m], acc[m])
        else:
            for m in range(nb):
                best[m] = max(best[m], group_value(vs, b, p, q + 2, size, n, m))
        q += 2 + size
    for i in range(int(p[q])):
        x = vs[b + int(p[q + 1 + i])]
        for m in range(nb):
            best[m] = max(best[m], x[m])
    for m in range(nb):
        vs[b, m] = best[m]


@register
class ControlledBlend(Operator):
    """Controlled blend (Eq. 6): each listed pair (j, k) of children blends f_j + f_k, and each
    listed group blends its children by the super-elliptic blend (Eq. 4) of its exponent (the
    node's ``n`` unless the group gives its own); the field is the max over the pairs, the groups
    and the children in neither.  Zero children keep their places under specialisation (the
    lists index them).  Each group's gradient is at most the sum of its children's, so the
    Lipschitz bounds add."""

    TYPE = "controlled_blend"
    PARAMS = (Param("pairs", Pairs(), (), "pairs (j, k) of child indices that blend"),
              Param("groups", Groups(), (),
                    "groups of child indices that blend, each [indices] or [[indices], n]",
                    since=3),
              Param("n", Number(lo=1.0, hi=LARGEST_N, sample=(1.0, 8.0)), 1.0,
                    "super-elliptic exponent of the groups that give none: 1 = sum", since=3))
    ZERO_FIRST = ZERO_REST = "keep"
    MONOTONE = (1, 1)  # a max of sums and n-norms
    KERNELS = OperatorKernels(combine=controlled_combine, rows=controlled_rows,
                              bound=controlled_bound)

    def _check(self):
        m = len(self.children)
        for k, (i, j) in enumerate(self.pairs):
            if not (0 <= i < m and 0 <= j < m) or i == j:
                raise ValueError(
                    f"pairs[{k}] must be two different child indices in [0, {m}), got {[i, j]}")
        for k, (members, _) in enumerate(self.groups):
            if not all(0 <= i < m for i in members) or len(set(members)) != len(members):
                raise ValueError(f"groups[{k}] must be different child indices in [0, {m}), "
                                 f"got {list(members)}")

    @property
    def blend_groups(self) -> tuple[tuple[tuple[int, ...], float], ...]:
        """Every group with its exponent: the pairs (n = 1), then the groups."""
        return (tuple((pair, 1.0) for pair in self.pairs) + self._groups)

    @property
    def _groups(self) -> tuple[tuple[tuple[int, ...], float], ...]:
        """The groups with their exponents (the node's n where a group gives none)."""
        return tuple((g, self.n if n is None else n) for g, n in self.groups)

    @property
    def singles(self) -> tuple[int, ...]:
        """The children in no pair or group."""
        grouped = {i for g, _ in self.blend_groups for i in g}
        return tuple(i for i in range(len(self.children)) if i not in grouped)

    def op_params(self):
        out = [len(self.pairs), *(v for pair in self.pairs for v in pair), len(self._groups)]
        for members, n in self._groups:
            out += [n, len(members), *members]
        return [*out, len(self.singles), *self.singles]

    def _ref(self, P, look=None):
        f, g, c = self._refs(P, look)
        cand_f, cand_g, cand_c = [], [], []
        for members, n in self.blend_groups:
            fm, gm, cm = f[list(members)], g[list(members)], c[list(members)]
            if n == 1.0:
                value = fm.sum(axis=0)
                cand_g.append(gm.sum(axis=0))
                cand_c.append(weighted_color(fm, cm))
            else:
                top = fm.max(axis=0)
                safe = np.where(top > 0.0, top, 1.0)
                value = np.where(top > 0.0, top * ((fm / safe) ** n).sum(axis=0) ** (1.0 / n),
                                 0.0)
                ratio = fm / np.where(value > 0.0, value, 1.0)
                w = np.where(value > 0.0, ratio ** (n - 1.0), 1.0)
                cand_g.append((w[:, :, None] * gm).sum(axis=0))
                cand_c.append(weighted_color(fm * w, cm))
            cand_f.append(value)
        for i in self.singles:
            cand_f.append(f[i])
            cand_g.append(g[i])
            cand_c.append(c[i])
        cf = np.stack(cand_f)
        k = np.argmax(cf, axis=0)
        return cf.max(axis=0), pick(k, np.stack(cand_g)), pick(k, np.stack(cand_c))


controlled_blend = operator_function(
    ControlledBlend,
    """Controlled blend, Eq. 6: only the listed pairs (i, j) of the children blend (f_i + f_j), and
    the listed groups, each by the super-elliptic blend (Eq. 4) of exponent ``n`` or its own:
    ``groups=[(0, 1, 2), ((2, 3), 4.0)]``.  The children may come as one list.""")
