"""Field values of many points at once: cell-sorted batches, SIMD over points.

``eval_point`` runs a program one point at a time, so every instruction pays its dispatch and
its box test per point, and points in random order fetch a different cell program each time.
Here blocks of points are partitioned by grid cell (``Program.grid``) with a parallel counting
sort (points in cells whose program is a lone zero are answered while counting, not sorted);
the points of one cell then run that cell's short program together, each instruction looping
over up to ``BATCH`` points at once.  The loops have no per-point branches, so the compiler
vectorises them (numpy's error model: no division checks inside them).

The value stack holds one row of ``BATCH`` values per entry.  A box test (BOX, PUSHPT, warps) skips
its subtree only when no point of the batch is inside; the other points of the batch then
evaluate the subtree exactly (a node's field is 0 outside its box), so the results equal
``eval_point``'s.  Gradients and colours (:func:`eval_rows_full`) run ``eval_point``'s own steps
point by point inside each instruction: each instruction's dispatch then serves the batch.
"""

from __future__ import annotations

import numpy as np

from ..nodes import kernel_math
from ..nodes.layout import (
    ARG,
    COLOR,
    FALLOFF,
    FIELD,
    GRAD,
    OFFSET,
    OP,
    POINT_COLUMNS,
    RESULT_COLUMNS,
    ROWS_SCRATCH,
    SHADE,
    SKIP,
)
from ..runtime.jit import kernel
from ..runtime.threads import parallel_for, threads
from .dispatch import (
    K_BOX,
    K_OPERATOR,
    K_PAINT,
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
from .interp import (
    DEFAULT_GREY,
    apply_warp,
    combine,
    nan_point,
    outside,
    paint_top,
    pop_frame,
    push_frame,
    push_primitive,
    push_zero,
)
from .specialize import Grid, Regions, cell_of

#: Points per batch (the length of a value-stack row).
BATCH = 64
#: Lanes of a point level (``point_rows``) past the batch's points: at level 0, the least and
#: greatest of each coordinate over them, so that a box test can often answer for the whole
#: batch at once.
LOWEST, HIGHEST = BATCH, BATCH + 1
#: Rows are computed in whole groups of W points, so a batch never ends in a scalar remainder
#: loop (the lanes past the batch hold stale points whose values are ignored).  Small, so a
#: packet's last few rays cost few lanes (32 took 3-4% more of a whorl126 render's samples,
#: with rays below 8 evaluated one by one; the field of 2e6 points the same).
W = 8


@kernel(inline="always")
def _span(pts, nb):
    """Lanes LOWEST and HIGHEST of the batch's points (level 0 of pts): each coordinate's least
    and greatest over the nb points (-inf and inf where one is NaN: a NaN point is inside every
    box, as for ``interp.outside``)."""
    for r in range(3):
        lo, hi = np.inf, -np.inf
        nan = False
        for k in range(nb):
            v = pts[0, r, k]
            lo = min(lo, v)
            hi = max(hi, v)
            nan |= v != v
        pts[0, r, LOWEST], pts[0, r, HIGHEST] = (-np.inf, np.inf) if nan else (lo, hi)


@kernel(inline="always")
def _any_inside(boxes, i, pts, pp, nb):
    """Is any of the batch's points (at point level pp) inside instruction i's box?  At level
    0, decided from the batch's span (:func:`_span`) where the box misses it or holds it whole
    (boxes of the full program far from the batch, mostly; the frames below, whose boxes a
    specialised program has mostly kept for their overlap, are not worth spanning: measured);
    else point by point."""
    if pp == 0:
        if (pts[0, 0, HIGHEST] < boxes[i, 0] or pts[0, 1, HIGHEST] < boxes[i, 1]
                or pts[0, 2, HIGHEST] < boxes[i, 2] or pts[0, 0, LOWEST] > boxes[i, 3]
                or pts[0, 1, LOWEST] > boxes[i, 4] or pts[0, 2, LOWEST] > boxes[i, 5]):
            return False
        if not (outside(boxes, i, pts[0, 0, LOWEST], pts[0, 1, LOWEST], pts[0, 2, LOWEST])
                or outside(boxes, i, pts[0, 0, HIGHEST], pts[0, 1, HIGHEST],
                           pts[0, 2, HIGHEST])):
            return True
    for k in range(nb):
        if not outside(boxes, i, pts[pp, 0, k], pts[pp, 1, k], pts[pp, 2, k]):
            return True
    return False


@kernel
def _zero_row(vs, sp, nb):
    for m in range(nb):
        vs[sp, m] = 0.0


@kernel(inline="always")
def _push_rows(p, o, pts, pp, nb):
    """Level pp + 1 of the point stack: the 3x4 affine map at params[o:o + 12] of level pp's
    points (its coefficients read once, so the loop over the points vectorises)."""
    a = kernel_math.affine(p, o)
    for m in range(nb):
        pts[pp + 1, 0, m], pts[pp + 1, 1, m], pts[pp + 1, 2, m] = kernel_math.map_with(
            a, pts[pp, 0, m], pts[pp, 1, m], pts[pp, 2, m])


@kernel(nrt=True)
def value_rows(depth):
    """The value stack of :func:`eval_rows`: depth rows of BATCH values, and ``ROWS_SCRATCH``
    more for operators' batch kernels."""
    return np.empty((depth + ROWS_SCRATCH, BATCH))


@kernel(nrt=True)
def point_rows(depth):
    """The point stack of :func:`eval_rows`: for each of depth + 1 frames, rows x, y, z of BATCH
    points and two lanes more (LOWEST and HIGHEST)."""
    return np.zeros((depth + 1, 3, BATCH + 2))


@kernel
def eval_rows(code, params, boxes, a, b, pts, nb, vs, tmp):
    """Run the program in rows a:b of code and boxes (skip targets relative to a) on the nb
    points pts[0, :, :nb] (rows x, y, z); the field is left in vs[0, :nb].  pts
    (:func:`point_rows`) is the point stack of warps, vs (:func:`value_rows`) the value stack,
    tmp (depth, RESULT_COLUMNS) scratch for operators without a batch kernel."""
    n = b - a
    nw = (nb + W - 1) // W * W
    p = params
    sp = 0
    pp = 0
    i = 0
    _span(pts, nb)
    while i < n:
        op = code[a + i, OP]
        o = code[a + i, OFFSET]
        kind = kind_of(op)
        if kind == K_PRIMITIVE:
            prim_rows(op, int(p[o + FALLOFF]), p, o, pts, pp, vs, sp, nw)
            sp += 1
            i += 1
        elif kind == K_OPERATOR:
            k = code[a + i, ARG]
            combine_rows(op, vs, sp - k, k, p, o, nw, tmp)
            sp += 1 - k
            i += 1
        elif kind == K_BOX or kind == K_PUSHPT or kind == K_WARP:
            if not _any_inside(boxes, a + i, pts, pp, nb):
                _zero_row(vs, sp, nw)
                sp += 1
                i = code[a + i, SKIP]
                continue
            if kind == K_PUSHPT:  # the warp's frame: an affine map of the current points
                _push_rows(p, o, pts, pp, nb)
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
def _bucket_counts(t0, t1, P, lo, scale, dims, live, cell, counts, out_f):
    """Pass 1 of the partition, for parts t0..t1 - 1 of the points (one per row of counts):
    each point's cell, and how many of the part's points fall in each.  out_f holds zeros: a
    point outside the grid or in a cell whose program is a lone zero (``live`` 0) keeps its 0
    (NaN for a point with a NaN coordinate, as ``eval_point`` gives), gets cell -1 and is not
    sorted."""
    n = P.shape[0]
    nparts = counts.shape[0]
    for t in range(t0, t1):
        row = counts[t]
        row[:] = 0
        j0, j1 = t * n // nparts, (t + 1) * n // nparts
        for j in range(j0, j1):  # (vectorises: the counting, a scatter, is the next loop)
            x, y, z = P[j, 0], P[j, 1], P[j, 2]
            k, inside = cell_of(x, y, z, lo, scale, dims)
            if nan_point(x, y, z):
                out_f[j] = np.nan
            cell[j] = k if inside else -1
        for j in range(j0, j1):
            k = max(cell[j], 0)
            ok = np.int64(live[k]) * (cell[j] >= 0)  # no branch: points mix at random
            row[k] += ok
            cell[j] = k * ok - (1 - ok)


@kernel(nogil=True)
def _bucket_scatter(t0, t1, P, cell, offsets, xyz, src):
    """Pass 2, for parts t0..t1 - 1: copy each point of a live cell to its cell's run of xyz
    (M, 3), recording where it came from in src."""
    n = P.shape[0]
    nparts = offsets.shape[0]
    for t in range(t0, t1):
        for j in range(t * n // nparts, (t + 1) * n // nparts):
            c = cell[j]
            if c >= 0:
                k = offsets[t, c]
                offsets[t, c] = k + 1
                xyz[k, 0], xyz[k, 1], xyz[k, 2] = P[j, 0], P[j, 1], P[j, 2]
                src[k] = j


@kernel
def eval_rows_full(code, params, boxes, a, b, pts, nb, vs, ps):
    """``interp.eval_point`` in mode SHADE (field, gradient, colour) on the nb points pts[:nb]
    at once: rows a:b of code and boxes as in :func:`eval_rows`, each instruction dispatched once
    for all of them; point m keeps its own stacks vs[m] (depth, RESULT_COLUMNS) and ps[m]
    (depth, POINT_COLUMNS) and its results in vs[m, 0].  A point outside a box the batch enters
    evaluates the subtree to the zero it would have skipped."""
    n = b - a
    p = params
    sp = 0
    pp = 0
    i = 0
    while i < n:
        op = code[a + i, OP]
        o = code[a + i, OFFSET]
        kind = kind_of(op)
        if kind == K_PRIMITIVE:
            for m in range(nb):
                if outside(boxes, a + i, pts[m, 0], pts[m, 1], pts[m, 2]):
                    push_zero(vs[m], sp, SHADE)
                else:
                    push_primitive(op, code, a + i, p, o, pts[m, 0], pts[m, 1], pts[m, 2], SHADE,
                                   vs[m], sp)
            sp += 1
            i += 1
        elif kind == K_OPERATOR:
            k = code[a + i, ARG]
            for m in range(nb):
                combine(op, vs[m], sp - k, k, p, o, SHADE)
            sp += 1 - k
            i += 1
        elif kind == K_BOX or kind == K_PUSHPT or kind == K_WARP:
            inside = False
            for m in range(nb):
                if not outside(boxes, a + i, pts[m, 0], pts[m, 1], pts[m, 2]):
                    inside = True
                    break
            if not inside:
                for m in range(nb):
                    push_zero(vs[m], sp, SHADE)
                sp += 1
                i = code[a + i, SKIP]
                continue
            if kind == K_PUSHPT:
                pp += 1
                for m in range(nb):
                    pts[m, 0], pts[m, 1], pts[m, 2] = push_frame(p, o, pts[m, 0], pts[m, 1],
                                                                 pts[m, 2], ps[m], pp, SHADE)
            elif kind == K_WARP:
                for m in range(nb):
                    pts[m, 0], pts[m, 1], pts[m, 2] = apply_warp(op, p, o, pts[m, 0], pts[m, 1],
                                                                 pts[m, 2], ps[m], pp, SHADE)
            i += 1
        elif kind == K_POPPT:
            for m in range(nb):
                pts[m, 0], pts[m, 1], pts[m, 2] = pop_frame(vs[m], sp - 1, ps[m], pp, SHADE)
            pp -= 1
            i += 1
        elif kind == K_PAINT:
            for m in range(nb):
                paint_top(op, p, o, pts[m, 0], pts[m, 1], pts[m, 2], vs[m], sp - 1, SHADE)
            i += 1
        else:  # K_ZERO
            for m in range(nb):
                push_zero(vs[m], sp, SHADE)
            sp += 1
            i += 1


@kernel(nrt=True, nogil=True)
def _eval_runs(t0, t1, start, gc, gb, params, first, xyz, depth, slab, vals):
    """Evaluate slabs t0..t1 - 1 of ``slab`` cell-sorted points of xyz (slabs, so crowded cells
    spread over the threads), each cell's run in batches of BATCH: the field into vals[:, 0], or
    with vals (M, RESULT_COLUMNS) also the gradient and colour (:func:`eval_rows_full`)."""
    m = xyz.shape[0]
    full = vals.shape[1] == RESULT_COLUMNS
    pts = point_rows(depth)
    vs = value_rows(depth)
    tmp = np.empty((depth, RESULT_COLUMNS))
    lanes = BATCH if full else 0  # each point's own stacks, for eval_rows_full
    points = np.empty((lanes, 3))
    stacks = np.empty((lanes, depth, RESULT_COLUMNS))
    frames = np.empty((lanes, depth, POINT_COLUMNS))
    for t in range(t0, t1):
        s0, s1 = t * slab, min(m, (t + 1) * slab)
        c = np.searchsorted(first, s0, side="right") - 1
        s = s0
        while s < s1:
            while first[c + 1] <= s:
                c += 1
            nb = min(BATCH, first[c + 1] - s, s1 - s)
            if full:
                for k in range(nb):
                    for r in range(3):
                        points[k, r] = xyz[s + k, r]
                eval_rows_full(gc, params, gb, start[c], start[c + 1], points, nb, stacks,
                               frames)
                for k in range(nb):
                    for r in range(RESULT_COLUMNS):
                        vals[s + k, r] = stacks[k, 0, r]
            else:
                for r in range(3):
                    for k in range(nb):
                        pts[0, r, k] = xyz[s + k, r]
                eval_rows(gc, params, gb, start[c], start[c + 1], pts, nb, vs, tmp)
                for k in range(nb):
                    vals[s + k, 0] = vs[0, k]
            s += nb


@kernel(nogil=True)
def put_back(k0, k1, vals, src, out_f, out_g, out_c):
    """Results k0..k1 - 1 back in the points' order, vals[k] being point src[k]'s, split into
    the field, gradient and colour."""
    full = vals.shape[1] == RESULT_COLUMNS
    for k in range(k0, k1):
        j = src[k]
        out_f[j] = vals[k, FIELD]
        if full:
            for r in range(3):
                out_g[j, r] = vals[k, GRAD + r]
                out_c[j, r] = vals[k, COLOR + r]


#: Points partitioned at a time (scratch: 40 bytes per point of a block, 88 with gradients).
PARTITION_BLOCK = 1 << 20
#: Sorted points per evaluation task.
SLAB = 1 << 13


def eval_sorted(grid: Grid, params: np.ndarray, depth: int, P: np.ndarray, out_f: np.ndarray,
                out_g: np.ndarray | None = None, out_c: np.ndarray | None = None) -> None:
    """Field values of the (N, 3) points P into out_f (and, given out_g and out_c (N, 3), the
    gradients and colours), through ``grid`` (program.Grid): blocks of points are partitioned
    by cell in parallel parts, evaluated cell by cell, and the results put back in the points'
    order.  Points in cells whose program is a lone zero are answered while partitioning."""
    lo, scale, dims = grid.frame
    live = grid.live
    ncell = len(live)
    nparts = threads()
    counts = np.empty((nparts, ncell), dtype=np.int64)
    first = np.zeros(ncell + 1, dtype=np.int64)
    m = min(len(P), PARTITION_BLOCK)
    cell, src = np.empty(m, dtype=np.int32), np.empty(m, dtype=np.int32)
    xyz, vals = np.empty((m, 3)), np.empty((m, 1 if out_g is None else RESULT_COLUMNS))
    if out_g is None:
        out_g = out_c = np.empty((0, 3))
    for a in range(0, len(P), PARTITION_BLOCK):
        end = a + PARTITION_BLOCK
        Q = P[a:end]
        f, g, c = out_f[a:end], out_g[a:end], out_c[a:end]
        # A zero field's (final where no cell holds the point): written on this thread, since
        # two threads touching fresh pages at once can take ten times as long (docs/engine.md).
        f[:], g[:], c[:] = 0.0, 0.0, DEFAULT_GREY
        parallel_for(_bucket_counts, nparts, Q, lo, scale, dims, live, cell, counts, f,
                     parts=nparts)
        if len(g):  # a NaN point's gradient is NaN too (its field is; no cell holds it)
            g[np.isnan(f)] = np.nan
        np.cumsum(counts.sum(axis=0), out=first[1:])
        offsets = first[:-1] + np.cumsum(counts, axis=0) - counts  # each part's place
        k = int(first[-1])
        parallel_for(_bucket_scatter, nparts, Q, cell, offsets, xyz, src, parts=nparts)
        eval_grouped(grid, params, depth, xyz[:k], first, vals)
        parallel_for(put_back, k, vals, src, f, g, c)


def eval_grouped(regions: Regions, params: np.ndarray, depth: int, xyz: np.ndarray,
                 first: np.ndarray, vals: np.ndarray) -> None:
    """Values of the (M, 3) points xyz, grouped by region (xyz[first[r]:first[r + 1]] lie in
    region r), into vals (M, 1) (the field) or (M, 7) (with gradients and colours), each group
    run by its region's program in slabs across the threads."""
    start, gc, gb = regions.arrays
    parallel_for(_eval_runs, (len(xyz) + SLAB - 1) // SLAB, start, gc, gb, params, first, xyz,
                 depth, SLAB, vals, grain=1)
