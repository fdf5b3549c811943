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

from typing import TYPE_CHECKING

import numpy as np
from numba import njit, prange

from . import kernels as K
from .specialize import cell_of

if TYPE_CHECKING:
    from .compile import Grid

#: Points per batch (the length of a value-stack row).
SUB = 64
#: Rows are computed in whole groups of W points, so a batch never ends in a scalar remainder
#: loop (the lanes past the batch hold stale points whose values are ignored).
W = 32


@njit(cache=True, inline="always")
def _prim_rows(op, fid, p, o, pts, pp, vs, sp, nb):
    """Field of one primitive (opcode ``op``, falloff ``fid``) at the nb points pts[pp], into
    vs[sp]."""
    for k in range(nb):
        px, py, pz = pts[pp, 0, k], pts[pp, 1, k], pts[pp, 2, k]
        qx = p[o] * px + p[o + 1] * py + p[o + 2] * pz + p[o + 3]
        qy = p[o + 4] * px + p[o + 5] * py + p[o + 6] * pz + p[o + 7]
        qz = p[o + 8] * px + p[o + 9] * py + p[o + 10] * pz + p[o + 11]
        s = K._prim_s(op, p, o, qx, qy, qz)[0]
        f = K._fo(fid, min(s, 1.0))
        vs[sp, k] = f if s < 1.0 else 0.0


@njit(cache=True, error_model="numpy")
def _prim_batch(op, fid, p, o, pts, pp, vs, sp, nb):
    """``_prim_rows`` with the opcode as a constant, so each loop is compiled on its own (the
    compiler unswitches the loop-invariant falloff test)."""
    if op == K.OP_POINT:
        _prim_rows(K.OP_POINT, fid, p, o, pts, pp, vs, sp, nb)
    elif op == K.OP_CONE:
        _prim_rows(K.OP_CONE, fid, p, o, pts, pp, vs, sp, nb)
    elif op == K.OP_TORUS:
        _prim_rows(K.OP_TORUS, fid, p, o, pts, pp, vs, sp, nb)
    elif op == K.OP_DISC:
        _prim_rows(K.OP_DISC, fid, p, o, pts, pp, vs, sp, nb)
    else:
        _prim_rows(K.OP_CYLINDER, fid, p, o, pts, pp, vs, sp, nb)


@njit(cache=True, inline="always")
def _any_inside(boxes, i, pts, pp, nb):
    for k in range(nb):
        if not K._outside(boxes, i, pts[pp, 0, k], pts[pp, 1, k], pts[pp, 2, k]):
            return True
    return False


@njit(cache=True, inline="always")
def _zero_row(vs, sp, nb):
    for m in range(nb):
        vs[sp, m] = 0.0


@njit(cache=True, error_model="numpy")
def _combine(op, p, o, vs, b, k, nb):
    """An operator over the k rows from b, into row b (``eval_point``'s rules, field only)."""
    if op == K.OP_BLEND:
        for j in range(b + 1, b + k):
            for m in range(nb):
                vs[b, m] += vs[j, m]
    elif op == K.OP_UNION:
        for j in range(b + 1, b + k):
            for m in range(nb):
                vs[b, m] = max(vs[b, m], vs[j, m])
    elif op == K.OP_INTER:
        for j in range(b + 1, b + k):
            for m in range(nb):
                vs[b, m] = min(vs[b, m], vs[j, m])
    elif op == K.OP_DIFF:  # min of f_0 and 1 - f_i, clamped at 0
        for j in range(b + 1, b + k):
            for m in range(nb):
                vs[b, m] = min(vs[b, m], 1.0 - vs[j, m])
        for m in range(nb):
            vs[b, m] = max(vs[b, m], 0.0)
    elif op == K.OP_SUPER:  # Eq. 4 as m (sum (f / m)^n)^(1/n), m the largest child
        n = p[o]
        for m in range(nb):
            top = 0.0
            for j in range(b, b + k):
                top = max(top, vs[j, m])
            if top > 0.0:
                s = 0.0
                for j in range(b, b + k):
                    s += (vs[j, m] / top) ** n
                vs[b, m] = top * s ** (1.0 / n)
            else:
                vs[b, m] = 0.0
    else:  # OP_CBLEND (Eq. 6): max over pairs of f_j + f_k and over single children
        npairs = int(p[o])
        nsingle = int(p[o + 1 + 2 * npairs])
        for m in range(nb):
            best = -1.0
            for q in range(npairs):
                best = max(best, vs[b + int(p[o + 1 + 2 * q]), m]
                           + vs[b + int(p[o + 2 + 2 * q]), m])
            for q in range(nsingle):
                best = max(best, vs[b + int(p[o + 2 + 2 * npairs + q]), m])
            vs[b, m] = best


