"""The bound passes: Lipschitz bounds over a region, with or without the field's values (the
walk's ``lipschitz`` and ``bounded`` modes), and the entry points the tracer, the mesher and
``specialize`` call.

Both passes take ``at``, a tuple of :data:`AT` floats: the region's box ``at[LO:LO + 3]``,
``at[HI:HI + 3]``; a point of it ``at[ORIGIN:ORIGIN + 3]`` (where ``bounded`` evaluates the field,
and a segment's start); a unit direction ``at[DIRECTION:DIRECTION + 3]``, a segment's
``at[LENGTH]``, a cone's ``at[SPREAD]`` (< 0: none) and ``at[RAY]`` (1: primitives outside warps
take their directional bound along the segment).  The region also lies within the ball of
radius ``rad`` about the box's centre (a warp's region is a ball: :func:`carry`); leaving a
warp, it is again the box's own.  The walks' state ``cur`` is (lox, loy, loz, hix, hiy, hiz,
rad), the bounded pass's followed by its point in the frame.
"""

from __future__ import annotations

import math

from numba import types

from ..nodes.kernel_math import (
    fo,
    gaps,
    map_box,
    map_point,
    norm_of,
    safe_distances,
    to_canonical,
)
from ..nodes.kernels import LIPSCHITZ_RULES
from ..nodes.layout import (
    ABOVE,
    BELOW,
    BOUND,
    FALLOFF,
    FALLS,
    FIELD,
    FRAME_NORM,
    LEAST,
    MAP_NORM,
    MOST,
    OFFSET,
    OP,
    POINT,
    REGION,
    RISES,
    SAVED_BOX,
    VALUE,
)
from ..nodes.node import ISO
from ..runtime.jit import kernel, linked
from .dispatch import (
    LIPSCHITZ,
    MAX,
    MONOTONE_FIRST,
    MONOTONE_REST,
    NORM,
    SCALED,
    SUM,
    VALUE_BOUND,
    combine,
    op_bound,
    prim_along,
    prim_lipschitz,
    prim_rise,
    prim_s,
    prim_span,
    warp_stretch,
)
from .point import (
    PROGRAM,
    STACKS,
    apply_warp,
    eval_point,
    misses,
    outside,
    push_primitive,
    scratch,
)
from .walk import Mode, hook, walk

#: Places in a bound pass's ``at`` (see the module doc), and its length.
LO, HI, ORIGIN, DIRECTION, LENGTH, SPREAD, RAY = 0, 3, 6, 9, 12, 13, 14
AT = 15
#: The Lipschitz rules the passes apply (:func:`_rule`); an operator declaring any other is
#: refused on import.
RULES = {SUM, MAX, SCALED, NORM}
if set(range(len(LIPSCHITZ_RULES))) != RULES:
    raise ValueError(f"the bound passes apply the Lipschitz rules "
                     f"{[LIPSCHITZ_RULES[r] for r in sorted(RULES)]}, the nodes declare "
                     f"{list(LIPSCHITZ_RULES)}")


@kernel(inline="always")
def half_diagonal(lox, loy, loz, hix, hiy, hiz):
    """The radius of the ball around the box [lo, hi] (about its centre)."""
    return 0.5 * math.sqrt((hix - lox) ** 2 + (hiy - loy) ** 2 + (hiz - loz) ** 2)


@kernel(inline="always")
def region_stretch(prog, i, region):
    """A bound on the norm of warp i's Jacobian over ``region`` (its frame's coordinates): its
    ``stretch`` kernel's over the region's box in canonical axes, at most lips[i] (its stretch
    over its whole box)."""
    code, p = prog[0], prog[1]
    o = code[i, OFFSET]
    c0, c1, c2 = to_canonical(p, o, region[0], region[1], region[2])
    d0, d1, d2 = to_canonical(p, o, region[3], region[4], region[5])
    return min(prog[3][i], warp_stretch(code[i, OP], p, o, min(c0, d0), min(c1, d1), min(c2, d2),
                                        max(c0, d0), max(c1, d1), max(c2, d2)))


