"""Program specialisation to a region: the tape shortening of Keeter's MPR, for BlobTrees.

Given a box of space (a cell of points, an image tile's frustum, a mesher block), ``specialize``
copies the program keeping only what can be non-zero there.  A subtree whose box misses the
region becomes nothing or one ZERO instruction, or makes its parent zero, as the parent operator
declares (``ZERO_FIRST`` / ``ZERO_REST``): a blend, super-elliptic blend or union drops it, an
intersection dies, a difference dies of a zero first child and keeps zero subtrahends, a
controlled blend keeps zeros in place, a paint node dies with its child.  An operator left with
one child becomes that child; box tests that contain the whole region are dropped.  Parameters
are shared with the full program.  Points in the region evaluate exactly as with the full
program.

``specialize_regions`` specialises the program to each of a list of boxes: the cells of a grid
over the tree's bounds (``Program.grid``, built once per program), or a mesher's blocks
(``Program.regions``); ``batch.eval_sorted`` runs each point through its cell's short program: for
the 126-blob whorl a point then meets ~8 instructions instead of ~26.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numba import types

from ..nodes.layout import ARG, OFFSET, OP, SKIP
from ..runtime.jit import kernel, linked
from ..runtime.threads import parallel_for
from .bounds import carry, half_diagonal, support_misses
from .dispatch import (
    K_OPERATOR,
    K_PRIMITIVE,
    K_PUSHPT,
    K_WARP,
    K_ZERO,
    KEEP,
    KILL,
    OP_ZERO,
    ZERO_FIRST,
    ZERO_REST,
    kind_of,
)
from .point import PROGRAM, misses


@kernel
def _misses(boxes, i, lo, hi):
    return misses(boxes, i, (lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]))


@kernel
def _contains(boxes, i, lo, hi):
    return (boxes[i, 0] <= lo[0] and boxes[i, 1] <= lo[1] and boxes[i, 2] <= lo[2]
            and hi[0] <= boxes[i, 3] and hi[1] <= boxes[i, 4] and hi[2] <= boxes[i, 5])


@kernel
def _frame_misses(prog, i, lo, hi):
    """Does the box [lo, hi] miss the warp entered at PUSHPT i once carried into its frame?
    The PUSHPT's own box is the warp's box in the outer frame, an axis-aligned box around a
    turned one; carried in, the region meets the warp's box and then, carried through the warp,
    its child's box in their own axes (a long bent spine's box hides most of what its outer
    box holds).  The region must be bounded."""
    code, boxes = prog[0], prog[2]
    # (``boxes`` stands in for carry's point stack: a region carried through a warp maps one
    # point in mode VALUE, which reads no stack and writes none)
    region = carry(True, prog, i, (lo[0], lo[1], lo[2], hi[0], hi[1], hi[2],
                                   half_diagonal(lo[0], lo[1], lo[2], hi[0], hi[1], hi[2])),
                   boxes)
    w = i + 1
    if misses(boxes, w, region[:6]):
        return True
    if kind_of(code[w, OP]) != K_WARP:
        return False
    region = carry(False, prog, w, region, boxes)
    if misses(boxes, w + 1, region[:6]):
        return True
    return kind_of(code[w + 1, OP]) == K_PRIMITIVE and support_misses(prog, w + 1, region)


@kernel
def _finite(lo, hi):
    """Are the region's corners finite?  (Carried into frames and tested against supports, an
    unbounded region would give NaN centres; it meets everything anyway.)"""
    for k in range(3):
        if not (math.isfinite(lo[k]) and math.isfinite(hi[k])):
            return False
    return True


@kernel
def _copy(code, boxes, lips, i, oc, ob, ol, n):
    for c in range(4):
        oc[n, c] = code[i, c]
    for c in range(6):
        ob[n, c] = boxes[i, c]
    ol[n] = lips[i]
    return n + 1


@kernel
def _zero(oc, ob, ol, n):
    oc[n, OP] = OP_ZERO
    oc[n, OFFSET] = 0
    oc[n, SKIP] = n + 1
    oc[n, ARG] = 0
    for c in range(6):
        ob[n, c] = 0.0
    ol[n] = 0.0
    return n + 1


@kernel
def _rule(cop, first):
    """What a zero child does to the operator (or paint node) closing at ``cop``."""
    return ZERO_FIRST[cop] if first == 1 else ZERO_REST[cop]


@kernel(nrt=True)
def specialize_work(code):
    """Scratch for :func:`specialize` on ``code`` (its stack of open subtrees)."""
    return np.empty((7, code.shape[0] + 1), dtype=np.int64)


def _specialize(prog, lo, hi, out, work):
    """Write the program ``prog`` specialised to the box [lo, hi] into out = (oc, ob, ol) (its
    code, boxes and lips); return its length.

    One pass over the program with a stack of open subtrees (a BOX head, its children, then the
    closing operator or COLOR at the head's skip target - 1), kept in ``work``
    (:func:`specialize_work`): nothing is allocated, so kernels compiled without reference
    counting may call it.  ``code`` must be a whole program (``Program.arrays``), never one this
    wrote: that one lacks the BOX heads of the subtrees holding the box whole, and its closing
    instructions keep the whole program's skip targets."""
    code, boxes, lips = prog[0], prog[2], prog[3]
    oc, ob, ol = out
    f_end = work[0]     # source index after the subtree
    f_start = work[1]   # output index where it began
    f_head = work[2]    # output index of its kept BOX head, or -1
    f_kept = work[3]    # children that produce instructions
    f_first = work[4]   # (0 / 1 flags) no child finished yet
    f_dead = work[5]
    f_drop = work[6]    # may this subtree vanish if zero?
    ncode = code.shape[0]
    tight = _finite(lo, hi)  # also test frames and supports, beyond the boxes
    region = (lo[0], lo[1], lo[2], hi[0], hi[1], hi[2],
              half_diagonal(lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]))  # with the region's ball
    top = -1
    n = 0
    i = 0
    while True:
        z = False
        have = False  # a finished subtree with result z to report to its parent
        if top >= 0 and i == f_end[top] - 1:
            closing = i
            cop = code[closing, OP]
            if f_dead[top] == 1 or f_kept[top] == 0:
                n = f_start[top]
                if f_drop[top] == 0:
                    n = _zero(oc, ob, ol, n)
                z = True
            else:  # an operator left with one child is that child; a paint node stays
                if kind_of(cop) != K_OPERATOR or f_kept[top] > 1:
                    n = _copy(code, boxes, lips, closing, oc, ob, ol, n)
                    if kind_of(cop) == K_OPERATOR:
                        oc[n - 1, ARG] = f_kept[top]
                if f_head[top] >= 0:
                    oc[f_head[top], 2] = n
            i = f_end[top]
            top -= 1
            have = True
        elif i >= ncode:
            break
        else:
            # does the open operator keep a zero child in place (else it drops it, or dies)?
            drop = top >= 0 and _rule(code[f_end[top] - 1, OP], f_first[top]) != KEEP
            op = code[i, OP]
            if kind_of(op) == K_PRIMITIVE or kind_of(op) == K_ZERO:
                if kind_of(op) == K_ZERO or _misses(boxes, i, lo, hi) or (
                        tight and support_misses(prog, i, region)):
                    z = True
                    if not drop:
                        n = _zero(oc, ob, ol, n)
                else:
                    n = _copy(code, boxes, lips, i, oc, ob, ol, n)
                i += 1
                have = True
            elif _misses(boxes, i, lo, hi) or (tight and kind_of(op) == K_PUSHPT
                                               and _frame_misses(prog, i, lo, hi)):
                z = True
                if not drop:
                    n = _zero(oc, ob, ol, n)
                i = code[i, SKIP]
                have = True
            elif kind_of(op) == K_PUSHPT:  # inside a warp the frame differs: copy verbatim
                shift = n - i
                for j in range(i, code[i, SKIP]):
                    n = _copy(code, boxes, lips, j, oc, ob, ol, n)
                    oc[n - 1, SKIP] = code[j, SKIP] + shift
                i = code[i, SKIP]
                have = True
            else:  # a BOX head opens a subtree
                top += 1
                f_end[top] = code[i, SKIP]
                f_start[top] = n
                f_head[top] = -1
                if not _contains(boxes, i, lo, hi):
                    f_head[top] = n
                    n = _copy(code, boxes, lips, i, oc, ob, ol, n)
                f_kept[top] = 0
                f_first[top] = 1
                f_dead[top] = 0
                f_drop[top] = drop
                i += 1
        if have and top >= 0:
            rule = _rule(code[f_end[top] - 1, OP], f_first[top])
            if z and rule == KILL:
                f_dead[top] = 1
            if not z or rule == KEEP:
                f_kept[top] += 1
            f_first[top] = 0
    return n


