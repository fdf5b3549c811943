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
``eval_point``'s (the ``rows`` mode of the program walk).  Gradients and colours run the point
mode's own steps point by point inside each instruction (the ``lanes`` mode): each instruction's
dispatch then serves the batch.
"""

from __future__ import annotations

import numpy as np
from numba import types

from ..nodes import kernel_math
from ..nodes.layout import (
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
)
from ..runtime.jit import kernel, linked
from ..runtime.threads import parallel_for, threads
from .dispatch import combine, combine_rows, prim_rows, warp_rows
from .point import (
    DEFAULT_GREY,
    PROGRAM,
    apply_warp,
    misses,
    nan_point,
    outside,
    point_paint,
    point_primitive,
    pop_frame,
    push_frame,
    push_zero,
)
from .specialize import Grid, Regions, cell_of
from .walk import Mode, hook, walk

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
    box, as for ``point.outside``)."""
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
    else the first point, then the others in one loop without branches, which the compiler
    vectorises (a loop stopping at the first point inside ran point by point: a seventh of the
    rows walk's time in a Murex render; most boxes hold the first point)."""
    if pp == 0:
        if misses(boxes, i, (pts[0, 0, LOWEST], pts[0, 1, LOWEST], pts[0, 2, LOWEST],
                             pts[0, 0, HIGHEST], pts[0, 1, HIGHEST], pts[0, 2, HIGHEST])):
            return False
        if not (outside(boxes, i, pts[0, 0, LOWEST], pts[0, 1, LOWEST], pts[0, 2, LOWEST])
                or outside(boxes, i, pts[0, 0, HIGHEST], pts[0, 1, HIGHEST],
                           pts[0, 2, HIGHEST])):
            return True
    if nb > 0 and not outside(boxes, i, pts[pp, 0, 0], pts[pp, 1, 0], pts[pp, 2, 0]):
        return True
    inside = 0
    for k in range(1, nb):
        inside += not outside(boxes, i, pts[pp, 0, k], pts[pp, 1, k], pts[pp, 2, k])
    return inside > 0


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
    """The value stack of :data:`eval_rows`: depth rows of BATCH values, and ``ROWS_SCRATCH``
    more for operators' batch kernels."""
    return np.empty((depth + ROWS_SCRATCH, BATCH))


@kernel(nrt=True)
def point_rows(depth):
    """The point stack of :data:`eval_rows`: for each of depth + 1 frames, rows x, y, z of BATCH
    points and two lanes more (LOWEST and HIGHEST)."""
    return np.zeros((depth + 1, 3, BATCH + 2))


@kernel(inline="always")
def _lanes(nb):
    """The lanes a row computes for nb points: whole groups of W."""
    return (nb + W - 1) // W * W


# ----- the rows mode: at = nb points, st = (pts, vs, tmp), cur = the lanes computed ------------
@hook
def _r_start(prog, at, st):
    _span(st[0], at)
    return _lanes(at)


@hook
def _r_primitive(prog, at, i, cur, pp, st, sp):
    code, p = prog[0], prog[1]
    o = code[i, OFFSET]
    prim_rows(code[i, OP], int(p[o + FALLOFF]), p, o, st[0], pp, st[1], sp, cur)


@hook
def _r_operator(prog, at, i, cur, st, b, k):
    code = prog[0]
    combine_rows(code[i, OP], st[1], b, k, prog[1], code[i, OFFSET], cur, st[2])


@hook
def _r_misses(prog, at, i, cur, pp, st):
    return not _any_inside(prog[2], i, st[0], pp, at)


@hook
def _r_zero(at, st, sp):
    _zero_row(st[1], sp, _lanes(at))


@hook
def _r_enter(prog, at, i, cur, st, pp):
    """The warp's frame: an affine map of the points one level up."""
    _push_rows(prog[1], prog[0][i, OFFSET], st[0], pp - 1, at)
    return cur


@hook
def _r_warp(prog, at, i, cur, st, pp):
    code = prog[0]
    warp_rows(code[i, OP], prog[1], code[i, OFFSET], st[0], pp, at)
    return cur


@hook
def _r_leave(prog, at, i, cur, st, top, pp):
    return cur


@hook
def _r_paint(prog, at, i, cur, st, top):
    """Colours play no part in the field."""


@hook
def _r_finish(prog, at, cur, st):
    return 0


#: A batch's rows (pts, vs, tmp), as numba types.
ROWS = types.Tuple((types.float64[:, :, ::1], types.float64[:, ::1], types.float64[:, ::1]))
#: The rows mode: a batch's fields, each instruction once for all its points.
ROWS_MODE = Mode("rows", _r_start, _r_primitive, _r_operator, _r_misses, _r_zero, _r_enter,
                 _r_warp, _r_leave, _r_paint, _r_finish)
#: ``rows_walk(prog, nb, (pts, vs, tmp))``: run the program on the nb points pts[0, :, :nb] (rows
#: x, y, z); the field is left in vs[0, :nb].  pts (:func:`point_rows`) is the point stack of
#: warps, vs (:func:`value_rows`) the value stack, tmp (depth, RESULT_COLUMNS) scratch for
#: operators without a batch kernel.
rows_walk = linked(types.int64(PROGRAM, types.int64, ROWS))(walk(ROWS_MODE))
#: :data:`rows_walk` as kernels call it.
eval_rows = rows_walk.call


# ----- the lanes mode: the point mode's work for each of nb points, st = (pts, vs, ps) --------
@hook
def _f_start(prog, at, st):
    return at


@hook
def _f_primitive(prog, at, i, cur, pp, st, sp):
    pts, vs, ps = st
    for m in range(at):
        point_primitive(prog, (pts[m, 0], pts[m, 1], pts[m, 2], SHADE), i,
                                   (pts[m, 0], pts[m, 1], pts[m, 2]), pp, (vs[m], ps[m]), sp)


@hook
def _f_operator(prog, at, i, cur, st, b, k):
    code = prog[0]
    for m in range(at):
        combine(code[i, OP], st[1][m], b, k, prog[1], code[i, OFFSET], SHADE)


@hook
def _f_misses(prog, at, i, cur, pp, st):
    pts = st[0]
    for m in range(at):
        if not outside(prog[2], i, pts[m, 0], pts[m, 1], pts[m, 2]):
            return False
    return True


@hook
def _f_zero(at, st, sp):
    for m in range(at):
        push_zero(st[1][m], sp, SHADE)


@hook
def _f_enter(prog, at, i, cur, st, pp):
    pts, _, ps = st
    o = prog[0][i, OFFSET]
    for m in range(at):
        pts[m, 0], pts[m, 1], pts[m, 2] = push_frame(prog[1], o, pts[m, 0], pts[m, 1],
                                                     pts[m, 2], ps[m], pp, SHADE)
    return cur


@hook
def _f_warp(prog, at, i, cur, st, pp):
    pts, _, ps = st
    op, o = prog[0][i, OP], prog[0][i, OFFSET]
    for m in range(at):
        pts[m, 0], pts[m, 1], pts[m, 2] = apply_warp(op, prog[1], o, pts[m, 0], pts[m, 1],
                                                     pts[m, 2], ps[m], pp, SHADE)
    return cur


@hook
def _f_leave(prog, at, i, cur, st, top, pp):
    pts, vs, ps = st
    for m in range(at):
        pts[m, 0], pts[m, 1], pts[m, 2] = pop_frame(vs[m], top, ps[m], pp, SHADE)
    return cur


@hook
def _f_paint(prog, at, i, cur, st, top):
    pts, vs, ps = st
    for m in range(at):
        point_paint(prog, (pts[m, 0], pts[m, 1], pts[m, 2], SHADE), i,
                               (pts[m, 0], pts[m, 1], pts[m, 2]), (vs[m], ps[m]), top)


#: The lanes mode: the point mode in mode SHADE (field, gradient, colour) on a batch's points,
#: each instruction dispatched once for all of them; a point outside a box the batch enters
#: evaluates the subtree to the zero it would have skipped.
LANES_MODE = Mode("lanes", _f_start, _f_primitive, _f_operator, _f_misses, _f_zero, _f_enter,
                  _f_warp, _f_leave, _f_paint, _r_finish)
#: ``lanes_walk(prog, nb, (pts, vs, ps))``: point m of pts[:nb] (nb, 3) keeps its own stacks
#: vs[m] (depth, RESULT_COLUMNS) and ps[m] (depth, POINT_COLUMNS) and its results in vs[m, 0].
lanes_walk = linked(types.int64(PROGRAM, types.int64, types.Tuple((
    types.float64[:, ::1], types.float64[:, :, ::1], types.float64[:, :, ::1]))))(
    walk(LANES_MODE))
eval_lanes = lanes_walk.call


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


@kernel(nrt=True, nogil=True)
def _eval_runs(t0, t1, regions, params, first, xyz, depth, slab, vals):
    """Evaluate slabs t0..t1 - 1 of ``slab`` cell-sorted points of xyz (slabs, so crowded cells
    spread over the threads), each cell's run in batches of BATCH: the field into vals[:, 0], or
    with vals (M, RESULT_COLUMNS) also the gradient and colour (:data:`eval_lanes`).
    ``regions``: (start, code, boxes) of ``Regions.arrays``."""
    start, gc, gb = regions
    m = xyz.shape[0]
    full = vals.shape[1] == RESULT_COLUMNS
    rows = (point_rows(depth), value_rows(depth), np.empty((depth, RESULT_COLUMNS)))
    pts, vs = rows[0], rows[1]
    lanes = BATCH if full else 0  # each point's own stacks, for eval_lanes
    each = (np.empty((lanes, 3)), np.empty((lanes, depth, RESULT_COLUMNS)),
            np.empty((lanes, depth, POINT_COLUMNS)))
    points, stacks = each[0], each[1]
    no_lips = np.empty(0)  # (regions keep no Lipschitz bounds: batches read none)
    for t in range(t0, t1):
        s0, s1 = t * slab, min(m, (t + 1) * slab)
        c = np.searchsorted(first, s0, side="right") - 1
        s = s0
        while s < s1:
            while first[c + 1] <= s:
                c += 1
            nb = min(BATCH, first[c + 1] - s, s1 - s)
            prog = (gc[start[c]:start[c + 1]], params, gb[start[c]:start[c + 1]], no_lips)
            if full:
                for k in range(nb):
                    for r in range(3):
                        points[k, r] = xyz[s + k, r]
                eval_lanes(prog, nb, each)
                for k in range(nb):
                    for r in range(RESULT_COLUMNS):
                        vals[s + k, r] = stacks[k, 0, r]
            else:
                for r in range(3):
                    for k in range(nb):
                        pts[0, r, k] = xyz[s + k, r]
                eval_rows(prog, nb, rows)
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
    parallel_for(_eval_runs, (len(xyz) + SLAB - 1) // SLAB, regions.arrays, params, first, xyz,
                 depth, SLAB, vals, grain=1)