@kernel
def carry(entering, prog, i, region, scratch):
    """``region`` (lox, loy, loz, hix, hiy, hiz, rad: the box and the ball of radius rad about
    its centre) carried into the frame of PUSHPT i (``entering``: the box around its affine
    image, the ball grown by the map's norm) or through warp i (a ball, and the cube around
    it, about the warped centre: the query map moves points by at most its stretch over the
    region, :func:`region_stretch`, times the distance): the new region.  A warp's region is a
    ball: the cube around it reaches sqrt(3) times further.  ``scratch``: a point stack the warp
    may not use."""
    code, p = prog[0], prog[1]
    o = code[i, OFFSET]
    lox, loy, loz, hix, hiy, hiz, rad = region
    if entering:
        cx, cy, cz, ex, ey, ez = map_box(p, o, lox, loy, loz, hix, hiy, hiz)
        return cx - ex, cy - ey, cz - ez, cx + ex, cy + ey, cz + ez, rad * p[o + FRAME_NORM]
    cx, cy, cz = 0.5 * (lox + hix), 0.5 * (loy + hiy), 0.5 * (loz + hiz)
    reach = region_stretch(prog, i, region) * min(rad, half_diagonal(lox, loy, loz, hix, hiy,
                                                                     hiz))
    wx, wy, wz = apply_warp(code[i, OP], p, o, cx, cy, cz, scratch, 0, VALUE)
    return wx - reach, wy - reach, wz - reach, wx + reach, wy + reach, wz + reach, reach


@kernel
def support_misses(prog, i, region):
    """Is primitive i zero all over ``region`` (its frame's coordinates, as :func:`carry`
    takes it)?  True when its bound on ``|grad f|`` there is 0 (its field is constant there) and
    it is zero at the centre: a tighter test than its box's (a ball's support against a box, a
    cone's distance from its axis)."""
    code, p, lips = prog[0], prog[1], prog[3]
    op, o = code[i, OP], code[i, OFFSET]
    cx, cy, cz, hx, hy, hz = map_box(p, o, region[0], region[1], region[2], region[3], region[4],
                                     region[5])
    if prim_lipschitz(op, p, o, lips[i], cx, cy, cz, hx, hy, hz, region[6] * p[o + MAP_NORM]) > 0.0:
        return False
    return prim_s(op, p, o, cx, cy, cz)[0] >= 1.0


@kernel
def _rule(op, p, o, vs, col, b, e):
    """Operator op's ``LIPSCHITZ`` rule over its children's bounds in vs[b:e, col]."""
    rule = LIPSCHITZ[op]
    if rule == NORM:
        return norm_of(vs, b, e, col, p[o])
    acc = 0.0
    if rule == MAX:
        for j in range(b, e):
            acc = max(acc, vs[j, col])
        return acc
    for j in range(b, e):
        acc += vs[j, col]
    return acc * p[o] if rule == SCALED else acc  # SUM


@kernel(inline="always")
def _prim_along(prog, i, at, pp):
    """Primitive i's directional bound along the segment (outside warps, ``at[RAY]``), or -1
    where it has none (then its bound over the region: :func:`_prim_bound`)."""
    if not (at[RAY] > 0.0 and pp == 0):
        return -1.0
    code = prog[0]
    return prim_along(code[i, OP], prog[1], code[i, OFFSET], at[ORIGIN], at[ORIGIN + 1],
                      at[ORIGIN + 2], at[DIRECTION], at[DIRECTION + 1], at[DIRECTION + 2],
                      at[LENGTH])


@kernel(inline="always")
def _local(prog, i, cur):
    """The region ``cur`` in primitive i's own coordinates: the centre and half extents of its
    box, and the radius of its ball."""
    p, o = prog[1], prog[0][i, OFFSET]
    cx, cy, cz, hx, hy, hz = map_box(p, o, cur[0], cur[1], cur[2], cur[3], cur[4], cur[5])
    return cx, cy, cz, hx, hy, hz, cur[6] * p[o + MAP_NORM]


