"""The point evaluator: field, gradient and colour at one point (the walk's ``point`` mode).

Primitives push (field, gradient, colour) on the value stack, operators combine their children's
rows, warps move the point and PUSHPT / POPPT enter and leave their frames on the point stack
(chaining the Jacobian for the gradient).  ``at = (x, y, z, mode)``: mode ``VALUE`` computes the
field only (tracing), ``GRADIENT`` also the gradient, ``SHADE`` also the colour, in the top row
vs[0] of the stacks ``st = (vs, ps)`` (:func:`scratch`).  Compiled once for all three modes:
branches skip the work a mode does not need.  Kernels call :data:`eval_point` (by symbol, see
``runtime.linked``); Python calls :data:`point_walk` or, for many points, ``Program.evaluate``.
"""

from __future__ import annotations

import numpy as np
from numba import types

from ..nodes.kernel_math import (
    fo,
    fo_ds,
    from_canonical,
    map_point,
    texel,
    to_canonical,
)
from ..nodes.layout import (
    ARG,
    COLOR,
    COLUMNS,
    FALLOFF,
    FIELD,
    GRAD,
    GRADIENT,
    JACOBIAN,
    OFFSET,
    OP,
    POINT,
    POINT_COLUMNS,
    SHADE,
    VALUE,
    WARP,
)
from ..runtime.jit import kernel, linked
from .dispatch import combine, paint, prim_s, prim_uv, warp_map
from .walk import Mode, hook, walk

DEFAULT_GREY = 0.8

#: The program bundle every walk takes: (code, params, boxes, lips) (``Program.arrays``).
PROGRAM = types.Tuple((types.int64[:, ::1], types.float64[::1], types.float64[:, ::1],
                       types.float64[::1]))
#: The stacks of a point's evaluation and of the bound passes: (vs, ps).
STACKS = types.UniTuple(types.float64[:, ::1], 2)


@kernel(nrt=True)
def scratch(depth):
    """Per-thread stacks ``(vs, ps)`` for :data:`eval_point` and the bound passes: values
    (depth, COLUMNS): field, gradient, colour (and a bound's rise and fall); and points
    (depth, POINT_COLUMNS): the point to restore, the Jacobian to the outer frame, warp
    scratch."""
    return np.empty((depth, COLUMNS)), np.empty((depth, POINT_COLUMNS))


@kernel(forceinline=True)
def outside(boxes, i, x, y, z):
    """Is (x, y, z) outside instruction i's box?  A point with a NaN coordinate is inside (no
    comparison with it holds).  Without branches, so that a loop over points testing each
    vectorises (``batch._any_inside``)."""
    return ((x < boxes[i, 0]) | (y < boxes[i, 1]) | (z < boxes[i, 2])
            | (x > boxes[i, 3]) | (y > boxes[i, 4]) | (z > boxes[i, 5]))


@kernel(forceinline=True)
def misses(boxes, i, region):
    """Does the box ``region`` (lox, loy, loz, hix, hiy, hiz) miss instruction i's?  (Callers
    pass a region's first six entries, so that it is compiled once.)"""
    return (region[3] < boxes[i, 0] or region[4] < boxes[i, 1] or region[5] < boxes[i, 2]
            or region[0] > boxes[i, 3] or region[1] > boxes[i, 4] or region[2] > boxes[i, 5])


@kernel(inline="always")
def nan_point(x, y, z):
    """Has (x, y, z) a NaN coordinate?  Such a point has no field: it evaluates to NaN (field
    and gradient) on every path.  (No branches: it vectorises.)"""
    return (x != x) | (y != y) | (z != z)


@kernel
def push_zero(vs, sp, mode):
    vs[sp, FIELD] = 0.0
    if mode == VALUE:
        return
    vs[sp, GRAD] = 0.0
    vs[sp, GRAD + 1] = 0.0
    vs[sp, GRAD + 2] = 0.0
    vs[sp, COLOR] = DEFAULT_GREY
    vs[sp, COLOR + 1] = DEFAULT_GREY
    vs[sp, COLOR + 2] = DEFAULT_GREY


