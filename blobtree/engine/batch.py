"""Field values of many points at once: cell-sorted batches, SIMD over points.

``eval_point`` runs a program one point at a time, so every instruction pays its dispatch and
its box test per point, and points in random order fetch a different cell program each time.
Here blocks of points are partitioned by grid cell (``specialize.build_grid``) with a parallel
counting sort; the points of one cell then run that cell's short program together, each
instruction looping over up to ``SUB`` points at once.  The loops have no per-point branches, so
the compiler vectorises them (numpy's error model: no division checks inside them).

The value stack holds one row of ``SUB`` values per entry.  A box test (BOX, PUSHPT, warps) skips
its subtree only when no point of the batch is inside; the other points of the batch then
evaluate the subtree exactly (a node's field is 0 outside its box), so the results equal
``eval_point``'s.  Field values only: gradients and colours take ``eval_point``.
"""

from __future__ import annotations

import numpy as np

from ..jit import kernel
from ..nodes.base import FALLOFF
from ..parallel import parallel_for, threads
from .dispatch import (
    K_BOX,
    K_OPERATOR,
    K_POPPT,
    K_PRIMITIVE,
    K_PUSHPT,
    K_WARP,
    K_ZERO,
    combine_rows,
    kind_of,
    prim_rows,
    warp_rows,
)
from .interp import outside
from .specialize import Grid, cell_of

#: Points per batch (the length of a value-stack row).
SUB = 64
#: Rows are computed in whole groups of W points, so a batch never ends in a scalar remainder
#: loop (the lanes past the batch hold stale points whose values are ignored).
W = 32


@kernel
def _any_inside(boxes, i, pts, pp, nb):
    for k in range(nb):
        if not outside(boxes, i, pts[pp, 0, k], pts[pp, 1, k], pts[pp, 2, k]):
            return True
    return False


@kernel
def _zero_row(vs, sp, nb):
    for m in range(nb):
        vs[sp, m] = 0.0


@kernel
def eval_rows(code, params, boxes, a, b, pts, nb, vs, tmp):
    """Run the program in rows a:b of code and boxes (skip targets relative to a) on the nb
    points pts[0, :, :nb] (rows x, y, z); the field is left in vs[0, :nb].  pts (depth + 1, 3,
    SUB) is the point stack of warps, vs (depth, SUB) the value stack, tmp (depth, 7) scratch for
    operators without a batch kernel."""
    n = b - a
    nw = (nb + W - 1) // W * W
    p = params
    sp = 0
    pp = 0
    i = 0
    while i < n:
        op = code[a + i, 0]
        o = code[a + i, 1]
        kind = kind_of(op)
        if kind == K_PRIMITIVE:
            prim_rows(op, int(p[o + FALLOFF]), p, o, pts, pp, vs, sp, nw)
            sp += 1
            i += 1
        elif kind == K_OPERATOR:
            k = code[a + i, 3]
            combine_rows(op, vs, sp - k, k, p, o, nw, tmp)
            sp += 1 - k
            i += 1
        elif kind == K_BOX or kind == K_PUSHPT or kind == K_WARP:
            if not _any_inside(boxes, a + i, pts, pp, nb):
                _zero_row(vs, sp, nw)
                sp += 1
                i = code[a + i, 2]
                continue
            if kind == K_PUSHPT:  # the warp's frame: an affine map of the current points
                for m in range(nb):
                    x, y, z = pts[pp, 0, m], pts[pp, 1, m], pts[pp, 2, m]
                    for r in range(3):
                        pts[pp + 1, r, m] = (p[o + 4 * r] * x + p[o + 4 * r + 1] * y
                                             + p[o + 4 * r + 2] * z + p[o + 4 * r + 3])
                pp += 1
            elif kind == K_WARP:
                warp_rows(op, p, o, pts, pp, nb)
            i += 1
        elif kind == K_POPPT:
            pp -= 1
            i += 1
        elif kind == K_ZERO:
            _zero_row(vs, sp, nw)
            sp += 1
            i += 1
        else:  # K_PAINT: colours play no part in the field
            i += 1