@kernel(inline="always")
def _prim_bound(prog, i, local):
    """Primitive i's bound on ``|grad f|`` over the region (:func:`_local`)."""
    code, p = prog[0], prog[1]
    cx, cy, cz, hx, hy, hz, r = local
    return prim_lipschitz(code[i, OP], p, code[i, OFFSET], prog[3][i], cx, cy, cz, hx, hy, hz, r)


@kernel(inline="always")
def _prim_moves(prog, i, at, cur, pp, bound, vs, sp):
    """How fast primitive i's field can rise and fall over the region along the cone (unit
    directions within ``at[SPREAD]`` of ``at[DIRECTION]``), into vs[sp, RISES] and
    vs[sp, FALLS]: its ``rise`` kernel outside warps, at most its plain bound; the fall is the
    plain bound (only a difference's carving needs it, and its ``rise`` along -d would cost
    every primitive a second call)."""
    vs[sp, RISES] = vs[sp, FALLS] = bound
    if pp == 0:
        code = prog[0]
        rise = prim_rise(code[i, OP], prog[1], code[i, OFFSET], cur[:6],
                         (at[DIRECTION], at[DIRECTION + 1], at[DIRECTION + 2], at[SPREAD]))
        if rise >= 0.0:
            vs[sp, RISES] = min(rise, bound)


@kernel(inline="always")
def _moves(op, j, b):
    """How operator op's field moves with its child in row j, its first in row b: +1 with it,
    -1 against it, 0 either way (``Operator.MONOTONE``)."""
    return MONOTONE_FIRST[op] if j == b else MONOTONE_REST[op]


@kernel(inline="always")
def _op_moves(op, p, o, vs, b, e, bound):
    """An operator's rise and fall along the cone, into vs[b, RISES] and vs[b, FALLS]: its rule
    over what each child's moves do to it (``MONOTONE``: a child it grows with gives its rise
    to the rise and its fall to the fall, one it shrinks with the other way round, one it moves
    either way with its plain bound vs[j, FIELD] to both), at most its own ``bound``."""
    for j in range(b, e):
        sign = _moves(op, j, b)
        if sign == 0:
            vs[j, RISES] = vs[j, FALLS] = vs[j, FIELD]
        elif sign < 0:
            vs[j, RISES], vs[j, FALLS] = vs[j, FALLS], vs[j, RISES]
    rise = min(_rule(op, p, o, vs, RISES, b, e), bound)
    fall = min(_rule(op, p, o, vs, FALLS, b, e), bound)
    vs[b, RISES], vs[b, FALLS] = rise, fall


@kernel(inline="always")
def _prim_range(prog, i, local):
    """The least and the most primitive i's field can be over the region (:func:`_local`): the
    falloff at the most and the least r / R there (its ``span``)."""
    code, p = prog[0], prog[1]
    o = code[i, OFFSET]
    cx, cy, cz, hx, hy, hz, r = local
    rmin, rmax = prim_span(code[i, OP], p, o, cx, cy, cz, hx, hy, hz, r)
    fid = int(p[o + FALLOFF])
    return (fo(fid, rmax * rmax) if rmax < 1.0 else 0.0,
            fo(fid, rmin * rmin) if rmin < 1.0 else 0.0)


@kernel(inline="always")
def _combine_ends(op, p, o, vs, b, k, least):
    """Operator op's field with each child at the end of its range vs[j, LEAST:MOST + 1] that
    makes it least (``least``) or most: the end it rises toward, or away from where it falls
    with that child (``MONOTONE``)."""
    for j in range(b, b + k):
        rises = _moves(op, j, b) > 0
        vs[j, FIELD] = vs[j, LEAST] if rises == least else vs[j, MOST]
    combine(op, vs, b, k, p, o, VALUE)
    return vs[b, FIELD]


