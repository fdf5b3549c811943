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

``build_grid`` specialises the program to every cell of a grid over the tree's bounds (done
once per program); ``batch.eval_sorted`` runs each point through its cell's short program: for
the 126-blob whorl a point then meets ~8 instructions instead of ~26.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..jit import kernel
from ..parallel import parallel_for
from .dispatch import (
    K_OPERATOR,
    K_PRIMITIVE,
    K_PUSHPT,
    K_ZERO,
    KEEP,
    KILL,
    OP_ZERO,
    ZERO_FIRST,
    ZERO_REST,
    kind_of,
)


@kernel
def _misses(boxes, i, lo, hi):
    return (hi[0] < boxes[i, 0] or hi[1] < boxes[i, 1] or hi[2] < boxes[i, 2]
            or lo[0] > boxes[i, 3] or lo[1] > boxes[i, 4] or lo[2] > boxes[i, 5])


@kernel
def _contains(boxes, i, lo, hi):
    return (boxes[i, 0] <= lo[0] and boxes[i, 1] <= lo[1] and boxes[i, 2] <= lo[2]
            and hi[0] <= boxes[i, 3] and hi[1] <= boxes[i, 4] and hi[2] <= boxes[i, 5])


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
    oc[n, 0] = OP_ZERO
    oc[n, 1] = 0
    oc[n, 2] = n + 1
    oc[n, 3] = 0
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


@kernel
def specialize(code, boxes, lips, lo, hi, oc, ob, ol, work):
    """Write the program specialised to the box [lo, hi] into oc, ob, ol; return its length.

    One pass over the program with a stack of open subtrees (a BOX head, its children, then the
    closing operator or COLOR at the head's skip target - 1), kept in ``work``
    (:func:`specialize_work`): nothing is allocated, so kernels compiled without reference
    counting may call it."""
    f_end = work[0]     # source index after the subtree
    f_start = work[1]   # output index where it began
    f_head = work[2]    # output index of its kept BOX head, or -1
    f_kept = work[3]    # children that produce instructions
    f_first = work[4]   # (0 / 1 flags) no child finished yet
    f_dead = work[5]
    f_drop = work[6]    # may this subtree vanish if zero?
    ncode = code.shape[0]
    top = -1
    n = 0
    i = 0
    while True:
        z = False
        have = False  # a finished subtree with result z to report to its parent
        if top >= 0 and i == f_end[top] - 1:
            closing = i
            cop = code[closing, 0]
            if f_dead[top] == 1 or f_kept[top] == 0:
                n = f_start[top]
                if f_drop[top] == 0:
                    n = _zero(oc, ob, ol, n)
                z = True
            else:  # an operator left with one child is that child; a paint node stays
                if kind_of(cop) != K_OPERATOR or f_kept[top] > 1:
                    n = _copy(code, boxes, lips, closing, oc, ob, ol, n)
                    if kind_of(cop) == K_OPERATOR:
                        oc[n - 1, 3] = f_kept[top]
                if f_head[top] >= 0:
                    oc[f_head[top], 2] = n
            i = f_end[top]
            top -= 1
            have = True
        elif i >= ncode:
            break
        else:
            # does the open operator keep a zero child in place (else it drops it, or dies)?
            drop = top >= 0 and _rule(code[f_end[top] - 1, 0], f_first[top]) != KEEP
            op = code[i, 0]
            if kind_of(op) == K_PRIMITIVE or kind_of(op) == K_ZERO:
                if kind_of(op) == K_ZERO or _misses(boxes, i, lo, hi):
                    z = True
                    if not drop:
                        n = _zero(oc, ob, ol, n)
                else:
                    n = _copy(code, boxes, lips, i, oc, ob, ol, n)
                i += 1
                have = True
            elif _misses(boxes, i, lo, hi):
                z = True
                if not drop:
                    n = _zero(oc, ob, ol, n)
                i = code[i, 2]
                have = True
            elif kind_of(op) == K_PUSHPT:  # inside a warp the frame differs: copy verbatim
                shift = n - i
                for j in range(i, code[i, 2]):
                    n = _copy(code, boxes, lips, j, oc, ob, ol, n)
                    oc[n - 1, 2] = code[j, 2] + shift
                i = code[i, 2]
                have = True
            else:  # a BOX head opens a subtree
                top += 1
                f_end[top] = code[i, 2]
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
            rule = _rule(code[f_end[top] - 1, 0], f_first[top])
            if z and rule == KILL:
                f_dead[top] = 1
            if not z or rule == KEEP:
                f_kept[top] += 1
            f_first[top] = 0
    return n