@kernel(inline="always")
def apply_warp(op, p, o, x, y, z, ps, pp, mode):
    """A warp's query map at the frame point (x, y, z); with mode >= GRADIENT its Jacobian is
    chained into ps[pp, JACOBIAN:JACOBIAN + 9] (the Jacobian from the point stack's frame to
    the outer one).

    params[o:o + 9] is the signed permutation Pm to the warp's canonical axes: q = Pm^T w(Pm x)
    and J = Pm^T Jc Pm.  Compiled into each caller with the warp's map: where mode is the
    constant VALUE (a region carried through the warp, the bounds' field values) the Jacobian
    is never computed."""
    X, Y, Z = to_canonical(p, o, x, y, z)
    qx, qy, qz, j00, j01, j02, j10, j11, j12, j20, j21, j22 = warp_map(op, p, o, X, Y, Z)
    nx, ny, nz = from_canonical(p, o, qx, qy, qz)
    if mode == VALUE:
        return nx, ny, nz
    for col in range(3):  # column col of Jc Pm, then of Pm^T (Jc Pm)
        m0, m1, m2 = p[o + col], p[o + 3 + col], p[o + 6 + col]
        a0 = j00 * m0 + j01 * m1 + j02 * m2
        a1 = j10 * m0 + j11 * m1 + j12 * m2
        a2 = j20 * m0 + j21 * m1 + j22 * m2
        for r in range(3):
            ps[pp, WARP + 3 * r + col] = p[o + r] * a0 + p[o + 3 + r] * a1 + p[o + 6 + r] * a2
    for r in range(3):  # times the Jacobian so far
        for col in range(3):
            acc = 0.0
            for m in range(3):
                acc += ps[pp, WARP + 3 * r + m] * ps[pp, JACOBIAN + 3 * m + col]
            ps[pp, WARP + 9 + 3 * r + col] = acc
    for q in range(9):
        ps[pp, JACOBIAN + q] = ps[pp, WARP + 9 + q]
    return nx, ny, nz


@kernel(inline="always")
def push_frame(p, o, x, y, z, ps, pp, mode):
    """Enter a warp's frame (PUSHPT): save the point (and, for gradients, the frame map's
    Jacobian) in ps[pp]; return the point in the frame."""
    ps[pp, POINT], ps[pp, POINT + 1], ps[pp, POINT + 2] = x, y, z  # the point to restore
    if mode >= GRADIENT:  # the Jacobian so far, for the gradient
        for r in range(3):
            for c in range(3):
                ps[pp, JACOBIAN + 3 * r + c] = p[o + 4 * r + c]
    return map_point(p, o, x, y, z)


@kernel(inline="always")
def pop_frame(vs, t, ps, pp, mode):
    """Leave a warp's frame (POPPT): the gradient on top of the stack back to the outer frame,
    g <- J^T g; return the saved point."""
    if mode >= GRADIENT:
        gx, gy, gz = vs[t, GRAD], vs[t, GRAD + 1], vs[t, GRAD + 2]
        j = JACOBIAN
        vs[t, GRAD] = ps[pp, j] * gx + ps[pp, j + 3] * gy + ps[pp, j + 6] * gz
        vs[t, GRAD + 1] = ps[pp, j + 1] * gx + ps[pp, j + 4] * gy + ps[pp, j + 7] * gz
        vs[t, GRAD + 2] = ps[pp, j + 2] * gx + ps[pp, j + 5] * gy + ps[pp, j + 8] * gz
    return ps[pp, POINT], ps[pp, POINT + 1], ps[pp, POINT + 2]


@kernel(inline="always")
def push_primitive(prog, i, px, py, pz, mode, vs, sp):
    """Push primitive i's field (and gradient, colour) at the frame point."""
    code, p = prog[0], prog[1]
    op, o = code[i, OP], code[i, OFFSET]
    qx, qy, qz = map_point(p, o, px, py, pz)
    s, sx, sy, sz = prim_s(op, p, o, qx, qy, qz)
    if s >= 1.0:
        push_zero(vs, sp, mode)
        return
    fid = int(p[o + FALLOFF])
    vs[sp, FIELD] = fo(fid, s)
    if mode == VALUE:
        return
    d = fo_ds(fid, s)
    gx, gy, gz = d * sx, d * sy, d * sz
    vs[sp, GRAD] = p[o] * gx + p[o + 4] * gy + p[o + 8] * gz
    vs[sp, GRAD + 1] = p[o + 1] * gx + p[o + 5] * gy + p[o + 9] * gz
    vs[sp, GRAD + 2] = p[o + 2] * gx + p[o + 6] * gy + p[o + 10] * gz
    if mode >= SHADE and code[i, ARG] >= 0:  # painted by a field-interpolated texture
        tu, tv = prim_uv(op, p, o, qx, qy, qz)
        vs[sp, COLOR], vs[sp, COLOR + 1], vs[sp, COLOR + 2] = texel(p, code[i, ARG], tu, tv)
    else:
        vs[sp, COLOR] = DEFAULT_GREY
        vs[sp, COLOR + 1] = DEFAULT_GREY
        vs[sp, COLOR + 2] = DEFAULT_GREY