@kernel(inline="always")
def _op_range(op, p, o, vs, b, k):
    """The least and the most operator op's field can be over the region, from its children's
    ranges: a field that moves one way with each child (``MONOTONE``) is least and most at
    their ends (:func:`_combine_ends`, which leaves the children's values, and the result's,
    overwritten); (-inf, inf) for one that does not."""
    for j in range(b, b + k):
        if _moves(op, j, b) == 0:
            return -math.inf, math.inf
    return (_combine_ends(op, p, o, vs, b, k, True), _combine_ends(op, p, o, vs, b, k, False))


@kernel(inline="always")
def _region(at):
    """The region of ``at``: its box and the ball about the box's centre."""
    return (at[LO], at[LO + 1], at[LO + 2], at[HI], at[HI + 1], at[HI + 2],
            half_diagonal(at[LO], at[LO + 1], at[LO + 2], at[HI], at[HI + 1], at[HI + 2]))


# ----- the lipschitz mode: cur = the region ----------------------------------------------------
# Bounds in vs[:, FIELD], rises and falls in vs[:, RISES] and vs[:, FALLS], the regions saved
# across warps in vs[pp, REGION:REGION + 6] (it computes no field values).
@hook
def _l_start(prog, at, st):
    return _region(at)


@hook
def _l_primitive(prog, at, i, cur, pp, st, sp):
    vs = st[0]
    vs[sp, FIELD] = vs[sp, RISES] = vs[sp, FALLS] = 0.0
    if not misses(prog[2], i, cur[:6]):
        bound = _prim_along(prog, i, at, pp)
        vs[sp, FIELD] = bound if bound >= 0.0 else _prim_bound(prog, i, _local(prog, i, cur))
        if at[SPREAD] >= 0.0:
            _prim_moves(prog, i, at, cur, pp, vs[sp, FIELD], vs, sp)


@hook
def _l_operator(prog, at, i, cur, st, b, k):
    code, p, vs = prog[0], prog[1], st[0]
    op, o = code[i, OP], code[i, OFFSET]
    bound = _rule(op, p, o, vs, FIELD, b, b + k)
    if at[SPREAD] >= 0.0:
        _op_moves(op, p, o, vs, b, b + k, bound)
    vs[b, FIELD] = bound


@hook
def _l_misses(prog, at, i, cur, pp, st):
    return misses(prog[2], i, cur[:6])


@hook
def _l_zero(at, st, sp):
    vs = st[0]
    vs[sp, FIELD] = vs[sp, RISES] = vs[sp, FALLS] = 0.0


@hook
def _l_enter(prog, at, i, cur, st, pp):
    vs = st[0]
    for c in range(6):  # save the region
        vs[pp, REGION + c] = cur[c]
    return carry(True, prog, i, cur, st[1])


@hook
def _l_warp(prog, at, i, cur, st, pp):
    return carry(False, prog, i, cur, st[1])


@hook
def _l_leave(prog, at, i, cur, st, top, pp):
    """(A warped subtree moves as fast as its bound.)"""
    vs = st[0]
    vs[top, FIELD] *= prog[3][i]
    vs[top, RISES] = vs[top, FALLS] = vs[top, FIELD]
    lox, loy, loz = vs[pp, REGION], vs[pp, REGION + 1], vs[pp, REGION + 2]
    hix, hiy, hiz = vs[pp, REGION + 3], vs[pp, REGION + 4], vs[pp, REGION + 5]
    return lox, loy, loz, hix, hiy, hiz, half_diagonal(lox, loy, loz, hix, hiy, hiz)


@hook
def _nothing(prog, at, i, cur, st, top):
    """A paint node: colours play no part in a bound."""


@hook
def _l_finish(prog, at, cur, st):
    vs = st[0]
    return vs[0, FIELD], (vs[0, RISES] if at[SPREAD] >= 0.0 else vs[0, FIELD])


