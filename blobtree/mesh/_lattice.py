"""The sparse lattice the polygonizer samples: numba kernels over blocks of ``block`` cells.

Each block holds the values of its ``(block + 1)**3`` lattice points and which are sampled;
only the points of the boxes of ``fine`` cells the culling kept are sampled.  See
``polygonizer._sample``.
"""

from __future__ import annotations

import numpy as np

from ..runtime.jit import cached
from ..runtime.threads import parallel_for


def new_store(nblocks, block, fine, kept_slot, kept_loc, kept_value):
    """Values, which points are sampled, and the kept-box map ``(B, s, s, s)`` (s = block /
    fine) of the blocks, with the centres of kept boxes (sampled by the culling) stored.  Only
    points of kept boxes are ever sampled or read.  (Both passes run in parallel: each block,
    then each box, writes its own entries, and the memory's first touch is shared out.)"""
    m = block + 1
    s = block // fine
    values = np.empty((nblocks, m, m, m))
    sampled = np.empty((nblocks, m, m, m), dtype=np.bool_)
    boxmap = np.empty((nblocks, s, s, s), dtype=np.int64)
    parallel_for(_clear_blocks, nblocks, sampled, boxmap)
    parallel_for(_store_centres, len(kept_slot), fine, kept_slot, kept_loc, kept_value, values,
                 sampled, boxmap)
    return values, sampled, boxmap


@cached(nogil=True)
def _clear_blocks(start, stop, sampled, boxmap):
    """Blocks start..stop - 1: nothing sampled, no kept box."""
    for b in range(start, stop):
        sampled[b] = False
        boxmap[b] = -1


