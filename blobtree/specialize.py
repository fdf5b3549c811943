"""Program specialisation to a region: the tape shortening of Keeter's MPR, for BlobTrees.

Given a box of space (a cell of points, an image tile's frustum, a mesher block), ``specialize``
copies the program keeping only what can be non-zero there: a subtree whose box misses the region
becomes nothing (inside a blend, super-elliptic blend or union, where a 0 changes nothing) or one
ZERO instruction; an intersection with a zero child, or a difference whose first child is zero,
becomes ZERO; box tests that contain the whole region are dropped.  Parameters are shared with the
full program.  Points in the region evaluate exactly as with the full program.

``eval_binned`` sorts a batch of points into a grid of cells and runs each cell's specialised
program: for the 126-blob whorl a point then meets a handful of instructions instead of ~26.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from . import kernels as K


@njit(cache=True, inline="always")
def _misses(boxes, i, lo, hi):
    return (hi[0] < boxes[i, 0] or hi[1] < boxes[i, 1] or hi[2] < boxes[i, 2]
            or lo[0] > boxes[i, 3] or lo[1] > boxes[i, 4] or lo[2] > boxes[i, 5])


@njit(cache=True, inline="always")
def _contains(boxes, i, lo, hi):
    return (boxes[i, 0] <= lo[0] and boxes[i, 1] <= lo[1] and boxes[i, 2] <= lo[2]
            and hi[0] <= boxes[i, 3] and hi[1] <= boxes[i, 4] and hi[2] <= boxes[i, 5])


@njit(cache=True, inline="always")
def _copy(code, boxes, lips, i, oc, ob, ol, n):
    for c in range(4):
        oc[n, c] = code[i, c]
    for c in range(6):
        ob[n, c] = boxes[i, c]
    ol[n] = lips[i]
    return n + 1


@njit(cache=True, inline="always")
def _zero(oc, ob, ol, n):
    oc[n, 0] = K.OP_ZERO
    oc[n, 1] = 0
    oc[n, 2] = n + 1
    oc[n, 3] = 0
    for c in range(6):
        ob[n, c] = 0.0
    ol[n] = 0.0
    return n + 1


@njit(cache=True)
def specialize(code, boxes, lips, lo, hi, oc, ob, ol):
    """Write the program specialised to the box [lo, hi] into oc, ob, ol; return its length.

    One pass over the program with a stack of open subtrees (a BOX head, its children, then the
    closing operator or COLOR at the head's skip target - 1)."""
    ncode = code.shape[0]
    cap = ncode + 1
    f_end = np.empty(cap, dtype=np.int64)     # source index after the subtree
    f_start = np.empty(cap, dtype=np.int64)   # output index where it began
    f_head = np.empty(cap, dtype=np.int64)    # output index of its kept BOX head, or -1
    f_kept = np.empty(cap, dtype=np.int64)    # children that produce instructions
    f_first = np.empty(cap, dtype=np.bool_)
    f_dead = np.empty(cap, dtype=np.bool_)
    f_drop = np.empty(cap, dtype=np.bool_)    # may this subtree vanish if zero?
    top = -1
    n = 0
    i = 0
    while True:
        z = False
        have = False  # a finished subtree with result z to report to its parent
        if top >= 0 and i == f_end[top] - 1:
            closing = i
            cop = code[closing, 0]
            if f_dead[top] or f_kept[top] == 0:
                n = f_start[top]
                if not f_drop[top]:
                    n = _zero(oc, ob, ol, n)
                z = True
            else:
                if cop == K.OP_COLOR or f_kept[top] > 1:
                    n = _copy(code, boxes, lips, closing, oc, ob, ol, n)
                    if cop != K.OP_COLOR:
                        oc[n - 1, 3] = f_kept[top]
                if f_head[top] >= 0:
                    oc[f_head[top], 2] = n
            i = f_end[top]
            top -= 1
            have = True
        elif i >= ncode:
            break
        else:
            # zeros vanish from blends, super-elliptic blends, unions and differences'
            # subtrahends; controlled blends keep them in place (their pairs index children)
            drop = top >= 0 and code[f_end[top] - 1, 0] != K.OP_CBLEND
            op = code[i, 0]
            if op <= K.OP_CYLINDER:
                if _misses(boxes, i, lo, hi):
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
            elif op == K.OP_PUSHPT:  # inside a warp the frame differs: copy verbatim
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
                f_first[top] = True
                f_dead[top] = False
                f_drop[top] = drop
                i += 1
        if have and top >= 0:
            cop = code[f_end[top] - 1, 0]
            # a zero child kills an intersection, a colour node, or a difference's first child
            if z and (cop == K.OP_INTER or cop == K.OP_COLOR
                      or (cop == K.OP_DIFF and f_first[top])):
                f_dead[top] = True
            if not z or cop == K.OP_CBLEND:
                f_kept[top] += 1
            f_first[top] = False
    return n


@njit(parallel=True, cache=True)
def eval_binned(code, params, boxes, lips, P, mode, depth, lo, hi, dims, out_f, out_g, out_c):
    """Evaluate points grouped by the cells of a grid over [lo, hi] with dims cells per axis,
    each cell running its specialised program."""
    n = P.shape[0]
    ncell = dims[0] * dims[1] * dims[2]
    cell = np.empty(n, dtype=np.int64)
    size = (hi - lo) / dims
    for m in prange(n):
        c = 0
        for a in range(3):
            k = int((P[m, a] - lo[a]) / size[a])
            k = min(max(k, 0), dims[a] - 1)
            c = c * dims[a] + k
        cell[m] = c
    counts = np.zeros(ncell + 1, dtype=np.int64)
    for m in range(n):
        counts[cell[m] + 1] += 1
    for c in range(ncell):
        counts[c + 1] += counts[c]
    order = np.empty(n, dtype=np.int64)
    fill = counts[:-1].copy()
    for m in range(n):
        order[fill[cell[m]]] = m
        fill[cell[m]] += 1
    ncode = code.shape[0]
    for c in prange(ncell):
        a, b = counts[c], counts[c + 1]
        if a == b:
            continue
        clo = np.empty(3)
        chi = np.empty(3)
        r = c
        for ax in range(2, -1, -1):
            k = r % dims[ax]
            r //= dims[ax]
            clo[ax] = lo[ax] + k * size[ax]
            chi[ax] = lo[ax] + (k + 1) * size[ax]
        # points outside [lo, hi] were clamped into border cells: widen those cells
        for ax in range(3):
            for q in range(a, b):
                v = P[order[q], ax]
                clo[ax] = min(clo[ax], v)
                chi[ax] = max(chi[ax], v)
        oc = np.empty((ncode, 4), dtype=np.int64)
        ob = np.empty((ncode, 6))
        ol = np.empty(ncode)
        m = specialize(code, boxes, lips, clo, chi, oc, ob, ol)
        sub = oc[:m]
        vs, ps = K.scratch(depth)
        for q in range(a, b):
            idx = order[q]
            out_f[idx] = K.eval_point(sub, params, ob, P[idx, 0], P[idx, 1], P[idx, 2], mode,
                                      vs, ps)
            if mode > 0:
                out_g[idx, 0], out_g[idx, 1], out_g[idx, 2] = vs[0, 1], vs[0, 2], vs[0, 3]
            if mode > 1:
                out_c[idx, 0], out_c[idx, 1], out_c[idx, 2] = vs[0, 4], vs[0, 5], vs[0, 6]