# ----- the bounded mode: cur = the region, then the point --------------------------------------
# Fields in vs[:, FIELD], bounds in vs[:, BOUND], the distances an operator proved in vs[:, BELOW]
# and vs[:, ABOVE]; ps[pp, POINT:POINT + 3] saves the point and ps[pp, SAVED_BOX:SAVED_BOX + 6]
# the region across warps.
@hook
def _b_start(prog, at, st):
    r = _region(at)
    return r[0], r[1], r[2], r[3], r[4], r[5], r[6], at[ORIGIN], at[ORIGIN + 1], at[ORIGIN + 2]


@hook
def _b_primitive(prog, at, i, cur, pp, st, sp):
    vs = st[0]
    vs[sp, FIELD] = vs[sp, BOUND] = vs[sp, BELOW] = vs[sp, ABOVE] = 0.0
    vs[sp, LEAST] = vs[sp, MOST] = 0.0
    if not misses(prog[2], i, cur[:6]):
        local = _local(prog, i, cur)
        bound = _prim_along(prog, i, at, pp)
        vs[sp, BOUND] = bound if bound >= 0.0 else _prim_bound(prog, i, local)
        vs[sp, LEAST], vs[sp, MOST] = _prim_range(prog, i, local)
        if not outside(prog[2], i, cur[7], cur[8], cur[9]):
            push_primitive(prog, i, cur[7], cur[8], cur[9], VALUE, vs, sp)


@hook
def _b_operator(prog, at, i, cur, st, b, k):
    code, p, vs = prog[0], prog[1], st[0]
    op, o = code[i, OP], code[i, OFFSET]
    reach = math.sqrt((cur[3] - cur[0]) ** 2 + (cur[4] - cur[1]) ** 2 + (cur[5] - cur[2]) ** 2)
    bound, below, above = op_bound(op, vs, b, k, p, o, reach)  # before combine
    if bound < 0.0:
        bound = _rule(op, p, o, vs, BOUND, b, b + k)
    combine(op, vs, b, k, p, o, VALUE)
    f = vs[b, FIELD]
    least, most = _op_range(op, p, o, vs, b, k)
    vs[b, FIELD] = f
    # (no field is below 0: a range from a non-monotone operator's value less its bound times
    # the region's size must not reach its parent's combine, an n-norm, below 0)
    least, most = max(least, f - bound * reach, 0.0), min(most, f + bound * reach)
    if most < ISO:  # below ISO all over the region
        below = math.inf
    if least > ISO:
        above = math.inf
    vs[b, BOUND], vs[b, BELOW], vs[b, ABOVE] = bound, below, above
    vs[b, LEAST], vs[b, MOST] = least, most


@hook
def _b_zero(at, st, sp):
    vs = st[0]
    vs[sp, FIELD] = vs[sp, BOUND] = vs[sp, BELOW] = vs[sp, ABOVE] = 0.0
    vs[sp, LEAST] = vs[sp, MOST] = 0.0


@hook
def _b_enter(prog, at, i, cur, st, pp):
    """Save the point and region, carry them into the warp's frame."""
    ps = st[1]
    for c in range(3):
        ps[pp, POINT + c] = cur[7 + c]
    for c in range(6):
        ps[pp, SAVED_BOX + c] = cur[c]
    px, py, pz = map_point(prog[1], prog[0][i, OFFSET], cur[7], cur[8], cur[9])
    r = carry(True, prog, i, cur[:7], ps)
    return r[0], r[1], r[2], r[3], r[4], r[5], r[6], px, py, pz


@hook
def _b_warp(prog, at, i, cur, st, pp):
    code = prog[0]
    px, py, pz = apply_warp(code[i, OP], prog[1], code[i, OFFSET], cur[7], cur[8], cur[9], st[1],
                            0, VALUE)
    r = carry(False, prog, i, cur[:7], st[1])
    return r[0], r[1], r[2], r[3], r[4], r[5], r[6], px, py, pz