@dataclass
class Grid:
    """Per-cell specialised programs (see specialize.py): cell c runs rows start[c]:start[c+1]."""

    start: np.ndarray
    code: np.ndarray
    boxes: np.ndarray
    lo: np.ndarray
    size: np.ndarray
    dims: np.ndarray

    @property
    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(start, code, boxes) for ``batch.eval_sorted``."""
        return self.start, self.code, self.boxes

    @property
    def frame(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(lo, size, dims) of the grid."""
        return self.lo, self.size, self.dims


@kernel
def _cell_box(c, lo, size, dims, pad, clo, chi):
    r = c
    for ax in range(2, -1, -1):
        k = r % dims[ax]
        r //= dims[ax]
        clo[ax] = lo[ax] + k * size[ax] - pad
        chi[ax] = lo[ax] + (k + 1) * size[ax] + pad


@kernel(nrt=True, nogil=True)
def _grid_part(start, stop, code, boxes, lips, lo, size, dims, pad, lengths, gc, gb, fill):
    """Specialise to cells start..stop - 1: record the lengths (``fill`` False), or copy the
    programs to rows lengths[c]:lengths[c] + m (``fill`` True; lengths then holds the starts)."""
    n = code.shape[0]
    oc = np.empty((n, 4), dtype=np.int64)  # scratch: specialize may write past its length
    ob = np.empty((n, 6))
    ol = np.empty(n)
    clo = np.empty(3)
    chi = np.empty(3)
    work = specialize_work(code)
    for c in range(start, stop):
        _cell_box(c, lo, size, dims, pad, clo, chi)
        m = specialize(code, boxes, lips, clo, chi, oc, ob, ol, work)
        if not fill:
            lengths[c + 1] = m
            continue
        a = lengths[c]
        for r in range(m):
            for q in range(4):
                gc[a + r, q] = oc[r, q]
            for q in range(6):
                gb[a + r, q] = ob[r, q]


def grid_starts(code, boxes, lips, lo, size, dims, pad) -> np.ndarray:
    """Where each cell's specialised program would start in the grid's rows (ncell + 1; the
    last entry is the grid's length): the counting pass of :func:`build_grid`, cheap enough to
    try grids of several sizes."""
    lengths = np.zeros(int(np.prod(dims)) + 1, dtype=np.int64)
    parallel_for(_grid_part, len(lengths) - 1, code, boxes, lips, lo, size, dims, pad, lengths,
                 np.empty((0, 4), dtype=np.int64), np.empty((0, 6)), False)
    return np.cumsum(lengths)


def build_grid(code, boxes, lips, lo, size, dims, pad, start):
    """Specialise the program to every cell of a grid: (code, boxes), cell c's program being
    rows start[c]:start[c + 1] (``start`` from :func:`grid_starts`; skip targets relative to
    the cell's start).  (Batch evaluation reads no Lipschitz bounds, so the cells keep none.)"""
    total = int(start[-1])
    gc, gb = np.empty((total, 4), dtype=np.int64), np.empty((total, 6))
    parallel_for(_grid_part, len(start) - 1, code, boxes, lips, lo, size, dims, pad, start, gc,
                 gb, True)
    return gc, gb


@kernel
def cell_of(x, y, z, lo, size, dims):
    """Index of the grid cell holding (x, y, z), or -1 outside the grid."""
    c = 0
    v = (x, y, z)
    for ax in range(3):
        t = (v[ax] - lo[ax]) / size[ax]
        if not (0.0 <= t <= dims[ax]):
            return -1
        c = c * dims[ax] + min(int(t), dims[ax] - 1)
    return c