@cached(nogil=True)
def _store_centres(start, stop, fine, kept_slot, kept_loc, kept_value, values, sampled, boxmap):
    """Kept boxes start..stop - 1 into the map, their centres' values stored as sampled."""
    half = fine // 2
    for q in range(start, stop):
        b = kept_slot[q]
        i, j, k = kept_loc[q, 0], kept_loc[q, 1], kept_loc[q, 2]
        boxmap[b, i // fine, j // fine, k // fine] = q
        values[b, i + half, j + half, k + half] = kept_value[q]
        sampled[b, i + half, j + half, k + half] = True


def gather(sampled, boxes, kept_slot, kept_loc, offsets, block_origins, grid_origin, h):
    """Points of the kept boxes ``boxes`` at ``offsets`` (P, 3) not sampled yet, each once,
    grouped by block: their flat indices into the store (S,), positions (S, 3), and where each
    block's points start (B + 1: block b's at first[b]:first[b + 1]).  ``boxes`` must come
    grouped by block (``kept_slot[boxes]`` never decreasing).  Marks the points sampled (the
    caller stores their values).  Blocks are gathered in parallel: each owns its points."""
    assert sampled.shape[1] <= 256  # (local coordinates are packed in bytes)
    counts = np.zeros(sampled.shape[0] + 1, dtype=np.int64)
    slots = kept_slot[boxes]
    group = np.r_[np.flatnonzero(np.diff(slots, prepend=slots[:1] - 1)), len(boxes)]
    found = np.empty(len(boxes) * len(offsets), dtype=np.int64)  # room for each group's points
    groups = len(group) - 1
    parallel_for(_find_new, groups, sampled, boxes, group, kept_slot, kept_loc, offsets, found,
                 counts)
    first = np.cumsum(counts)
    flat, coords = np.empty(first[-1], dtype=np.int64), np.empty((first[-1], 3))
    parallel_for(_place_new, groups, (boxes, group, kept_slot), (len(offsets), sampled.shape[1]),
                 found, first, (block_origins, grid_origin, h), (flat, coords))
    return flat, coords, first


@cached(nogil=True)
def _find_new(start, stop, sampled, boxes, group, kept_slot, kept_loc, offsets, found, counts):
    """Groups start..stop - 1 of ``boxes`` (one block each): their points not sampled yet,
    marked sampled, their local coordinates (i << 16 | j << 8 | k) from found[group[g] * P]
    on, their count in counts[block + 1]."""
    for g in range(start, stop):
        b = kept_slot[boxes[group[g]]]
        n = group[g] * offsets.shape[0]
        for q in boxes[group[g]:group[g + 1]]:
            for p in range(offsets.shape[0]):
                i = kept_loc[q, 0] + offsets[p, 0]
                j = kept_loc[q, 1] + offsets[p, 1]
                k = kept_loc[q, 2] + offsets[p, 2]
                if not sampled[b, i, j, k]:
                    sampled[b, i, j, k] = True
                    found[n] = (i << 16) | (j << 8) | k
                    n += 1
        counts[b + 1] = n - group[g] * offsets.shape[0]


@cached(nogil=True)
def _place_new(start, stop, groups, sizes, found, first, lattice, out):
    """Groups start..stop - 1 of groups = (boxes, group, kept_slot): the points
    :func:`_find_new` found (sizes = (offsets per box, block side m)), at their block's place in
    out = (flat, coords); lattice = (block_origins, grid_origin, h)."""
    boxes, group, kept_slot = groups
    noffsets, m = sizes
    block_origins, grid_origin, h = lattice
    flat, coords = out
    for g in range(start, stop):
        b = kept_slot[boxes[group[g]]]
        src = group[g] * noffsets
        for n in range(first[b], first[b + 1]):
            i, j, k = found[src] >> 16, (found[src] >> 8) & 255, found[src] & 255
            src += 1
            flat[n] = ((b * m + i) * m + j) * m + k
            coords[n, 0] = grid_origin[0] + (block_origins[b, 0] + i) * h
            coords[n, 1] = grid_origin[1] + (block_origins[b, 1] + j) * h
            coords[n, 2] = grid_origin[2] + (block_origins[b, 2] + k) * h


@cached(nogil=True)
def store(start, stop, flat, f, values):
    """values (flat view) at ``flat`` start..stop - 1 from f."""
    for n in range(start, stop):
        values[flat[n]] = f[n]


@cached
def keep_boxes(lip, fc, below, above, half, lo, hi, bounds_lo, bounds_hi, clip, iso):
    """Boxes the surface may cross: ``|f(centre) - iso| <= L * half-diagonal`` (and L > 0),
    unless the field surely stays below (or above) iso over the half-diagonal from the centre
    (``below``, ``above``: distances the engine proved, 0 for none); with ``clip``, also boxes
    reaching out of the bounds where the field may exceed iso there (the cap of the cut
    solid)."""
    keep = np.empty(lip.shape[0], dtype=np.bool_)
    for q in range(lip.shape[0]):
        reach = lip[q] * half[q] * (1.0 + 1e-9) + 1e-12
        stays_below = below[q] > half[q] * (1.0 + 1e-9)
        stays_above = above[q] > half[q] * (1.0 + 1e-9)
        keep[q] = (lip[q] > 0 and abs(fc[q] - iso) <= reach
                   and not (stays_below or stays_above))
        if clip and not keep[q] and lip[q] > 0 and fc[q] + reach >= iso and not stays_below:
            for a in range(3):
                if lo[q, a] < bounds_lo[a] or hi[q, a] > bounds_hi[a]:
                    keep[q] = True
    return keep


def seeds(values, kept_slot, kept_loc, fine, iso):
    """Kept boxes whose corners and centre are not all on one side of the iso-value."""
    out = np.zeros(kept_slot.shape[0], dtype=np.bool_)
    parallel_for(_seeds, len(out), values, kept_slot, kept_loc, fine, iso, out)
    return out


@cached(nogil=True)
def _seeds(start, stop, values, kept_slot, kept_loc, fine, iso, out):
    """:func:`seeds` for kept boxes start..stop - 1."""
    half = fine // 2
    for q in range(start, stop):
        b = kept_slot[q]
        i, j, k = kept_loc[q, 0], kept_loc[q, 1], kept_loc[q, 2]
        inside = values[b, i + half, j + half, k + half] >= iso
        for c in range(8):
            v = values[b, i + fine * (c & 1), j + fine * ((c >> 1) & 1), k + fine * (c >> 2)]
            if (v >= iso) != inside:
                out[q] = True
                break


@cached
def _face_crossed(values, b, i, j, k, axis, side, fine, iso):
    """Does a lattice edge on a face of the box at local (i, j, k) of block b cross the iso?
    Exactly when the face's samples are not all on one side (its lattice is connected)."""
    inside = outside = False
    for u in range(fine + 1):
        for v in range(fine + 1):
            if _face_value(values, b, i, j, k, axis, side * fine, u, v) >= iso:
                inside = True
            else:
                outside = True
            if inside and outside:
                return True
    return False


@cached(inline="always")
def _face_value(values, b, i, j, k, axis, w, u, v):
    """Value at offset w along ``axis`` and (u, v) along the next two axes (cyclically)."""
    if axis == 0:
        return values[b, i + w, j + u, k + v]
    if axis == 1:
        return values[b, i + v, j + w, k + u]
    return values[b, i + u, j + v, k + w]


def spread(
    values, frontier, active, kept_slot, kept_loc, boxmap, block_of, block_origins, block, fine, iso
):
    """Kept boxes not yet active across a crossed face of a frontier box; marks them active
    (the faces are read in parallel, the boxes marked in order)."""
    across = np.empty((frontier.shape[0], 6), dtype=np.int64)
    parallel_for(_across, len(frontier), values, frontier, (kept_slot, kept_loc, boxmap, block_of,
                 block_origins), (block, fine, iso), across)
    return _activate(across.reshape(-1), active)


@cached(nogil=True)
def _across(start, stop, values, frontier, lattice, sizes, across):
    """For frontier boxes start..stop - 1, the kept box across each face (axis, side) with a
    crossed lattice edge, in across[q, 2 * axis + side], else -1 (lattice = (kept_slot,
    kept_loc, boxmap, block_of, block_origins), sizes = (block, fine, iso))."""
    kept_slot, kept_loc, boxmap, block_of, block_origins = lattice
    block, fine, iso = sizes
    s = block // fine  # boxes per side of a block
    here = np.empty(3, dtype=np.int64)  # a box's place in its block, in boxes
    there = np.empty(3, dtype=np.int64)  # and the box across a face
    blk = np.empty(3, dtype=np.int64)  # the block's indices
    for q in range(start, stop):
        b = kept_slot[frontier[q]]
        for a in range(3):
            here[a] = kept_loc[frontier[q], a] // fine
            blk[a] = block_origins[b, a] // block
        i, j, k = kept_loc[frontier[q], 0], kept_loc[frontier[q], 1], kept_loc[frontier[q], 2]
        for axis in range(3):
            for side in range(2):
                across[q, 2 * axis + side] = -1
                if not _face_crossed(values, b, i, j, k, axis, side, fine, iso):
                    continue
                for a in range(3):
                    there[a] = here[a]
                there[axis] += 1 if side else -1
                other = b
                if there[axis] < 0 or there[axis] >= s:  # in the next block along the axis
                    blk[axis] += 1 if side else -1
                    inside = 0 <= blk[axis] < block_of.shape[axis]
                    other = block_of[blk[0], blk[1], blk[2]] if inside else -1
                    blk[axis] -= 1 if side else -1
                    if other < 0:
                        continue
                    there[axis] = 0 if side else s - 1
                across[q, 2 * axis + side] = boxmap[other, there[0], there[1], there[2]]


@cached
def _activate(boxes, active):
    """The boxes (>= 0) not yet active, each once, ascending (so grouped by block, as the kept
    boxes are); marks them active."""
    new = np.zeros(active.shape[0], dtype=np.bool_)
    for r in boxes:
        if r >= 0 and not active[r]:
            active[r] = True
            new[r] = True
    return np.flatnonzero(new)


def box_geometry(origins, size, grid_origin, h, limit):
    """Corners lo, hi (M, 3), centres (M, 3) and half-diagonals (M,) of cubic boxes of ``size``
    cells at lattice ``origins``, cut at lattice point ``limit``."""
    n = origins.shape[0]
    lo, hi, centre, half = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)), np.empty(n)
    parallel_for(_box_geometry, n, origins, size, grid_origin, h, limit, lo, hi, centre, half)
    return lo, hi, centre, half