@hook
def _b_leave(prog, at, i, cur, st, top, pp):
    """Frame distances are at most lips[i] times the outer ones."""
    vs, ps, lip = st[0], st[1], prog[3][i]
    vs[top, BOUND] *= lip
    vs[top, BELOW] /= lip
    vs[top, ABOVE] /= lip
    lox, loy, loz = ps[pp, SAVED_BOX], ps[pp, SAVED_BOX + 1], ps[pp, SAVED_BOX + 2]
    hix, hiy, hiz = ps[pp, SAVED_BOX + 3], ps[pp, SAVED_BOX + 4], ps[pp, SAVED_BOX + 5]
    return (lox, loy, loz, hix, hiy, hiz, half_diagonal(lox, loy, loz, hix, hiy, hiz),
            ps[pp, POINT], ps[pp, POINT + 1], ps[pp, POINT + 2])


@hook
def _b_finish(prog, at, cur, st):
    vs = st[0]
    below, above = safe_distances(vs, 0)
    return vs[0, FIELD], vs[0, BOUND], below, above


#: The plain bound pass: Lipschitz rules over the primitives that meet the region.
LIPSCHITZ_MODE = Mode("lipschitz", _l_start, _l_primitive, _l_operator, _l_misses, _l_zero,
                      _l_enter, _l_warp, _l_leave, _nothing, _l_finish)
#: The value-aware bound pass: also the field at the region's point, handed to operators'
#: ``bound`` kernels.
BOUNDED_MODE = Mode("bounded", _b_start, _b_primitive, _b_operator, _l_misses, _b_zero,
                    _b_enter, _b_warp, _b_leave, _nothing, _b_finish)

_AT = types.UniTuple(types.float64, AT)
#: ``lipschitz_walk(prog, at, (vs, ps))``: (a bound on ``|grad f|`` over the region, and with
#: ``at[SPREAD]`` >= 0 a bound on how fast the field *rises* along every unit direction within
#: that spread of ``at[DIRECTION]`` (a cone of rays), else the bound again).  A primitive outside
#: warps rises as its ``rise`` kernel says (0 where the whole box moves away from it), an operator
#: by its children's rises and falls (:func:`_op_moves`), anything else as fast as its bound.
lipschitz_walk = linked(types.UniTuple(types.float64, 2)(PROGRAM, _AT, STACKS))(
    walk(LIPSCHITZ_MODE))
#: ``bounded_walk(prog, at, (vs, ps))``: the lipschitz pass that also evaluates the field at
#: ``at[ORIGIN]`` (a point of the box) and hands each operator its children's values: an
#: operator with a ``bound`` kernel uses them to leave out children that cannot set its field
#: anywhere in the region (a CSG operator's loser), and to say how far its field surely stays
#: below and above ISO.  Returns (the field there; the bound; how far from it the field surely
#: stays below ISO, and above it).  It bounds no rise along rays.
bounded_walk = linked(types.UniTuple(types.float64, 4)(PROGRAM, _AT, STACKS))(walk(BOUNDED_MODE))
_lipschitz = lipschitz_walk.call
_bounded = bounded_walk.call


@kernel
def bounds_use_values(code):
    """Whether the program's root is an operator whose bound uses field values (a CSG root):
    then the bound pass that evaluates the field (``bounded``) is worth its extra work; a
    program of blends gains nothing from it."""
    n = code.shape[0]
    return n > 0 and VALUE_BOUND[code[n - 1, OP]]


@kernel(inline="always")
def _bound_at(prog, at, values, st):
    """The bounded pass with ``values``; else the field by ``eval_point``, the plain bound and
    the distances those two give (cheaper for a program of blends); with ``at[SPREAD]`` >= 0 the
    bound is the rise along the cone (the distances stay the plain bound's, which hold in every
    direction: infinite below ISO where the field is the same all over the box)."""
    if values:
        return _bounded(prog, at, st)
    f = eval_point(prog, (at[ORIGIN], at[ORIGIN + 1], at[ORIGIN + 2], VALUE), st)
    bound, rise = _lipschitz(prog, at, st)
    below, above = gaps(f, bound)
    return f, rise, below, above


