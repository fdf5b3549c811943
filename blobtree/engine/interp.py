"""The program interpreter: field, gradient and colour at a point, and Lipschitz bounds over boxes
and segments (see ``program.py`` for the layout and docs/engine.md for how to call these from
your own kernels).

The program is postfix: primitives push (field, gradient, colour) on a value stack, operators pop
their children and push the result, warps push a transformed point on a point stack.  Every
primitive and every BOX instruction first tests its box; a miss pushes 0 and jumps over the
subtree (``code[i, SKIP]``), so a subtree whose box misses the point costs one test.  Each node
type's maths comes from its own kernels through ``dispatch``.

``eval_point`` and the two bound passes (``_lipschitz``, ``_bounded``) are compiled once and
called (not inlined by numba) from the mesher, the ray tracer and the batches: that keeps the
first run's compilation short.  The thin entry points around them (``lipschitz_box``,
``bound_box_at``, ``lipschitz_segment``, ``_bound_at``) are inlined into their callers instead:
numba links and optimises again the whole code a compiled function calls, so each entry point
compiled on its own would take two to three seconds of a first run for a few lines.  All are
compiled without reference counting (docs/engine.md).
"""

from __future__ import annotations

import math

import numpy as np

from ..nodes.kernel_math import (
    fo,
    fo_ds,
    from_canonical,
    gaps,
    map_box,
    map_point,
    norm_of,
    safe_distances,
    texel,
    to_canonical,
)
from ..nodes.layout import (
    ABOVE,
    ARG,
    BELOW,
    BOUND,
    COLOR,
    COLUMNS,
    FALLOFF,
    FALLS,
    FIELD,
    FRAME_NORM,
    GRAD,
    GRADIENT,
    JACOBIAN,
    MAP_NORM,
    OFFSET,
    OP,
    POINT,
    POINT_COLUMNS,
    REGION,
    RISES,
    SAVED_BOX,
    SHADE,
    SKIP,
    VALUE,
    WARP,
)
from ..runtime.jit import kernel
from .dispatch import (
    K_BOX,
    K_OPERATOR,
    K_PAINT,
    K_POPPT,
    K_PRIMITIVE,
    K_PUSHPT,
    K_WARP,
    LIPSCHITZ,
    MAX,
    MONOTONE_FIRST,
    MONOTONE_REST,
    NORM,
    SCALED,
    VALUE_BOUND,
    combine,
    kind_of,
    op_bound,
    paint,
    prim_along,
    prim_lipschitz,
    prim_rise,
    prim_s,
    prim_uv,
    warp_map,
)

DEFAULT_GREY = 0.8


@kernel(nrt=True)
def scratch(depth):
    """Per-thread stacks for ``eval_point`` and the bound passes: values (depth, COLUMNS):
    field, gradient, colour (and a bound's rise and fall); and points (depth, 30): the point to
    restore, the Jacobian to the outer frame, warp scratch."""
    return np.empty((depth, COLUMNS)), np.empty((depth, POINT_COLUMNS))


@kernel
def outside(boxes, i, x, y, z):
    """Is (x, y, z) outside instruction i's box?"""
    return (x < boxes[i, 0] or y < boxes[i, 1] or z < boxes[i, 2]
            or x > boxes[i, 3] or y > boxes[i, 4] or z > boxes[i, 5])


@kernel(inline="always")
def nan_point(x, y, z):
    """Has (x, y, z) a NaN coordinate?  Such a point has no field: it evaluates to NaN (field
    and gradient) on every path.  (No branches: it vectorises.)"""
    return (x != x) | (y != y) | (z != z)