@cached(nogil=True)
def _box_geometry(start, stop, origins, size, grid_origin, h, limit, lo, hi, centre, half):
    """:func:`box_geometry` for boxes start..stop - 1."""
    for q in range(start, stop):
        d2 = 0.0
        for a in range(3):
            lo[q, a] = grid_origin[a] + origins[q, a] * h
            hi[q, a] = grid_origin[a] + min(origins[q, a] + size, limit[a]) * h
            # in lattice units first: a box of even size has its centre on a lattice point,
            # computed as the sampling computes that point (the finest boxes' values are kept)
            centre[q, a] = grid_origin[a] + 0.5 * (origins[q, a]
                                                   + min(origins[q, a] + size, limit[a])) * h
            d2 += (hi[q, a] - lo[q, a]) ** 2
        half[q] = 0.5 * np.sqrt(d2)


@cached
def split(origins, size, step, limit):
    """The ``step``^3 descendants of ``size`` cells of each box (of ``size * step`` cells,
    ``step`` a power of 2) whose origin lies before ``limit``, in octree order (the base-8
    digits of a descendant's number pick the octant at each level, x first), and the index of
    each one's parent."""
    out = np.empty((origins.shape[0] * step**3, 3), dtype=np.int64)
    parent = np.empty(origins.shape[0] * step**3, dtype=np.int64)
    n = 0
    for q in range(origins.shape[0]):
        for c in range(step**3):
            i, j, k = origins[q, 0], origins[q, 1], origins[q, 2]
            span, digit = size * step, step**3
            while digit > 1:
                digit //= 8
                span //= 2
                octant = c // digit % 8
                i += span * (octant & 1)
                j += span * ((octant >> 1) & 1)
                k += span * (octant >> 2)
            if i < limit[0] and j < limit[1] and k < limit[2]:
                out[n, 0], out[n, 1], out[n, 2] = i, j, k
                parent[n] = q
                n += 1
    return out[:n], parent[:n]