@kernel(inline="always")
def lipschitz_box(prog, box, st):
    """A bound on ``|grad f|`` over the box (lox, loy, loz, hix, hiy, hiz) (world coordinates):
    the tree's Lipschitz rules (sum at blends, max at CSG) over only the primitives whose boxes
    meet it, each with its distance-aware bound; through a warp the region is carried into the
    warp's child frame (:func:`carry`) and the result scaled back."""
    return _lipschitz(prog, (box[0], box[1], box[2], box[3], box[4], box[5], 0.0, 0.0, 0.0, 0.0,
                             0.0, 0.0, 0.0, -1.0, 0.0), st)[0]


@kernel(inline="always")
def bound_box_at(prog, box, point, cone, values, st):
    """(The field at ``point``, a point of ``box``; a bound on ``|grad f|`` over the box; how
    far from the point within the box the field surely stays below ISO; and above it).  With
    ``values`` (see :func:`bounds_use_values`), CSG operators drop the bounds of children that
    the field values at the point show cannot set the result anywhere in the box, and prove
    longer distances (the bounded pass).  Without, and with a cone (dx, dy, dz, spread >= 0),
    the bound is only on how fast the field rises along unit directions within ``spread`` of d
    (rays that leave some primitives, or pass them sideways); the distances are still those of
    the bound without the cone."""
    return _bound_at(prog, (box[0], box[1], box[2], box[3], box[4], box[5], point[0], point[1],
                            point[2], cone[0], cone[1], cone[2], 0.0, cone[3], 0.0), values, st)


@kernel(inline="always")
def lipschitz_segment(prog, origin, direction, length, values, st):
    """(The field at o; a bound on how fast f rises along the segment o + t d, 0 <= t <= length,
    d a unit vector; how far along it the field surely stays below ISO; and above it):
    :func:`bound_box_at` over the segment's box with d's rise, except that primitives with a
    directional bound (point primitives, outside warps) take it instead (never larger, and
    small where the segment passes a primitive sideways, so grazing rays take long steps)."""
    ox, oy, oz = origin
    dx, dy, dz = direction
    bx, by, bz = ox + length * dx, oy + length * dy, oz + length * dz
    return _bound_at(prog, (min(ox, bx), min(oy, by), min(oz, bz), max(ox, bx), max(oy, by),
                            max(oz, bz), ox, oy, oz, dx, dy, dz, length, 0.0, 1.0), values, st)


@kernel(nrt=True, nogil=True)
def bound_range(start, stop, prog, lo, hi, at, depth, out):
    """:func:`bound_box_at` for boxes start..stop - 1 of (M, 3) lo, hi at their points ``at``:
    the four values in the rows of out (M, 4)."""
    st = scratch(depth)
    for m in range(start, stop):
        out[m, 0], out[m, 1], out[m, 2], out[m, 3] = bound_box_at(
            prog, (lo[m, 0], lo[m, 1], lo[m, 2], hi[m, 0], hi[m, 1], hi[m, 2]),
            (at[m, 0], at[m, 1], at[m, 2]), (0.0, 0.0, 0.0, -1.0), True, st)


@kernel(nrt=True, nogil=True)
def lipschitz_range(start, stop, prog, lo, hi, depth, out):
    """:func:`lipschitz_box` for boxes start..stop - 1 of (M, 3) lo, hi."""
    st = scratch(depth)
    for m in range(start, stop):
        out[m] = lipschitz_box(prog, (lo[m, 0], lo[m, 1], lo[m, 2], hi[m, 0], hi[m, 1],
                                      hi[m, 2]), st)