@kernel(nogil=True)
def _bucket_counts(t0, t1, P, lo, size, dims, cell, counts):
    """Pass 1 of the partition, for parts t0..t1 - 1 of the points (one per row of counts):
    each point's cell (-1 outside the grid), and how many of the part's points fall in each."""
    n = P.shape[0]
    nparts = counts.shape[0]
    for t in range(t0, t1):
        counts[t, :] = 0
        for j in range(t * n // nparts, (t + 1) * n // nparts):
            c = cell_of(P[j, 0], P[j, 1], P[j, 2], lo, size, dims)
            cell[j] = c
            if c >= 0:
                counts[t, c] += 1


@kernel(nogil=True)
def _bucket_scatter(t0, t1, P, cell, offsets, xyz, pos):
    """Pass 2, for parts t0..t1 - 1: copy each point to its cell's run of xyz (M, 3), recording
    where in pos."""
    n = P.shape[0]
    nparts = offsets.shape[0]
    for t in range(t0, t1):
        for j in range(t * n // nparts, (t + 1) * n // nparts):
            c = cell[j]
            if c < 0:
                pos[j] = -1
            else:
                k = offsets[t, c]
                offsets[t, c] = k + 1
                xyz[k, 0], xyz[k, 1], xyz[k, 2] = P[j, 0], P[j, 1], P[j, 2]
                pos[j] = k


@kernel(nrt=True, nogil=True)
def _eval_runs(t0, t1, start, gc, gb, params, first, xyz, depth, slab, vals):
    """Evaluate slabs t0..t1 - 1 of ``slab`` cell-sorted points of xyz (slabs, so crowded cells
    spread over the threads), each cell's run in batches of SUB."""
    m = xyz.shape[0]
    pts = np.zeros((depth + 1, 3, SUB))
    vs = np.empty((depth, SUB))
    tmp = np.empty((depth, 7))
    for t in range(t0, t1):
        s0, s1 = t * slab, min(m, (t + 1) * slab)
        c = np.searchsorted(first, s0, side="right") - 1
        s = s0
        while s < s1:
            while first[c + 1] <= s:
                c += 1
            nb = min(SUB, first[c + 1] - s, s1 - s)
            for r in range(3):
                for k in range(nb):
                    pts[0, r, k] = xyz[s + k, r]
            eval_rows(gc, params, gb, start[c], start[c + 1], pts, nb, vs, tmp)
            for k in range(nb):
                vals[s + k] = vs[0, k]
            s += nb


@kernel(nogil=True)
def _unsort(j0, j1, vals, pos, out):
    for j in range(j0, j1):
        out[j] = vals[pos[j]] if pos[j] >= 0 else 0.0


#: Points partitioned at a time (scratch: ~60 bytes per point of a block).
BLOCK = 1 << 20
#: Sorted points per evaluation task.
SLAB = 1 << 13


def field_sorted(grid: Grid, params: np.ndarray, depth: int, P: np.ndarray, out: np.ndarray
                 ) -> None:
    """Field values of the (N, 3) points P into out, through ``grid`` (program.Grid): blocks of
    points are partitioned by cell in parallel parts, evaluated cell by cell, and the values put
    back in the points' order."""
    start, gc, gb = grid.arrays
    lo, size, dims = grid.frame
    ncell = len(start) - 1
    nparts = threads()
    counts = np.empty((nparts, ncell), dtype=np.int64)
    first = np.zeros(ncell + 1, dtype=np.int64)
    m = min(len(P), BLOCK)
    cell, pos = np.empty(m, dtype=np.int32), np.empty(m, dtype=np.int32)
    xyz, vals = np.empty((m, 3)), np.empty(m)
    for a in range(0, len(P), BLOCK):
        Q = P[a:a + BLOCK]
        parallel_for(_bucket_counts, nparts, Q, lo, size, dims, cell, counts, parts=nparts)
        np.cumsum(counts.sum(axis=0), out=first[1:])
        offsets = first[:-1] + np.cumsum(counts, axis=0) - counts  # each part's place
        k = int(first[-1])
        parallel_for(_bucket_scatter, nparts, Q, cell, offsets, xyz, pos, parts=nparts)
        parallel_for(_eval_runs, (k + SLAB - 1) // SLAB, start, gc, gb, params, first, xyz[:k],
                     depth, SLAB, vals)
        parallel_for(_unsort, len(Q), vals, pos, out[a:a + BLOCK])