@kernel
def misses(boxes, i, lox, loy, loz, hix, hiy, hiz):
    """Does the box [lo, hi] miss instruction i's box?"""
    return (hix < boxes[i, 0] or hiy < boxes[i, 1] or hiz < boxes[i, 2]
            or lox > boxes[i, 3] or loy > boxes[i, 4] or loz > boxes[i, 5])


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
    chained into ps[pp, 3:12] (the Jacobian from the point stack's frame to the outer one).

    params[o:o + 9] is the signed permutation Pm to the warp's canonical axes: q = Pm^T w(Pm x)
    and J = Pm^T Jc Pm.  Compiled into each caller with the warp's map: where mode is the
    constant 0 (a region carried through the warp, the bounds' field values) the Jacobian is
    never computed: the Murex's rays trace about 12% faster for it, for 5 s more of compiling
    on a first run."""
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
def paint_top(op, p, o, x, y, z, vs, t, mode):
    """A paint node (mode SHADE): colour the value on top of the stack where its field is > 0."""
    if mode >= SHADE and vs[t, FIELD] > 0.0:
        r, g, b = paint(op, p, o, x, y, z, vs[t, GRAD], vs[t, GRAD + 1], vs[t, GRAD + 2])
        vs[t, COLOR], vs[t, COLOR + 1], vs[t, COLOR + 2] = r, g, b


@kernel(inline="always")
def push_primitive(op, code, i, p, o, px, py, pz, mode, vs, sp):
    """Push a primitive's field (and gradient, colour) at the frame point."""
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


@kernel
def eval_point(code, params, boxes, x, y, z, mode, vs, ps):
    """Field at (x, y, z); mode GRADIENT also leaves the gradient in vs[0, GRAD:GRAD + 3], mode
    SHADE also the colour in vs[0, COLOR:COLOR + 3] (VALUE: the field only, for tracing).
    Compiled once for all modes (``jit.kernel`` types constants as plain values): branches skip
    the work a mode does not need.  (A copy per mode, with that work folded away, traces the
    Murex about 14% faster but takes 33 s more to compile on a first run.)"""
    n = code.shape[0]
    p = params
    sp = 0
    pp = 0
    px, py, pz = x, y, z
    i = 0
    while i < n:
        op = code[i, OP]
        o = code[i, OFFSET]
        kind = kind_of(op)
        if kind == K_PRIMITIVE:
            if outside(boxes, i, px, py, pz):
                push_zero(vs, sp, mode)
            else:
                push_primitive(op, code, i, p, o, px, py, pz, mode, vs, sp)
            sp += 1
            i += 1
        elif kind == K_OPERATOR:
            k = code[i, ARG]
            b = sp - k
            combine(op, vs, b, k, p, o, mode)
            sp = b + 1
            i += 1
        elif kind == K_BOX or kind == K_PUSHPT or kind == K_WARP:
            if outside(boxes, i, px, py, pz):
                push_zero(vs, sp, mode)
                sp += 1
                i = code[i, SKIP]
                continue
            if kind == K_PUSHPT:
                pp += 1
                px, py, pz = push_frame(p, o, px, py, pz, ps, pp, mode)
            elif kind == K_WARP:
                px, py, pz = apply_warp(op, p, o, px, py, pz, ps, pp, mode)
            i += 1
        elif kind == K_POPPT:
            px, py, pz = pop_frame(vs, sp - 1, ps, pp, mode)
            pp -= 1
            i += 1
        elif kind == K_PAINT:
            paint_top(op, p, o, px, py, pz, vs, sp - 1, mode)
            i += 1
        else:  # K_ZERO
            push_zero(vs, sp, mode)
            sp += 1
            i += 1
    return vs[0, FIELD]


@kernel(inline="always")
def half_diagonal(lox, loy, loz, hix, hiy, hiz):
    """The radius of the ball around the box [lo, hi] (about its centre)."""
    return 0.5 * math.sqrt((hix - lox) ** 2 + (hiy - loy) ** 2 + (hiz - loz) ** 2)


@kernel(inline="always")
def _prim_bound(op, p, o, lip, ray, pp, lox, loy, loz, hix, hiy, hiz, rad, ox, oy, oz, dx, dy,
                dz, length):
    """A primitive's bound over the region (the box [lo, hi] and the ball of radius ``rad``
    about its centre), or along the segment where it has a directional one (outside warps,
    ``ray``)."""
    if ray and pp == 0:
        along = prim_along(op, p, o, ox, oy, oz, dx, dy, dz, length)
        if along >= 0.0:
            return along
    cx, cy, cz, hx, hy, hz = map_box(p, o, lox, loy, loz, hix, hiy, hiz)
    return prim_lipschitz(op, p, o, lip, cx, cy, cz, hx, hy, hz, rad * p[o + MAP_NORM])


@kernel
def carry(kind, op, p, o, lip, lox, loy, loz, hix, hiy, hiz, rad, scratch):
    """The region, within the box [lo, hi] and the ball of radius ``rad`` about its centre,
    carried into a PUSHPT's frame (the box around its affine image, the ball grown by the map's
    norm) or through a WARP (a ball, and the cube around it, about the warped centre: the query
    map moves points by at most its stretch ``lip`` times the distance): the new box and ball
    radius.  A warp's region is a ball: the cube around it reaches sqrt(3) times further.
    ``scratch``: a point stack the warp may not use."""
    if kind == K_PUSHPT:
        cx, cy, cz, ex, ey, ez = map_box(p, o, lox, loy, loz, hix, hiy, hiz)
        return cx - ex, cy - ey, cz - ez, cx + ex, cy + ey, cz + ez, rad * p[o + FRAME_NORM]
    cx, cy, cz = 0.5 * (lox + hix), 0.5 * (loy + hiy), 0.5 * (loz + hiz)
    reach = lip * min(rad, half_diagonal(lox, loy, loz, hix, hiy, hiz))
    wx, wy, wz = apply_warp(op, p, o, cx, cy, cz, scratch, 0, VALUE)
    return wx - reach, wy - reach, wz - reach, wx + reach, wy + reach, wz + reach, reach


@kernel
def support_misses(code, p, lips, i, lox, loy, loz, hix, hiy, hiz, rad):
    """Is primitive i zero all over the region (its frame's coordinates: within the box
    [lo, hi] and the ball of radius ``rad`` about its centre)?  True when its bound on ``|grad f|``
    there is 0 (its field is constant there) and it is zero at the centre: a tighter test than
    its box's (a ball's support against a box, a cone's distance from its axis)."""
    op, o = code[i, OP], code[i, OFFSET]
    cx, cy, cz, hx, hy, hz = map_box(p, o, lox, loy, loz, hix, hiy, hiz)
    if prim_lipschitz(op, p, o, lips[i], cx, cy, cz, hx, hy, hz, rad * p[o + MAP_NORM]) > 0.0:
        return False
    return prim_s(op, p, o, cx, cy, cz)[0] >= 1.0


@kernel
def _rule(op, p, o, vs, col, b, sp):
    """An operator's ``LIPSCHITZ`` rule over its children's bounds in vs[b:sp, col]."""
    acc = 0.0
    if LIPSCHITZ[op] == NORM:
        return norm_of(vs, b, sp, col, p[o])
    if LIPSCHITZ[op] == MAX:
        for j in range(b, sp):
            acc = max(acc, vs[j, col])
        return acc
    for j in range(b, sp):
        acc += vs[j, col]
    return acc * p[o] if LIPSCHITZ[op] == SCALED else acc


@kernel(inline="always")
def _prim_moves(op, p, o, pp, lox, loy, loz, hix, hiy, hiz, dx, dy, dz, spread, bound, vs, sp):
    """How fast primitive op's field can rise and fall over the box along the cone (unit
    directions within ``spread`` of d), into vs[sp, RISES] and vs[sp, FALLS]: its ``rise``
    kernel outside warps, at most its plain bound; the fall is the plain bound (only a
    difference's carving needs it, and its ``rise`` along -d would cost every primitive a
    second call)."""
    vs[sp, RISES] = vs[sp, FALLS] = bound
    if pp == 0:
        rise = prim_rise(op, p, o, lox, loy, loz, hix, hiy, hiz, dx, dy, dz, spread)
        if rise >= 0.0:
            vs[sp, RISES] = min(rise, bound)


@kernel(inline="always")
def _op_moves(op, p, o, vs, b, sp, bound):
    """An operator's rise and fall along the cone, into vs[b, RISES] and vs[b, FALLS]: its rule
    over what each child's moves do to it (``MONOTONE``: a child it grows with gives its rise
    to the rise and its fall to the fall, one it shrinks with the other way round, one it moves
    either way with its plain bound vs[j, FIELD] to both), at most its own ``bound``."""
    for j in range(b, sp):
        sign = MONOTONE_FIRST[op] if j == b else MONOTONE_REST[op]
        if sign == 0:
            vs[j, RISES] = vs[j, FALLS] = vs[j, FIELD]
        elif sign < 0:
            vs[j, RISES], vs[j, FALLS] = vs[j, FALLS], vs[j, RISES]
    rise = min(_rule(op, p, o, vs, RISES, b, sp), bound)
    fall = min(_rule(op, p, o, vs, FALLS, b, sp), bound)
    vs[b, RISES], vs[b, FALLS] = rise, fall


@kernel
def _lipschitz(code, params, boxes, lips, lox, loy, loz, hix, hiy, hiz, ray, ox, oy, oz, dx,
               dy, dz, length, spread, vs):
    """``lipschitz_box``; with ``ray``, primitives with a directional bound (outside warps) take
    it along the segment o + t d, 0 <= t <= length inside the box.  With ``spread`` >= 0 also
    a bound on how fast the field *rises* along every unit direction within ``spread`` of the
    unit vector d (a cone of rays): each row carries how fast it can rise and fall there (a
    primitive outside warps rises as its ``rise`` kernel says, 0 where the whole box moves
    away from it: :func:`_prim_moves`; an operator by :func:`_op_moves`; anything else as fast
    as its plain bound).  Returns (the bound, the rise: the bound when ``spread`` < 0).  Bounds
    in vs[:, 0], rises and falls in vs[:, RISES] and vs[:, FALLS], the regions saved across warps
    in vs[pp, 1:7] (no field values: see :func:`_bounded`).  The region also lies within the
    ball of radius ``rad`` about the box's centre (:func:`carry`: a warp's region is a ball);
    leaving a warp, that is again the box's own."""
    n = code.shape[0]
    rising = spread >= 0.0
    sp = 0
    pp = 0
    rad = half_diagonal(lox, loy, loz, hix, hiy, hiz)
    i = 0
    while i < n:
        op = code[i, OP]
        kind = kind_of(op)
        if kind == K_PRIMITIVE:
            vs[sp, FIELD] = vs[sp, RISES] = vs[sp, FALLS] = 0.0
            if not misses(boxes, i, lox, loy, loz, hix, hiy, hiz):
                o = code[i, OFFSET]
                vs[sp, FIELD] = _prim_bound(op, params, o, lips[i], ray, pp, lox, loy, loz, hix,
                                            hiy, hiz, rad, ox, oy, oz, dx, dy, dz, length)
                if rising:
                    _prim_moves(op, params, o, pp, lox, loy, loz, hix, hiy, hiz, dx, dy, dz,
                                spread, vs[sp, FIELD], vs, sp)
            sp += 1
            i += 1
        elif kind == K_OPERATOR:
            b = sp - code[i, ARG]
            o = code[i, OFFSET]
            bound = _rule(op, params, o, vs, 0, b, sp)
            if rising:
                _op_moves(op, params, o, vs, b, sp, bound)
            vs[b, FIELD] = bound
            sp = b + 1
            i += 1
        elif kind == K_BOX or kind == K_PUSHPT or kind == K_WARP:
            if misses(boxes, i, lox, loy, loz, hix, hiy, hiz):
                vs[sp, FIELD] = vs[sp, RISES] = vs[sp, FALLS] = 0.0
                sp += 1
                i = code[i, SKIP]
                continue
            if kind == K_PUSHPT:  # save the region
                pp += 1
                vs[pp, REGION], vs[pp, REGION + 1], vs[pp, REGION + 2] = lox, loy, loz
                vs[pp, REGION + 3], vs[pp, REGION + 4], vs[pp, REGION + 5] = hix, hiy, hiz
            if kind != K_BOX:
                lox, loy, loz, hix, hiy, hiz, rad = carry(kind, op, params, code[i, OFFSET],
                                                           lips[i], lox, loy, loz, hix, hiy, hiz,
                                                           rad, vs)
            i += 1
        elif kind == K_POPPT:  # (a warped subtree moves as fast as its bound)
            vs[sp - 1, FIELD] *= lips[i]
            vs[sp - 1, RISES] = vs[sp - 1, FALLS] = vs[sp - 1, FIELD]
            lox, loy, loz = vs[pp, REGION], vs[pp, REGION + 1], vs[pp, REGION + 2]
            hix, hiy, hiz = vs[pp, REGION + 3], vs[pp, REGION + 4], vs[pp, REGION + 5]
            rad = half_diagonal(lox, loy, loz, hix, hiy, hiz)
            pp -= 1
            i += 1
        elif kind == K_PAINT:
            i += 1
        else:  # K_ZERO
            vs[sp, FIELD] = vs[sp, RISES] = vs[sp, FALLS] = 0.0
            sp += 1
            i += 1
    return vs[0, FIELD], (vs[0, RISES] if rising else vs[0, FIELD])


@kernel
def _bounded(code, params, boxes, lips, lox, loy, loz, hix, hiy, hiz, ray, ox, oy, oz, dx, dy,
             dz, length, vs, ps):
    """:func:`_lipschitz` that also evaluates the field at o (a point of the box) and hands
    each operator its children's values: an operator with a ``bound`` kernel uses them to leave
    out children that cannot set its field anywhere in the region (a CSG operator's loser), and
    to say how far its field surely stays below and above ISO.  Returns (the field at o; the
    bound; how far from o the field surely stays below ISO, and above it).  Costlier than
    :func:`_lipschitz` where no such operator is (a program of blends).  It bounds no rise
    along rays (:func:`_lipschitz`): on the Murex, whose ray programs all take this pass, the
    rises save nothing measurable (``bench/ab.py`` at 256x256: within the noise).

    Stacks: fields in vs[:, 0], bounds in vs[:, BOUND], the distances an operator proved in
    vs[:, BELOW] and vs[:, ABOVE] (``kernel_math.safe_distances`` adds those of the value and
    bound); ps[pp, 0:3] saves the point and ps[pp, 3:9] the region across warps."""
    n = code.shape[0]
    p = params
    sp = 0
    pp = 0
    px, py, pz = ox, oy, oz
    rad = half_diagonal(lox, loy, loz, hix, hiy, hiz)
    i = 0
    while i < n:
        op = code[i, OP]
        kind = kind_of(op)
        if kind == K_PRIMITIVE:
            vs[sp, FIELD] = vs[sp, BOUND] = vs[sp, BELOW] = vs[sp, ABOVE] = 0.0
            if not misses(boxes, i, lox, loy, loz, hix, hiy, hiz):
                vs[sp, BOUND] = _prim_bound(op, p, code[i, OFFSET], lips[i], ray, pp, lox, loy, loz,
                                            hix, hiy, hiz, rad, ox, oy, oz, dx, dy, dz, length)
                if not outside(boxes, i, px, py, pz):
                    push_primitive(op, code, i, p, code[i, OFFSET], px, py, pz, VALUE, vs, sp)
            sp += 1
            i += 1
        elif kind == K_OPERATOR:
            k = code[i, ARG]
            b = sp - k
            o = code[i, OFFSET]
            reach = math.sqrt((hix - lox) ** 2 + (hiy - loy) ** 2 + (hiz - loz) ** 2)
            bound, below, above = op_bound(op, vs, b, k, p, o, reach)  # before combine
            if bound < 0.0:
                bound = _rule(op, p, o, vs, BOUND, b, sp)
            combine(op, vs, b, k, p, o, 0)
            vs[b, BOUND], vs[b, BELOW], vs[b, ABOVE] = bound, below, above
            sp = b + 1
            i += 1
        elif kind == K_BOX or kind == K_PUSHPT or kind == K_WARP:
            if misses(boxes, i, lox, loy, loz, hix, hiy, hiz):
                vs[sp, FIELD] = vs[sp, BOUND] = vs[sp, BELOW] = vs[sp, ABOVE] = 0.0
                sp += 1
                i = code[i, SKIP]
                continue
            o = code[i, OFFSET]
            if kind == K_PUSHPT:  # save the point and region, carry them into the warp's frame
                pp += 1
                ps[pp, POINT], ps[pp, POINT + 1], ps[pp, POINT + 2] = px, py, pz
                ps[pp, SAVED_BOX], ps[pp, SAVED_BOX + 1], ps[pp, SAVED_BOX + 2] = lox, loy, loz
                ps[pp, SAVED_BOX + 3], ps[pp, SAVED_BOX + 4], ps[pp, SAVED_BOX + 5] = hix, hiy, hiz
                px, py, pz = map_point(p, o, px, py, pz)
            elif kind == K_WARP:
                px, py, pz = apply_warp(op, p, o, px, py, pz, ps, 0, VALUE)
            if kind != K_BOX:
                lox, loy, loz, hix, hiy, hiz, rad = carry(kind, op, p, o, lips[i], lox, loy,
                                                           loz, hix, hiy, hiz, rad, ps)
            i += 1
        elif kind == K_POPPT:  # frame distances are at most lips[i] times the outer ones
            vs[sp - 1, BOUND] *= lips[i]
            vs[sp - 1, BELOW] /= lips[i]
            vs[sp - 1, ABOVE] /= lips[i]
            px, py, pz = ps[pp, POINT], ps[pp, POINT + 1], ps[pp, POINT + 2]
            lox, loy, loz = ps[pp, SAVED_BOX], ps[pp, SAVED_BOX + 1], ps[pp, SAVED_BOX + 2]
            hix, hiy, hiz = ps[pp, SAVED_BOX + 3], ps[pp, SAVED_BOX + 4], ps[pp, SAVED_BOX + 5]
            rad = half_diagonal(lox, loy, loz, hix, hiy, hiz)
            pp -= 1
            i += 1
        elif kind == K_PAINT:
            i += 1
        else:  # K_ZERO
            vs[sp, FIELD] = vs[sp, BOUND] = vs[sp, BELOW] = vs[sp, ABOVE] = 0.0
            sp += 1
            i += 1
    below, above = safe_distances(vs, 0)
    return vs[0, FIELD], vs[0, BOUND], below, above


@kernel(inline="always")
def lipschitz_box(code, params, boxes, lips, lox, loy, loz, hix, hiy, hiz, vs):
    """A bound on ``|grad f|`` over the box [lo, hi] (world coordinates): the tree's Lipschitz rules
    (sum at blends, max at CSG) over only the primitives whose boxes meet it, each with its
    distance-aware bound; through a warp the region is carried into the warp's child frame (as
    the ball about the warped centre grown by the warp's stretch, and the cube around it:
    :func:`carry`) and the result scaled back."""
    return _lipschitz(code, params, boxes, lips, lox, loy, loz, hix, hiy, hiz, False, 0.0, 0.0,
                      0.0, 0.0, 0.0, 0.0, 0.0, -1.0, vs)[0]


@kernel
def bounds_use_values(code):
    """Whether the program's root is an operator whose bound uses field values (a CSG root):
    then the bound pass that evaluates the field (:func:`_bounded`) is worth its extra work; a
    program of blends gains nothing from it."""
    n = code.shape[0]
    return n > 0 and VALUE_BOUND[code[n - 1, OP]]


@kernel(inline="always")
def _bound_at(code, params, boxes, lips, lox, loy, loz, hix, hiy, hiz, ray, x, y, z, dx, dy,
              dz, length, spread, values, vs, ps):
    """:func:`_bounded` with ``values``; else the field by ``eval_point``, the plain bound and
    the distances those two give (cheaper for a program of blends); with ``spread`` >= 0 the
    bound is the rise along the cone of directions within ``spread`` of d (the distances stay
    the plain bound's, which hold in every direction: infinite below ISO where the field is
    the same all over the box)."""
    if values:
        return _bounded(code, params, boxes, lips, lox, loy, loz, hix, hiy, hiz, ray, x, y, z,
                        dx, dy, dz, length, vs, ps)
    f = eval_point(code, params, boxes, x, y, z, VALUE, vs, ps)
    bound, rise = _lipschitz(code, params, boxes, lips, lox, loy, loz, hix, hiy, hiz, ray, x, y,
                             z, dx, dy, dz, length, spread, vs)
    below, above = gaps(f, bound)
    return f, rise, below, above


@kernel(inline="always")
def bound_box_at(code, params, boxes, lips, lox, loy, loz, hix, hiy, hiz, x, y, z, dx, dy, dz,
                 spread, values, vs, ps):
    """(The field at (x, y, z), a point of the box [lo, hi]; a bound on ``|grad f|`` over the box;
    how far from the point within the box the field surely stays below ISO; and above it).
    With ``values`` (see :func:`bounds_use_values`), CSG operators drop the bounds of children
    that the field values at the point show cannot set the result anywhere in the box, and
    prove longer distances (:func:`_bounded`).  Without, and with ``spread`` >= 0, the bound
    is only on how fast the field rises along unit directions within ``spread`` of the unit
    vector d (rays that leave some primitives, or pass them sideways: :func:`_lipschitz`); the
    distances are still those of the bound without the cone."""
    return _bound_at(code, params, boxes, lips, lox, loy, loz, hix, hiy, hiz, False, x, y, z,
                     dx, dy, dz, 0.0, spread, values, vs, ps)


@kernel(inline="always")
def lipschitz_segment(code, params, boxes, lips, ox, oy, oz, dx, dy, dz, length, values, vs,
                      ps):
    """(The field at o; a bound on how fast f rises along the segment o + t d, 0 <= t <= length,
    d a unit vector; how far along it the field surely stays below ISO; and above it):
    :func:`bound_box_at` over the segment's box with d's rise, except that primitives with a
    directional bound (point primitives, outside warps) take it instead (never larger, and
    small where the segment passes a primitive sideways, so grazing rays take long steps)."""
    bx, by, bz = ox + length * dx, oy + length * dy, oz + length * dz
    return _bound_at(code, params, boxes, lips, min(ox, bx), min(oy, by), min(oz, bz),
                     max(ox, bx), max(oy, by), max(oz, bz), True, ox, oy, oz, dx, dy, dz, length,
                     0.0, values, vs, ps)


@kernel(nrt=True, nogil=True)
def eval_range(start, stop, code, params, boxes, P, mode, depth, out_f, out_g, out_c):
    """Evaluate points start..stop - 1 of (N, 3) P; fills out_f and, by mode, out_g / out_c
    (one part of :func:`parallel.parallel_for`).  A point with a NaN coordinate has a NaN
    field and gradient and the grey of a zero field, as on the grid path
    (``batch.eval_sorted``), whatever boxes its other coordinates pass."""
    vs, ps = scratch(depth)
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
            out_f[m] = eval_point(code, params, boxes, P[m, 0], P[m, 1], P[m, 2], VALUE, vs, ps)
            continue
        out_f[m] = eval_point(code, params, boxes, P[m, 0], P[m, 1], P[m, 2], SHADE, vs, ps)
        if mode >= GRADIENT:
            out_g[m, 0], out_g[m, 1], out_g[m, 2] = vs[0, GRAD], vs[0, GRAD + 1], vs[0, GRAD + 2]
        if mode >= SHADE:
            out_c[m, 0], out_c[m, 1], out_c[m, 2] = vs[0, COLOR], vs[0, COLOR + 1], vs[0, COLOR + 2]


@kernel(nrt=True, nogil=True)
def bound_range(start, stop, code, params, boxes, lips, lo, hi, at, depth, out):
    """``bound_box_at`` for boxes start..stop - 1 of (M, 3) lo, hi at their points ``at``: the
    four values in the rows of out (M, 4)."""
    vs, ps = scratch(depth)
    for m in range(start, stop):
        out[m, 0], out[m, 1], out[m, 2], out[m, 3] = bound_box_at(
            code, params, boxes, lips, lo[m, 0], lo[m, 1], lo[m, 2], hi[m, 0], hi[m, 1],
            hi[m, 2], at[m, 0], at[m, 1], at[m, 2], 0.0, 0.0, 0.0, -1.0, True, vs, ps)


@kernel(nrt=True, nogil=True)
def lipschitz_range(start, stop, code, params, boxes, lips, lo, hi, depth, out):
    """``lipschitz_box`` for boxes start..stop - 1 of (M, 3) lo, hi."""
    vs, _ = scratch(depth)
    for m in range(start, stop):
        out[m] = lipschitz_box(code, params, boxes, lips, lo[m, 0], lo[m, 1], lo[m, 2],
                               hi[m, 0], hi[m, 1], hi[m, 2], vs)
