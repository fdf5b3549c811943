"""Numba kernels of the polygonizer: marching cubes by contour tracing on the cube faces.

No case table is stored or copied.  For each cell the surface polygon(s) are traced at run time
from the cell's six faces, the construction behind every face-consistent marching-cubes table
(Lorensen & Cline 1987; the face ambiguity is resolved by the asymptotic decider of Nielson &
Hamann, "The asymptotic decider", IEEE Visualization 1991):

* On each face, seen from outside the cube with its corners in counter-clockwise order, every
  edge whose first corner is inside and second outside ("in->out") starts a contour segment that
  keeps the inside on its left; it ends at an "out->in" edge of the same face.  With two such
  pairs (an ambiguous face) the bilinear saddle decides whether the inside corners connect.
* Every crossing cube edge lies on two faces and is traversed in opposite directions by them,
  so it starts exactly one segment and ends exactly one: the segments form disjoint loops.
* Each loop is fanned into triangles.  The decision on a face depends only on the face's four
  samples, so both cells sharing a face draw the same segments in opposite directions: the
  union of all cells is a closed, consistently oriented 2-manifold (given no sample equals the
  iso-value exactly; samples equal to it count as inside, as the field convention says).

Vertices are keyed on lattice edges, ``key = point_index * 3 + axis``, so cells and blocks that
share an edge share the vertex.
"""

from __future__ import annotations

import itertools

import numpy as np

from ..runtime.jit import cached
from ..runtime.threads import parallel_for, parallel_map

# --- cell geometry, generated (corner c = x + 2y + 4z) ----------------------------------------

_CORNERS = np.array([[c & 1, (c >> 1) & 1, (c >> 2) & 1] for c in range(8)], dtype=np.int64)


def _edge_of(c0: int, c1: int) -> int:
    """Cell edge id (axis * 4 + index of the other two coordinates) joining two corners."""
    d = c0 ^ c1
    axis = {1: 0, 2: 1, 4: 2}[d]
    lo = min(c0, c1)
    others = [_CORNERS[lo][a] for a in range(3) if a != axis]
    return axis * 4 + others[0] + 2 * others[1]


def _face_tables() -> tuple[np.ndarray, np.ndarray]:
    """Corners (6, 4) of each face counter-clockwise seen from outside, and edges (6, 4) with edge
    k joining corners k and k+1."""
    corners, edges = [], []
    for axis, side in itertools.product(range(3), (0, 1)):
        normal = np.zeros(3)
        normal[axis] = 1.0 if side else -1.0
        on_face = [c for c in range(8) if _CORNERS[c][axis] == side]
        centre = _CORNERS[on_face].mean(axis=0)
        u = np.roll(normal, 1)  # a direction in the face plane
        v = np.cross(normal, u)
        ang = [np.arctan2((_CORNERS[c] - centre) @ v, (_CORNERS[c] - centre) @ u) for c in on_face]
        ring = [on_face[i] for i in np.argsort(ang)]  # counter-clockwise about the outward normal
        corners.append(ring)
        edges.append([_edge_of(ring[k], ring[(k + 1) % 4]) for k in range(4)])
    return np.array(corners, dtype=np.int64), np.array(edges, dtype=np.int64)