#: Room for a specialised program, as numba types: (code, boxes, lips).
BUFFERS = types.Tuple((types.int64[:, ::1], types.float64[:, ::1], types.float64[::1]))
#: :func:`_specialize` compiled once, called by symbol (``runtime.linked``): the tracer's
#: kernels (the block cones, the hits, the shadow rays' stretches) and the grids' parts call it;
#: linked into each, it was optimised and emitted again in each (3,400 LLVM instructions).
#: ``specialize(prog, lo, hi, (oc, ob, ol), work)``.
region_specialize = linked(types.int64(PROGRAM, types.float64[::1], types.float64[::1], BUFFERS,
                                       types.int64[:, ::1]))(_specialize)
specialize = region_specialize.call


@dataclass
class Regions:
    """The program specialised to each of a list of boxes: region r runs rows
    start[r]:start[r + 1] of (code, boxes), skip targets relative to its start."""

    start: np.ndarray
    code: np.ndarray
    boxes: np.ndarray

    @property
    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(start, code, boxes), as the batch kernels take them."""
        return self.start, self.code, self.boxes


@dataclass
class Grid(Regions):
    """Regions that are the cells of a grid (lo, size, dims), cell (i, j, k) being region
    (i * dims[1] + j) * dims[2] + k: ``batch.eval_sorted`` finds a point's cell itself."""

    lo: np.ndarray
    size: np.ndarray
    dims: np.ndarray

    @cached_property
    def frame(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(lo, 1 / size, dims) of the grid, as ``cell_of`` takes them."""
        return self.lo, 1.0 / self.size, self.dims

    @cached_property
    def live(self) -> np.ndarray:
        """1 for each cell whose program is more than a lone ZERO (its field may be non-zero),
        else 0: ``batch.eval_sorted`` answers the points of dead cells without evaluating."""
        lone = self.start[1:] - self.start[:-1] == 1
        return (~lone | (self.code[self.start[:-1], OP] != OP_ZERO)).astype(np.uint8)


def cell_boxes(lo, size, dims, pad) -> tuple[np.ndarray, np.ndarray]:
    """Corners (C, 3) of every cell of a grid, in region order, grown by ``pad``."""
    index = np.stack(np.meshgrid(*(np.arange(n) for n in dims), indexing="ij"), -1)
    index = index.reshape(-1, 3)
    return lo + index * size - pad, lo + (index + 1) * size + pad


@kernel(nrt=True, nogil=True)
def _specialize_part(start, stop, prog, rlo, rhi, lengths, gc, gb, fill):
    """Specialise to regions start..stop - 1 (boxes rlo, rhi): record the lengths (``fill``
    False), or copy the programs to rows lengths[r]:lengths[r] + m (``fill`` True; lengths then
    holds the starts)."""
    n = prog[0].shape[0]
    out = (np.empty((n, 4), dtype=np.int64), np.empty((n, 6)), np.empty(n))  # (scratch:
    oc, ob = out[0], out[1]  # specialize may write past its length)
    work = specialize_work(prog[0])
    for r in range(start, stop):
        m = specialize(prog, rlo[r], rhi[r], out, work)
        if not fill:
            lengths[r + 1] = m
            continue
        a = lengths[r]
        for i in range(m):
            for q in range(4):
                gc[a + i, q] = oc[i, q]
            for q in range(6):
                gb[a + i, q] = ob[i, q]


def region_starts(prog, rlo, rhi) -> np.ndarray:
    """Where each region's specialised program would start (R + 1 entries; the last is the
    total length): the counting pass of :func:`specialize_regions`, cheap enough to try grids
    of several sizes."""
    lengths = np.zeros(len(rlo) + 1, dtype=np.int64)
    parallel_for(_specialize_part, len(rlo), prog, rlo, rhi, lengths,
                 np.empty((0, 4), dtype=np.int64), np.empty((0, 6)), False)
    return np.cumsum(lengths)


def specialize_regions(prog, rlo, rhi, start=None) -> Regions:
    """The program ``prog`` (``Program.arrays``) specialised to each box (rlo[r], rhi[r]) ((R, 3)
    each; ``start`` from
    :func:`region_starts` if already counted).  (Batch evaluation reads no Lipschitz bounds,
    so the regions keep none.)"""
    rlo = np.ascontiguousarray(rlo, dtype=np.float64)
    rhi = np.ascontiguousarray(rhi, dtype=np.float64)
    if start is None:
        start = region_starts(prog, rlo, rhi)
    total = int(start[-1])
    gc, gb = np.empty((total, 4), dtype=np.int64), np.empty((total, 6))
    parallel_for(_specialize_part, len(rlo), prog, rlo, rhi, start, gc, gb, True)
    return Regions(start, gc, gb)


@kernel
def cell_of(x, y, z, lo, scale, dims):
    """(Index of the grid cell nearest (x, y, z), whether the point is in the grid); ``scale``
    is 1 / the cell size.  No branches: the partition's points come in any order."""
    tx = (x - lo[0]) * scale[0]
    ty = (y - lo[1]) * scale[1]
    tz = (z - lo[2]) * scale[2]
    inside = (0.0 <= tx <= dims[0]) & (0.0 <= ty <= dims[1]) & (0.0 <= tz <= dims[2])
    if not inside:  # (a select, not a branch) NaN and huge values have no integer part
        tx = ty = tz = 0.0
    ix = min(int(tx), dims[0] - 1)
    iy = min(int(ty), dims[1] - 1)
    iz = min(int(tz), dims[2] - 1)
    return (ix * dims[1] + iy) * dims[2] + iz, inside