# ----- the point mode's hooks: cur = the point (x, y, z) in the current frame --------------
@hook
def _start(prog, at, st):
    return at[0], at[1], at[2]


@hook
def point_primitive(prog, at, i, cur, pp, st, sp):
    if outside(prog[2], i, cur[0], cur[1], cur[2]):
        push_zero(st[0], sp, at[3])
    else:
        push_primitive(prog, i, cur[0], cur[1], cur[2], at[3], st[0], sp)


@hook
def _operator(prog, at, i, cur, st, b, k):
    code = prog[0]
    combine(code[i, OP], st[0], b, k, prog[1], code[i, OFFSET], at[3])


@hook
def _misses(prog, at, i, cur, pp, st):
    return outside(prog[2], i, cur[0], cur[1], cur[2])


@hook
def _zero(at, st, sp):
    push_zero(st[0], sp, at[3])


@hook
def _enter(prog, at, i, cur, st, pp):
    return push_frame(prog[1], prog[0][i, OFFSET], cur[0], cur[1], cur[2], st[1], pp, at[3])


@hook
def _warp(prog, at, i, cur, st, pp):
    code = prog[0]
    return apply_warp(code[i, OP], prog[1], code[i, OFFSET], cur[0], cur[1], cur[2], st[1], pp,
                      at[3])


@hook
def _leave(prog, at, i, cur, st, top, pp):
    return pop_frame(st[0], top, st[1], pp, at[3])


@hook
def point_paint(prog, at, i, cur, st, top):
    """A paint node (mode SHADE): colour the row on top where its field is > 0."""
    vs = st[0]
    if at[3] >= SHADE and vs[top, FIELD] > 0.0:
        code = prog[0]
        r, g, b = paint(code[i, OP], prog[1], code[i, OFFSET], cur[0], cur[1], cur[2],
                        vs[top, GRAD], vs[top, GRAD + 1], vs[top, GRAD + 2])
        vs[top, COLOR], vs[top, COLOR + 1], vs[top, COLOR + 2] = r, g, b


@hook
def _finish(prog, at, cur, st):
    return st[0][0, FIELD]


#: The point mode: one point's field (and gradient, colour).
POINT_MODE = Mode("point", _start, point_primitive, _operator, _misses, _zero, _enter, _warp,
                  _leave, point_paint, _finish)

#: ``point_walk(prog, (x, y, z, mode), (vs, ps))``: the field at (x, y, z); mode GRADIENT also
#: leaves the gradient in vs[0, GRAD:GRAD + 3], SHADE also the colour in vs[0, COLOR:COLOR + 3].
point_walk = linked(types.float64(PROGRAM, types.Tuple((types.float64, types.float64,
                                                        types.float64, types.int64)),
                                  STACKS))(walk(POINT_MODE))
#: :data:`point_walk` as kernels call it.
eval_point = point_walk.call


@kernel(nrt=True, nogil=True)
def eval_range(start, stop, prog, P, mode, depth, out):
    """Evaluate points start..stop - 1 of (N, 3) P; fills out = (f, g, c) by mode (one part of
    ``threads.parallel_for``).  A point with a NaN coordinate has a NaN field and gradient and
    the grey of a zero field, as on the grid path (``batch.eval_sorted``), whatever boxes its
    other coordinates pass."""
    out_f, out_g, out_c = out
    st = scratch(depth)
    vs = st[0]
    for m in range(start, stop):
        if nan_point(P[m, 0], P[m, 1], P[m, 2]):
            out_f[m] = np.nan
            for r in range(3):
                if mode >= GRADIENT:
                    out_g[m, r] = np.nan
                if mode >= SHADE:
                    out_c[m, r] = DEFAULT_GREY
            continue
        if mode == VALUE:
            out_f[m] = eval_point(prog, (P[m, 0], P[m, 1], P[m, 2], VALUE), st)
            continue
        out_f[m] = eval_point(prog, (P[m, 0], P[m, 1], P[m, 2], SHADE), st)
        if mode >= GRADIENT:
            out_g[m, 0], out_g[m, 1], out_g[m, 2] = vs[0, GRAD], vs[0, GRAD + 1], vs[0, GRAD + 2]
        if mode >= SHADE:
            out_c[m, 0], out_c[m, 1], out_c[m, 2] = vs[0, COLOR], vs[0, COLOR + 1], vs[0, COLOR + 2]