@njit(cache=True, error_model="numpy")
def eval_rows(code, params, boxes, a, b, pts, nb, vs, ps):
    """Run the program in rows a:b of code and boxes (skip targets relative to a) on the nb
    points pts[0, :, :nb] (rows x, y, z); the field is left in vs[0, :nb].  pts (depth + 1, 3,
    SUB) is the point stack of warps, vs (depth, SUB) the value stack, ps (1, 30) scratch for
    ``kernels._warp``."""
    n = b - a
    nw = (nb + W - 1) // W * W
    p = params
    sp = 0
    pp = 0
    i = 0
    while i < n:
        op = code[a + i, 0]
        o = code[a + i, 1]
        if op <= K.OP_CYLINDER:
            _prim_batch(op, int(p[o + 13]), p, o, pts, pp, vs, sp, nw)
            sp += 1
            i += 1
        elif op == K.OP_BOX or op == K.OP_PUSHPT or op == K.OP_BEND or op == K.OP_TWIST \
                or op == K.OP_TAPER:
            if not _any_inside(boxes, a + i, pts, pp, nb):
                _zero_row(vs, sp, nw)
                sp += 1
                i = code[a + i, 2]
                continue
            if op == K.OP_PUSHPT:  # the warp's frame: an affine map of the current points
                for m in range(nb):
                    x, y, z = pts[pp, 0, m], pts[pp, 1, m], pts[pp, 2, m]
                    for r in range(3):
                        pts[pp + 1, r, m] = (p[o + 4 * r] * x + p[o + 4 * r + 1] * y
                                             + p[o + 4 * r + 2] * z + p[o + 4 * r + 3])
                pp += 1
            elif op != K.OP_BOX:
                for m in range(nb):
                    pts[pp, 0, m], pts[pp, 1, m], pts[pp, 2, m] = K._warp(
                        op, p, o, pts[pp, 0, m], pts[pp, 1, m], pts[pp, 2, m], ps, 0, 0)
            i += 1
        elif op == K.OP_POPPT:
            pp -= 1
            i += 1
        elif op == K.OP_ZERO:
            _zero_row(vs, sp, nw)
            sp += 1
            i += 1
        elif K.is_paint(op):
            i += 1
        else:
            k = code[a + i, 3]
            _combine(op, p, o, vs, sp - k, k, nw)
            sp += 1 - k
            i += 1


@njit(parallel=True, cache=True)
def _bucket_counts(P, lo, size, dims, cell, counts):
    """Pass 1 of the partition: each point's cell (-1 outside the grid), and per part of the
    points (one per row of counts) how many fall in each cell."""
    n = P.shape[0]
    nparts = counts.shape[0]
    for t in prange(nparts):
        counts[t, :] = 0
        for j in range(t * n // nparts, (t + 1) * n // nparts):
            c = cell_of(P[j, 0], P[j, 1], P[j, 2], lo, size, dims)
            cell[j] = c
            if c >= 0:
                counts[t, c] += 1


@njit(parallel=True, cache=True)
def _bucket_scatter(P, cell, offsets, xyz, pos):
    """Pass 2: copy each point to its cell's run of xyz (M, 3), recording where in pos."""
    n = P.shape[0]
    nparts = offsets.shape[0]
    for t in prange(nparts):
        for j in range(t * n // nparts, (t + 1) * n // nparts):
            c = cell[j]
            if c < 0:
                pos[j] = -1
            else:
                k = offsets[t, c]
                offsets[t, c] = k + 1
                xyz[k, 0], xyz[k, 1], xyz[k, 2] = P[j, 0], P[j, 1], P[j, 2]
                pos[j] = k


@njit(parallel=True, cache=True)
def _eval_runs(start, gc, gb, params, first, xyz, depth, slab, vals):
    """Evaluate the cell-sorted points xyz in slabs of ``slab`` points (one slab per task, so
    crowded cells spread over the threads), each cell's run in batches of SUB."""
    m = xyz.shape[0]
    for t in prange((m + slab - 1) // slab):
        s0, s1 = t * slab, min(m, (t + 1) * slab)
        pts = np.zeros((depth + 1, 3, SUB))
        vs = np.empty((depth, SUB))
        ps = np.empty((1, 30))
        c = np.searchsorted(first, s0, side="right") - 1
        s = s0
        while s < s1:
            while first[c + 1] <= s:
                c += 1
            nb = min(SUB, first[c + 1] - s, s1 - s)
            for r in range(3):
                for k in range(nb):
                    pts[0, r, k] = xyz[s + k, r]
            eval_rows(gc, params, gb, start[c], start[c + 1], pts, nb, vs, ps)
            for k in range(nb):
                vals[s + k] = vs[0, k]
            s += nb


@njit(parallel=True, cache=True)
def _unsort(vals, pos, out):
    for j in prange(pos.shape[0]):
        out[j] = vals[pos[j]] if pos[j] >= 0 else 0.0


#: Points partitioned at a time (scratch: ~60 bytes per point of a block).
BLOCK = 1 << 20
#: Sorted points per evaluation task.
SLAB = 1 << 13


def field_sorted(grid: Grid, params: np.ndarray, depth: int, P: np.ndarray, out: np.ndarray,
                 nparts: int) -> None:
    """Field values of the (N, 3) points P into out, through ``grid`` (compile.Grid): blocks of
    points are partitioned by cell in ``nparts`` parallel parts, evaluated cell by cell, and the
    values put back in the points' order."""
    start, gc, gb = grid.arrays
    lo, size, dims = grid.frame
    ncell = len(start) - 1
    counts = np.empty((nparts, ncell), dtype=np.int64)
    first = np.zeros(ncell + 1, dtype=np.int64)
    m = min(len(P), BLOCK)
    cell, pos = np.empty(m, dtype=np.int32), np.empty(m, dtype=np.int32)
    xyz, vals = np.empty((m, 3)), np.empty(m)
    for a in range(0, len(P), BLOCK):
        Q = P[a:a + BLOCK]
        _bucket_counts(Q, lo, size, dims, cell, counts)
        np.cumsum(counts.sum(axis=0), out=first[1:])
        offsets = first[:-1] + np.cumsum(counts, axis=0) - counts  # each part's place
        k = int(first[-1])
        _bucket_scatter(Q, cell, offsets, xyz, pos)
        _eval_runs(start, gc, gb, params, first, xyz[:k], depth, SLAB, vals)
        _unsort(vals, pos[:len(Q)], out[a:a + BLOCK])
