"""The kernels a node type provides, by kind (numba functions, see docs/extending.md), and the
rules an operator declares for specialisation and Lipschitz bounds."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass


@dataclass(frozen=True)
class PrimitiveKernels:
    """``s(p, o, qx, qy, qz) -> (s, ds/dqx, ds/dqy, ds/dqz)``: s = r^2 / R^2 at the local point q
    (the field is the falloff of s); ``uv(p, o, qx, qy, qz) -> (u, v)`` its own texture
    coordinates; optional ``lipschitz(p, o, lip, cx, cy, cz, hx, hy, hz, r)``: a bound on
    ``|grad f|`` over the local region within the box of centre c, half extents h and within the
    ball of centre c, radius r (``lip``: the global bound in the frame);
    optional ``along(p, o, ox, oy, oz, dx, dy, dz, length)``: a bound on |df/dt| along a frame
    segment, or -1 for none; optional ``rise(p, o, lox, loy, loz, hix, hiy, hiz, dx, dy, dz,
    spread)``: a bound on how fast the field can rise (df/dt, not |df/dt|) anywhere in the frame
    box [lo, hi] along any unit direction within distance ``spread`` of the unit vector d, or -1
    for none (0 where the rays all move away from the skeleton: they only leave the primitive);
    optional ``span(p, o, cx, cy, cz, hx, hy, hz, r)``: (least, most) of r / R over the local
    region (as ``lipschitz`` takes it), whose falloffs are the most and the least the field
    can be there (the field is the falloff of s = (r / R)^2); without it a primitive with no
    ``lipschitz`` kernel has a constant radius R (as the default bound assumes), one with
    its own has (0, inf): any value.  ``o`` is the primitive's params offset."""

    s: Callable
    uv: Callable
    lipschitz: Callable | None = None
    along: Callable | None = None
    rise: Callable | None = None
    span: Callable | None = None


@dataclass(frozen=True)
class OperatorKernels:
    """``combine(vs, b, k, p, o, mode)``: the operator over value-stack rows b .. b + k - 1 (field,
    gradient, colour; see engine.point), result in row b; optional ``rows(vs, b, k, p, o, nb)``:
    field only over the rows of a batch of nb points (engine.batch), vectorisable (its last
    ``layout.ROWS_SCRATCH`` rows are scratch); optional
    ``bound(vs, b, k, p, o, reach) -> (bound, below, above)``: from the children's fields at a
    point of a region (vs[b + j, 0]) and their bounds over it (vs[b + j, layout.BOUND], a region of
    diameter ``reach``), a bound on ``|grad f|`` over the region, and how far from the point the
    field surely stays below and above ISO (0: no more than its value and bound say); without
    it the ``LIPSCHITZ`` rule applies.  A CSG operator uses the values to drop the bound of a
    child that cannot set the result anywhere in the region, and its children's distances
    (``kmath.safe_distances``): a min stays below ISO as far as any of its terms does."""

    combine: Callable
    rows: Callable | None = None
    bound: Callable | None = None


@dataclass(frozen=True)
class WarpKernels:
    """``map(p, o, X, Y, Z) -> (qx, qy, qz, J00, J01, J02, J10, ..., J22)``: the query map of the
    warp in its canonical axes and its Jacobian, row by row; optional ``frame(p, o) -> w`` and
    ``apply(w, X, Y, Z) -> (qx, qy, qz)``: the same map without its Jacobian, its numbers read
    (and what they derive computed) once by ``frame`` for a whole batch of points, which
    ``apply`` then maps one by one (the batch walk's loop: the compiler cannot keep numbers
    read from the params array out of a loop that writes the points' array); optional
    ``stretch(p, o, lox, loy, loz, hix, hiy, hiz) -> float``: a bound on the norm of the map's
    Jacobian over the canonical box (inf where it has none: the warp's stretch over its whole box
    serves, ``bounds.carry``)."""

    map: Callable
    frame: Callable | None = None
    apply: Callable | None = None
    stretch: Callable | None = None


@dataclass(frozen=True)
class PaintKernels:
    """``paint(p, o, px, py, pz, gx, gy, gz) -> (r, g, b)``: the colour of the subtree at a point
    with field gradient g (frame coordinates)."""

    paint: Callable


#: How zero children are treated when a program is specialised to a region (engine.specialize):
#: "drop" (a zero changes nothing: remove it), "keep" (keep it as a ZERO instruction: its place or
#: value matters) or "kill" (the operator is then zero everywhere in the region).
ZERO_RULES = ("drop", "keep", "kill")
#: How an operator's Lipschitz bound follows from its children's: their sum, their largest,
#: their sum times the operator's first parameter (``op_params()[0]``, a factor it derives), or
#: their n-norm (sum L_j^n)^(1/n) with n that first parameter (an operator that is the n-norm of
#: its children's fields: |f(x) - f(y)| <= ||(f_j(x) - f_j(y))_j||_n by the triangle inequality).
LIPSCHITZ_RULES = ("sum", "max", "scaled", "norm")