FACE_CORNERS, FACE_EDGES = _face_tables()
#: axis and lower-corner lattice offset of each of the 12 cell edges
EDGE_AXIS = np.array([e // 4 for e in range(12)], dtype=np.int64)
EDGE_OFFSET = np.zeros((12, 3), dtype=np.int64)
for _c0, _c1 in itertools.combinations(range(8), 2):
    if bin(_c0 ^ _c1).count("1") == 1:
        EDGE_OFFSET[_edge_of(_c0, _c1)] = _CORNERS[min(_c0, _c1)]
#: NO_DIAGONAL[a, b]: cell edges a and b lie on a common lower face (x, y or z = 0) of the cell.
#: A diagonal of a loop joining two edges of one face could also be drawn by the cell across
#: that face, and four triangles would share it.  Such diagonals are left to the cell below the
#: face (for which it is an upper face); diagonals joining edges with no common face belong to
#: one cell only.
NO_DIAGONAL = np.zeros((12, 12), dtype=np.bool_)
for _f in range(6):
    if _f % 2 == 0:  # the faces are ordered (axis, side): even ones are at side 0
        NO_DIAGONAL[np.ix_(FACE_EDGES[_f], FACE_EDGES[_f])] = True


@cached(inline="always")
def _fan_apex(loop, start, n):
    """Position in the loop of a fan apex with no diagonal in :data:`NO_DIAGONAL`, or -1 (the
    loop then gets a vertex of its own at its centre, and a fan from there)."""
    for a in range(n):
        ok = True
        for r in range(2, n - 1):
            if NO_DIAGONAL[loop[start + a], loop[start + (a + r) % n]]:
                ok = False
                break
        if ok:
            return a
    return -1


@cached(inline="always")
def _cell_loops(v, iso, nxt, loops, loop_len):
    """Trace the contour loops of one cell with corner values ``v`` (8,).

    Writes the loops' cell edges into ``loops`` (12,) back to back and their lengths into
    ``loop_len`` (4,); returns the number of loops.
    """
    for e in range(12):
        nxt[e] = -1
    for f in range(6):
        n_io = 0
        k_io0 = -1
        k_io1 = -1
        k_oi = -1
        for k in range(4):
            a = v[FACE_CORNERS[f, k]] >= iso
            b = v[FACE_CORNERS[f, (k + 1) % 4]] >= iso
            if a and not b:
                if n_io == 0:
                    k_io0 = k
                else:
                    k_io1 = k
                n_io += 1
            elif b and not a:
                k_oi = k
        if n_io == 1:
            nxt[FACE_EDGES[f, k_io0]] = FACE_EDGES[f, k_oi]
        elif n_io == 2:
            # asymptotic decider: the saddle of the bilinear interpolant is inside iff the
            # product of the inside diagonal exceeds that of the outside diagonal.
            d0 = (v[FACE_CORNERS[f, 0]] - iso) * (v[FACE_CORNERS[f, 2]] - iso)
            d1 = (v[FACE_CORNERS[f, 1]] - iso) * (v[FACE_CORNERS[f, 3]] - iso)
            if v[FACE_CORNERS[f, 0]] >= iso:
                connect = d0 > d1
            else:
                connect = d1 > d0
            step = 1 if connect else 3
            for k in (k_io0, k_io1):
                nxt[FACE_EDGES[f, k]] = FACE_EDGES[f, (k + step) % 4]
    n_loops = 0
    pos = 0
    for e0 in range(12):
        if nxt[e0] < 0:
            continue
        start = pos
        e = e0
        while nxt[e] >= 0:
            loops[pos] = e
            pos += 1
            n = nxt[e]
            nxt[e] = -1
            e = n
        loop_len[n_loops] = pos - start
        n_loops += 1
    return n_loops


@cached(inline="always")
def _load_cell(values, blk, i, j, k, iso, v):
    """Corner values of cell (i, j, k) of block ``blk`` into ``v``; True if the surface crosses."""
    n_in = 0
    for c in range(8):
        v[c] = values[blk, i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2)]
        n_in += v[c] >= iso
    return 0 < n_in < 8


@cached(inline="always")
def _edge_slot(e, i, j, k, m):
    """Index of cell (i, j, k)'s edge ``e`` among the block's lattice edges (point * 3 + axis)."""
    return (
        ((i + EDGE_OFFSET[e, 0]) * m + j + EDGE_OFFSET[e, 1]) * m + k + EDGE_OFFSET[e, 2]
    ) * 3 + (EDGE_AXIS[e])


def block_triangles(values, origins, box_start, boxes, fine: int, dims, iso: float):
    """Contour the cells of the listed boxes of a batch of blocks.

    ``values`` (K, b+1, b+1, b+1): samples of each block; ``origins`` (K, 3): each block's first
    lattice point; ``boxes`` (B, 3): local coordinates of the first cell of each box of
    ``fine``^3 cells to contour, those of block q at ``box_start[q]:box_start[q + 1]``;
    ``dims`` (3,): lattice points per axis (for the keys).  Returns

    * ``keys`` (V,): lattice-edge keys of the edge vertices, each once, ``f0``, ``f1`` (V,) the
      samples at each edge's ends;
    * ``centres`` (C, 3): lattice coordinates of the extra vertices at the centre of loops that
      admit no safe fan (see :func:`_fan_apex`; rare, only at ambiguous faces);
    * ``tris`` (T, 3): vertex indices (int32 unless there are 2^31 vertices), the edge vertices
      first, then the centres; oriented outward (counter-clockwise seen from the side of lower
      field);
    * ``vertex_start`` (K + 1,): the edge vertices come block by block, block q's at
      ``vertex_start[q]:vertex_start[q + 1]`` (a vertex on a face between blocks goes with the
      first).
    """
    # (a few parts per thread: each part has a fixed cost, and 64 parts took 1.3-1.7x the time
    # of 8 on whorl126 at 256)
    parts = parallel_map(_fill_part, len(values), values, origins, box_start, boxes, fine, dims,
                         iso)
    if not parts:
        z = np.zeros(0)
        return (np.zeros(0, dtype=np.int64), z, z, np.zeros((0, 3)),
                np.zeros((0, 3), dtype=np.int32), np.zeros(len(values) + 1, dtype=np.int64))
    keys, f0, f1, shared, centres = (np.concatenate([part[k] for part in parts])
                                     for k in range(5))
    tris = np.concatenate([part[5] for part in parts])
    # where each part's triangles, vertices and centres start (each part numbered from 0)
    t_base, v_base, c_base = (np.cumsum([0] + [len(part[k]) for part in parts])
                              for k in (5, 0, 4))
    first, index = _weld(keys, shared)
    out = np.empty(tris.shape, dtype=np.int32 if len(first) + len(centres) < 2**31 else np.int64)
    parallel_for(_renumber, len(tris), tris, t_base, v_base, c_base, index, len(first), out)
    # each block's first vertex before welding, then among the vertices kept
    block_v = np.concatenate([part[6][:-1] + base
                              for part, base in zip(parts, v_base[:-1], strict=True)]
                             + [v_base[-1:]])
    return (keys[first], f0[first], f1[first], centres, out,
            np.searchsorted(first, block_v))


def compile_triangles(block: int, fine: int, iso: float) -> None:
    """Compile :func:`block_triangles`' kernels by contouring a ball in one block of
    ``block``^3 cells (a partner process's unit, ``runtime.partner``), with the argument types
    the polygonizer gives them."""
    m = block + 1
    q = np.indices((m, m, m)).reshape(3, -1).T - block / 2.0
    values = (1.0 - (q * q).sum(axis=1) / (0.4 * block) ** 2).reshape(1, m, m, m)
    boxes = np.ascontiguousarray(np.indices((block // fine,) * 3).reshape(3, -1).T * fine)
    block_triangles(values, np.zeros((1, 3), dtype=np.int64), np.array([0, len(boxes)]), boxes,
                    fine, np.full(3, m, dtype=np.int64), iso)


def _weld(keys: np.ndarray, shared: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The vertices to keep (the first of each key) and each vertex's index among them.  Each
    block lists an edge once, so only edges on block faces (``shared``) can repeat: only those
    are sorted."""
    candidates = np.flatnonzero(shared)
    order = candidates[np.argsort(keys[candidates], kind="stable")]
    repeat = np.zeros(len(order), dtype=bool)
    np.equal(keys[order[1:]], keys[order[:-1]], out=repeat[1:])
    # each repeat's first occurrence: the last place in ``order`` where a new key began
    head = order[np.maximum.accumulate(np.where(repeat, 0, np.arange(len(order))))]
    keep = np.ones(len(keys), dtype=bool)
    keep[order[repeat]] = False
    index = np.cumsum(keep) - 1
    index[order[repeat]] = index[head[repeat]]
    return np.flatnonzero(keep), index


@cached(nogil=True)
def _renumber(start, stop, tris, t_base, v_base, c_base, index, nverts, out):
    """Triangles start..stop - 1 (part q's from ``t_base[q]``, numbered within the part) on the
    welded vertices: part q's edge vertex i becomes ``index[v_base[q] + i]``, its centre
    ``-1 - i`` becomes ``nverts + c_base[q] + i``."""
    q = np.searchsorted(t_base, start, side="right") - 1
    for t in range(start, stop):
        while t >= t_base[q + 1]:
            q += 1
        for c in range(3):
            v = tris[t, c]
            out[t, c] = index[v_base[q] + v] if v >= 0 else nverts + c_base[q] - 1 - v


@cached(nogil=True)
def _fill_part(start, stop, values, origins, box_start, boxes, fine, dims, iso):
    """The work of :func:`block_triangles` for blocks start..stop - 1 in one pass, into arrays
    grown as needed: (keys, f0, f1, shared, centres, tris, block_v), numbered from 0 within the
    part (``shared``: whether each edge lies on a face of its block, so another block may list
    it too; ``block_v``: where each block's vertices start, and their end)."""
    m = values.shape[1]
    vid = np.full(m * m * m * 3, -1, dtype=np.int64)
    touched = np.empty(m * m * m * 3, dtype=np.int64)
    scratch = np.empty(12 + 12 + 4 + 13, dtype=np.int64)
    v = np.empty(8)
    cells = fine * fine * fine  # per box
    guess = (box_start[stop] - box_start[start]) * cells + 16  # about one vertex per cell
    keys = np.empty(guess, dtype=np.int64)
    f0 = np.empty(guess)
    f1 = np.empty(guess)
    shared = np.empty(guess, dtype=np.bool_)
    centres = np.empty((16, 3))
    tris = np.empty((2 * guess, 3), dtype=np.int64)
    block_v = np.empty(stop - start + 1, dtype=np.int64)
    ov = oc = ot = 0
    for blk in range(start, stop):
        block_v[blk - start] = ov
        most = 12 * cells * (box_start[blk + 1] - box_start[blk])  # a cell adds 12 at most
        if ov + most > keys.shape[0]:
            size = max(2 * keys.shape[0], ov + most)
            keys, f0, f1, shared = (_grown(keys, size), _grown(f0, size), _grown(f1, size),
                                    _grown(shared, size))
        if ot + most > tris.shape[0]:
            tris = _grown_rows(tris, max(2 * tris.shape[0], ot + most))
        if oc + most // 3 > centres.shape[0]:  # at most 4 loops, each one centre
            centres = _grown_rows(centres, max(2 * centres.shape[0], oc + most // 3))
        ov, oc, ot = _fill_block(values, blk, (origins, box_start, boxes, fine, dims), iso,
                                 (ov, oc, ot), (keys, f0, f1, centres, tris, shared),
                                 (vid, touched, scratch, v))
    block_v[stop - start] = ov
    return keys[:ov], f0[:ov], f1[:ov], shared[:ov], centres[:oc], tris[:ot], block_v


@cached
def _grown(a, size):
    """A copy of the 1-D array ``a`` with room for ``size`` items."""
    out = np.empty(size, dtype=a.dtype)
    for i in range(a.shape[0]):  # (a loop: slice assignment takes seconds to compile)
        out[i] = a[i]
    return out


@cached
def _grown_rows(a, size):
    """A copy of the (n, 3) array ``a`` with room for ``size`` rows (the shape spelled out: a
    shape built by tuple concatenation takes seconds to compile)."""
    out = np.empty((size, 3), dtype=a.dtype)
    for i in range(a.shape[0]):
        for c in range(3):
            out[i, c] = a[i, c]
    return out


@cached
def _fill_block(values, blk, grid, iso, at, out, work):
    """One block of :func:`_fill_part` (grid = (origins, box_start, boxes, fine, dims)), writing
    into out = (keys, f0, f1, centres, tris, shared) from at = (ov, oc, ot) on; returns where
    the next block writes, and leaves ``vid`` of work = (vid, touched, scratch, v) all -1
    again."""
    origins, box_start, boxes, fine, dims = grid
    ov, oc, ot = at
    keys, f0, f1, centres, tris, shared = out
    vid, touched, scratch, v = work
    m = values.shape[1]
    d1 = dims[1]
    d2 = dims[2]
    nxt = scratch[:12]
    loops = scratch[12:24]
    loop_len = scratch[24:28]
    cell_vid = scratch[28:]
    v0 = ov
    oi, oj, ok = origins[blk, 0], origins[blk, 1], origins[blk, 2]
    for b in range(box_start[blk], box_start[blk + 1]):
        di = dj = dk = 0  # the box's cells, x slowest (counted on: no division per cell)
        for _ in range(fine**3):
            i, j, k = boxes[b, 0] + di, boxes[b, 1] + dj, boxes[b, 2] + dk
            dk += 1
            if dk == fine:
                dk, dj = 0, dj + 1
                if dj == fine:
                    dj, di = 0, di + 1
            if not _load_cell(values, blk, i, j, k, iso, v):
                continue
            pos = 0
            for q in range(_cell_loops(v, iso, nxt, loops, loop_len)):
                n = loop_len[q]
                for r in range(n):
                    e = loops[pos + r]
                    a = EDGE_AXIS[e]
                    li = i + EDGE_OFFSET[e, 0]
                    lj = j + EDGE_OFFSET[e, 1]
                    lk = k + EDGE_OFFSET[e, 2]
                    slot = _edge_slot(e, i, j, k, m)
                    if vid[slot] < 0:
                        vid[slot] = ov
                        touched[ov - v0] = slot
                        keys[ov] = (((oi + li) * d1 + (oj + lj)) * d2 + (ok + lk)) * 3 + a
                        f0[ov] = values[blk, li, lj, lk]
                        f1[ov] = values[blk, li + (a == 0), lj + (a == 1), lk + (a == 2)]
                        shared[ov] = ((a != 0 and (li == 0 or li == m - 1))
                                      or (a != 1 and (lj == 0 or lj == m - 1))
                                      or (a != 2 and (lk == 0 or lk == m - 1)))
                        ov += 1
                    cell_vid[r] = vid[slot]
                apex = _fan_apex(loops, pos, n)
                if apex < 0:  # a centre vertex, fanned around the whole loop
                    centres[oc] = 0.0
                    for r in range(n):
                        w = cell_vid[r]
                        x = _edge_point(loops[pos + r], f0[w], f1[w], iso)
                        centres[oc, 0] += (oi + i + x[0]) / n
                        centres[oc, 1] += (oj + j + x[1]) / n
                        centres[oc, 2] += (ok + k + x[2]) / n
                    cell_vid[n] = cell_vid[0]
                    for r in range(n):
                        tris[ot, 0] = -1 - oc
                        tris[ot, 1] = cell_vid[r + 1]
                        tris[ot, 2] = cell_vid[r]
                        ot += 1
                    oc += 1
                else:  # reversed: the loop runs counter-clockwise about the inside
                    for r in range(1, n - 1):
                        tris[ot, 0] = cell_vid[apex]
                        tris[ot, 1] = cell_vid[(apex + r + 1) % n]
                        tris[ot, 2] = cell_vid[(apex + r) % n]
                        ot += 1
                pos += n
    for q in range(ov - v0):
        vid[touched[q]] = -1
    return ov, oc, ot


@cached(inline="always")
def _edge_point(e, f0, f1, iso):
    """Linear-interpolation crossing on cell edge ``e``, in cell coordinates (3,)."""
    x = np.empty(3)
    for c in range(3):
        x[c] = EDGE_OFFSET[e, c]
    x[EDGE_AXIS[e]] += (iso - f0) / (f1 - f0)
    return x
