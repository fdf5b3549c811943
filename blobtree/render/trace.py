"""Ray-surface intersection by segment tracing (Galin, Guerin, Paris, Peytavie, CGF 2020).

Along a ray p(t) = o + t d the tracer keeps a candidate segment [t, t + delta].  The engine bounds
the field's derivative along the segment (``bounds.lipschitz_segment``: the gradient bound over the
segment's box, and for point primitives the directional bound, small where the ray passes a
primitive sideways).  With that local Lipschitz bound L, the field cannot reach the iso-value 0.5
before t + (0.5 - f(t)) / L, so that step is safe, and so is every further step of that kind while
it stays inside the segment: one bound (the costlier half of a step) serves several field
evaluations.  The same pass evaluates the field at the segment's start, so CSG operators can leave
out children that cannot set the field on the segment, and say how far it surely stays below 0.5
when that is further (a min stays below as long as any of its terms does: the air in a carved hole
is far from the shell even where the carving's own field is steep).  The next candidate segment is
``SEGMENT_GROWTH`` times the one just crossed.  Where the support boxes miss the segment, L is 0 and
the whole segment is skipped.  Steps never fall below ``eps`` (a feature thinner than eps along the
ray may be skipped: eps is a fraction of a pixel for camera rays, and for shadow rays toward an area
light a fraction of the light's width seen from where the ray has got to), and once a step lands
inside (f >= 0.5) the root is refined by the Illinois variant of regula falsi, which keeps the root
bracketed.  A step the bound limits is over-relaxed (``OMEGA`` times as long, after Keinert et al.,
Enhanced Sphere Tracing, STAG 2014) and kept only when the field at both of its ends proves it free
under the same bound (each end below 0.5 by more than the bound lets the field rise between them);
else the ray takes the plain step.  On the Murex's studio picture this takes a camera ray's field
evaluations from 37.7 to 33.4.  :func:`march_cone` applies the same bound to a whole cone of camera
rays at once, so a block of pixels skips empty space together, and :func:`trace_packet` traces the
rays of such a block together: one bound serves them all, and each step evaluates all their points
in one batch.

All kernels take the program bundle ``prog = (code, params, boxes, lips)`` of ``Program.arrays``, a
ray as ``(ox, oy, oz, dx, dy, dz)`` (rays of a packet as arrays ``(O, D)``) and the per-thread
stacks ``st`` of ``point.scratch``.
"""

from __future__ import annotations

import numpy as np

from ..engine.batch import eval_rows
from ..engine.bounds import bound_box_at, bounds_use_values, lipschitz_box, lipschitz_segment
from ..engine.point import eval_point, scratch
from ..nodes.layout import VALUE
from ..nodes.node import ISO
from ..runtime.jit import kernel, linked
from .bundles import TRACE_PACKET

#: Growth factor of a cone's candidate segment over its last step (the paper's c).
GROWTH = 1.5
#: Growth factor of a ray's candidate segment over the last one (several steps share its bound).
SEGMENT_GROWTH = 2.0
#: A ray takes a new bound once its step falls below 1 / REBOUND of what is left of the segment.
REBOUND = 16.0
#: A cone stops once its safe step falls below this fraction of its radius.
CONE_STOP = 0.1
#: Regula-falsi iterations after a bracket is found (the bracket shrinks superlinearly).
REFINE_ITERS = 24
#: Refinement stops once the root is located to this fraction of the smallest step.
ROOT_TOL = 1e-3
#: Lipschitz-limited steps are over-relaxed by OMEGA; one is kept only if the bound then proves
#: the whole step free (the fields at both ends, each less than ISO by more than the bound
#: allows the field to rise between them), else the ray takes the plain step next.
OMEGA = 1.6
#: Fewer rays of a packet than this are evaluated one by one, not as a batch (of
#: ``batch.W`` lanes at least).
PACKET_MIN = 2


@kernel
def clip_box(ox, oy, oz, dx, dy, dz, lo, hi, tmin, tmax):
    """Slab test: the parameter range (t0, t1) of the ray inside box [lo, hi] within
    [tmin, tmax]; t0 > t1 when the ray misses."""
    t0 = tmin
    t1 = tmax
    o = (ox, oy, oz)
    d = (dx, dy, dz)
    for k in range(3):
        if d[k] != 0.0:
            inv = 1.0 / d[k]
            a = (lo[k] - o[k]) * inv
            b = (hi[k] - o[k]) * inv
            if a > b:
                a, b = b, a
            t0 = max(t0, a)
            t1 = min(t1, b)
        elif o[k] < lo[k] or o[k] > hi[k]:
            return 1.0, 0.0
    return t0, t1


@kernel(inline="always")
def _estimate(ta, fa, tb, fb):
    """Regula falsi's next estimate of the root of f - ISO in [ta, tb] (fa < 0 <= fb): where
    the secant crosses 0, or the midpoint if that falls outside the bracket."""
    t = (ta * fb - tb * fa) / (fb - fa)
    return t if ta < t < tb else 0.5 * (ta + tb)


@kernel(inline="always")
def _narrow(ta, fa, tb, fb, side, t, f):
    """The bracket (ta, fa, tb, fb, side) once f - ISO is f at t inside it (Illinois: an end
    kept twice running has its value halved; side is the end moved last, -1 or 1)."""
    if f >= 0.0:
        if side == 1:
            fa *= 0.5
        return ta, fa, t, f, 1
    if side == -1:
        fb *= 0.5
    return t, f, tb, fb, -1


@kernel(inline="always")
def _located(ta, fa, tb, fb, f, tol):
    """Whether f - ISO = f at the estimate puts the root within tol of it, by the secant's
    slope over the bracket (ta, fa, tb, fb)."""
    return abs(f) * (tb - ta) <= tol * (fb - fa)


@kernel(inline="always")
def _refine(prog, ray, bracket, tol, st):
    """Root of f - ISO along ``ray`` in the bracket (ta, fa, tb, fb), fa < 0 <= fb (Illinois
    regula falsi), stopping once the secant slope puts the root within tol of the estimate."""
    ox, oy, oz, dx, dy, dz = ray
    ta, fa, tb, fb = bracket
    side = 0
    for _ in range(REFINE_ITERS):
        t = _estimate(ta, fa, tb, fb)
        f = eval_point(prog, (ox + t * dx, oy + t * dy, oz + t * dz, VALUE), st) - ISO
        if _located(ta, fa, tb, fb, f, tol):
            return t
        ta, fa, tb, fb, side = _narrow(ta, fa, tb, fb, side, t, f)
        if tb - ta <= tol:
            break
    return 0.5 * (ta + tb)


@kernel
def trace(prog, ray, span, steps, delta0, st):
    """First t in span = [t0, t1] where the field reaches ISO along the unit-direction ray, or -1
    (a ray that starts inside, f >= ISO at t0, hits at t0).
    ``eps_abs + eps_rel * t`` is the smallest step, steps = (eps_abs, eps_rel).  One Lipschitz
    bound serves every step inside its candidate segment, unless the steps it allows are short
    next to what is left of the segment (the bound is loose there): then a shorter segment takes
    a new bound.
    """
    ox, oy, oz, dx, dy, dz = ray
    t0, t1 = span
    eps_abs, eps_rel = steps
    values = bounds_use_values(prog[0])
    t = t0
    delta = delta0
    f, lam, below, _ = lipschitz_segment(prog, (ox + t * dx, oy + t * dy, oz + t * dz),
                                         (dx, dy, dz), min(delta, t1 - t), values, st)
    f -= ISO
    if f >= 0.0:
        return t
    while t < t1:
        ts = t
        te = min(t + delta, t1)
        while True:  # lam bounds |df/dt| over the whole segment: step on inside it
            step = te - t
            if lam > 0.0:  # (and the field stays below ISO up to ts + below)
                step = min(step, max(-f / lam, ts + below - t))
            eps = eps_abs + eps_rel * t
            tn = min(t + max(step, eps), t1)
            last = tn - t
            # a new segment starts at tn once this one is crossed, or where the bound is
            # loose (its steps short next to what is left of it): its bound comes with f(tn)
            new_segment = tn >= te or te - tn > REBOUND * last
            if new_segment:
                delta = SEGMENT_GROWTH * (tn - ts) if tn >= te else GROWTH * last
                fn, lam, below, _ = lipschitz_segment(
                    prog, (ox + tn * dx, oy + tn * dy, oz + tn * dz), (dx, dy, dz),
                    min(delta, t1 - tn), values, st)
            else:
                fn = eval_point(prog, (ox + tn * dx, oy + tn * dy, oz + tn * dz, VALUE), st)
            fn -= ISO
            if fn >= 0.0:
                return _refine(prog, ray, (t, f, tn, fn), ROOT_TOL * eps, st)
            t = tn
            f = fn
            if new_segment:
                break
    return -1.0


#: Rows of :func:`trace_packet`'s scratch: each ray's field (minus ISO) where it is, its next
#: point, its last step, its segment's start and end; the lowest field (minus ISO) it met, the
#: most the field then climbed above its lowest before (on the samples taken: 0 for a ray
#: leaving a lone convex surface, positive where it passed another surface, which it came
#: nearest around the peak; soft shadows use it), and where it peaked.  These three carry over
#: from one call to the next (the caller sets them to inf, 0 and anything before the first).
#: Then, for a ray that crossed ISO, what :func:`_refine_packet` keeps: the field (minus ISO)
#: past the root, the end of the bracket moved last, and the tolerance.
F, TN, LAST, TS, TE, LOW, RISE, PEAK, FB, SIDE, TOL, PLAIN, RETRY = range(13)
#: Rows of :func:`trace_packet`'s scratch ``pk``.
PACKET_ROWS = RETRY + 1


@kernel
def _packet_field(prog, rays, at, ids, m, rows, st):
    """The field at O[k] + at[k] D[k] for the m rays k = ids[:m] of rays = (O, D), into
    vs[0, :m] of rows = (pts, vs, tmp): one batch (``batch.eval_rows``), or ray by ray when
    they are fewer than ``PACKET_MIN`` (a batch computes whole vector groups)."""
    O, D = rays
    pts, vs = rows[0], rows[1]
    if m < PACKET_MIN:
        for j in range(m):
            k = ids[j]
            vs[0, j] = eval_point(prog, (O[k, 0] + at[k] * D[k, 0], O[k, 1] + at[k] * D[k, 1],
                                         O[k, 2] + at[k] * D[k, 2], VALUE), st)
        return
    for j in range(m):
        k = ids[j]
        for r in range(3):
            pts[0, r, j] = O[k, r] + at[k] * D[k, r]
    eval_rows(prog, m, rows)


@kernel
def _refine_packet(prog, rays, hits, h, t, out, pk, rows, st):
    """:func:`_refine` for the rays k = hits[:h] together, one batch per iteration: ray k's
    bracket is [t[k], out[k]], with the field minus ISO pk[F, k] and pk[FB, k] there and
    tolerance pk[TOL, k]; its root goes to out[k]."""
    vs = rows[1]
    for j in range(h):
        pk[SIDE, hits[j]] = 0.0
    for _ in range(REFINE_ITERS):
        if h == 0:
            return
        for j in range(h):
            k = hits[j]
            pk[TN, k] = _estimate(t[k], pk[F, k], out[k], pk[FB, k])
        _packet_field(prog, rays, pk[TN], hits, h, rows, st)
        b = 0
        for j in range(h):
            k = hits[j]
            tn, f, tol = pk[TN, k], vs[0, j] - ISO, pk[TOL, k]
            if _located(t[k], pk[F, k], out[k], pk[FB, k], f, tol):
                out[k] = tn
                continue
            t[k], pk[F, k], out[k], pk[FB, k], side = _narrow(t[k], pk[F, k], out[k],
                                                             pk[FB, k], pk[SIDE, k], tn, f)
            pk[SIDE, k] = side
            if out[k] - t[k] <= tol:
                out[k] = 0.5 * (t[k] + out[k])
                continue
            hits[b] = k
            b += 1
        h = b
    for j in range(h):
        k = hits[j]
        out[k] = 0.5 * (t[k] + out[k])


@kernel(inline="always")
def _seen(pk, k, t, f):
    """Record the field (minus ISO) f met at t by ray k: its lowest, and its largest rise."""
    pk[LOW, k] = min(pk[LOW, k], f)
    if f - pk[LOW, k] > pk[RISE, k]:
        pk[RISE, k] = f - pk[LOW, k]
        pk[PEAK, k] = t


@kernel(inline="always")
def _still_going(act, a, out, t, t_end):
    """Keep in act[:a] the rays that found no hit and have not reached their end; return how
    many."""
    b = 0
    for j in range(a):
        k = act[j]
        if out[k] < 0.0 and t[k] < t_end[k]:
            act[b] = k
            b += 1
    return b


@kernel(inline="always")
def _cone(D, act, m):
    """The unit axis a of the directions D[k], k in act[:m], and the largest |D[k] - a| (-1 if
    they cancel out: no cone)."""
    ax = ay = az = 0.0
    for j in range(m):
        k = act[j]
        ax, ay, az = ax + D[k, 0], ay + D[k, 1], az + D[k, 2]
    norm = np.sqrt(ax * ax + ay * ay + az * az)
    if not norm > 0.0:
        return 1.0, 0.0, 0.0, -1.0
    ax, ay, az = ax / norm, ay / norm, az / norm
    spread = 0.0
    for j in range(m):
        k = act[j]
        spread = max(spread, (D[k, 0] - ax) ** 2 + (D[k, 1] - ay) ** 2 + (D[k, 2] - az) ** 2)
    return ax, ay, az, np.sqrt(spread)


def _trace_packet(prog, rays, n, span, steps, delta0, out, refine, scratch, st):
    """Segment tracing of the rays O[k] + t D[k], k < n (unit directions, rays = (O, D)), together,
    each over [t[k], t_end[k]] (span = (t, t_end); none where t[k] > t_end[k]), the smallest step
    eps[k] + eps_rel t (steps = (eps, eps_rel)): out[k] is its first hit, or -1 with t[k] where it
    stopped (t_end[k] if it got there); the hits are located to ``ROOT_TOL`` of their smallest step
    where ``refine`` (all together at the end, :func:`_refine_packet`), else out[k] is a point past
    the hit where the field is at least ISO (a shadow ray needs no more; t[k] of a ray that hit is
    left anywhere before its hit); the field's lowest value, largest rise and where it peaked go on
    in ``pk`` (:data:`LOW` ...). Each ray steps as :func:`trace` does (never less than eps[k] +
    eps_rel t), but one bound serves them all: over the box around every ray's candidate segment
    (value-aware at one of their points where the root is CSG; else a bound on how fast the field
    rises along the cone of their directions, which leaves out the primitives they all move away
    from), and each step evaluates the new points of all the rays in one batch (``batch.eval_rows``:
    SIMD over rays). A segment ends for all once every ray has crossed it (the next is
    ``SEGMENT_GROWTH`` times the longest crossing), or once some ray's steps are short next to what
    is left of it (the next is ``GROWTH`` times the shortest step). Where the bound is 0, or the
    bound pass proves the field below ISO all over the box, the rays cross their segments in one
    step (without evaluating the field where it is the same all over the box: no support meets it).
    Scratch = (pk, ids, rows): pk (PACKET_ROWS, n) floats, ids (3, n) ints; rows = (pts, vs, tmp) as
    ``eval_rows`` takes them (n at most their columns)."""
    O, D = rays
    t, t_end = span
    eps, eps_rel = steps
    pk, ids, rows = scratch
    vs = rows[1]
    values = bounds_use_values(prog[0])
    act, mov, hits = ids[0], ids[1], ids[2]
    h = 0
    m = 0
    for k in range(n):
        out[k] = -1.0
        pk[RETRY, k] = 0.0
        if t[k] <= t_end[k]:
            act[m] = k
            m += 1
    _packet_field(prog, rays, t, act, m, rows, st)
    a = 0
    for j in range(m):
        k = act[j]
        pk[F, k] = vs[0, j] - ISO
        if pk[F, k] >= 0.0:
            out[k] = t[k]
            continue
        _seen(pk, k, t[k], pk[F, k])
        if t[k] < t_end[k]:
            act[a] = k
            a += 1
    ax, ay, az, spread = _cone(D, act, a)
    delta = delta0
    while a > 0:
        lox = loy = loz = np.inf
        hix = hiy = hiz = -np.inf
        for j in range(a):
            k = act[j]
            pk[TS, k] = t[k]
            pk[TE, k] = min(t[k] + delta, t_end[k])
            for tt in (t[k], pk[TE, k]):
                x, y, z = O[k, 0] + tt * D[k, 0], O[k, 1] + tt * D[k, 1], O[k, 2] + tt * D[k, 2]
                lox, loy, loz = min(lox, x), min(loy, y), min(loz, z)
                hix, hiy, hiz = max(hix, x), max(hiy, y), max(hiz, z)
        k = act[0]
        _, lam, below, _ = bound_box_at(
            prog, (lox, loy, loz, hix, hiy, hiz), (O[k, 0] + t[k] * D[k, 0],
                                                   O[k, 1] + t[k] * D[k, 1],
                                                   O[k, 2] + t[k] * D[k, 2]),
            (ax, ay, az, spread), values, st)
        if lam == 0.0 and below == np.inf:  # the field is the same all over the box
            for j in range(a):
                k = act[j]
                pk[LAST, k] = pk[TE, k] - t[k]
                t[k] = pk[TE, k]
            a = _still_going(act, a, out, t, t_end)
        elif below ** 2 >= (hix - lox) ** 2 + (hiy - loy) ** 2 + (hiz - loz) ** 2:
            lam = 0.0  # the field stays below ISO all over the box: cross it in one step
        creep = False
        while not creep:  # lam bounds the field's rise on every segment: step each ray on
            mv = 0  # inside its own (across it where the field cannot rise there)
            for j in range(a):
                k = act[j]
                if t[k] < pk[TE, k]:
                    step = pk[TE, k] - t[k]
                    if lam > 0.0:
                        step = min(step, -pk[F, k] / lam)
                    e = eps[k] + eps_rel * t[k]
                    pk[TN, k] = pk[PLAIN, k] = min(t[k] + max(step, e), pk[TE, k])
                    if lam > 0.0 and step > e and pk[RETRY, k] == 0.0:  # (over-relaxed)
                        pk[TN, k] = min(t[k] + OMEGA * step, pk[TE, k])
                    mov[mv] = k
                    mv += 1
            if mv == 0:
                break
            _packet_field(prog, rays, pk[TN], mov, mv, rows, st)
            for j in range(mv):
                k = mov[j]
                fn = vs[0, j] - ISO
                tn = pk[TN, k]
                if tn > pk[PLAIN, k] and (fn >= 0.0 or -pk[F, k] - fn < lam * (tn - t[k])):
                    pk[RETRY, k] = 1.0  # not proven free: the plain step next
                    continue
                pk[RETRY, k] = 0.0
                if fn >= 0.0:  # the root lies in [t[k], tn]
                    out[k], pk[FB, k] = tn, fn
                    pk[TOL, k] = ROOT_TOL * (eps[k] + eps_rel * t[k])
                    hits[h] = k
                    h += 1
                    continue
                _seen(pk, k, tn, fn)
                pk[LAST, k] = tn - t[k]
                t[k] = tn
                pk[F, k] = fn
                if pk[TE, k] - tn > REBOUND * pk[LAST, k]:
                    creep = True
            a = _still_going(act, a, out, t, t_end)
        if creep:
            delta = np.inf
            for j in range(a):
                delta = min(delta, GROWTH * pk[LAST, act[j]])
        else:
            delta = 0.0
            for j in range(a):
                delta = max(delta, SEGMENT_GROWTH * (t[act[j]] - pk[TS, act[j]]))
    if refine:
        _refine_packet(prog, rays, hits, h, t, out, pk, rows, st)


#: :func:`_trace_packet` compiled once, called by symbol (``runtime.linked``): four kernels
#: trace packets, and each would otherwise compile the tracer again.
packet_trace = linked(TRACE_PACKET)(_trace_packet)
trace_packet = packet_trace.call


@kernel
def march_cone(prog, eye, axis, tan_a, t, t1, st):
    """Segment tracing for a whole cone of rays (apex at the eye, unit axis a, half-angle
    atan(tan_a)): the largest axis depth reached with the cone proven free of surface, or inf if
    the cone gets past t1 untouched.

    Over the candidate segment [t, te] the cone lies in the axis segment's box grown by
    te * tan_a, where the field is L-Lipschitz; a point of the cone at depth t' is within
    (t' - t) + t' tan_a of the axis point at t, so depths up to t + step are free while
    f(t) + L (step + (t + step) tan_a) < ISO.  Every ray in the cone may start at the returned
    depth (its own parameter is never less than its axis depth).
    """
    ex, ey, ez = eye
    ax, ay, az = axis
    values = bounds_use_values(prog[0])
    delta = 0.05 * (t1 - t) + 1e-12
    while t < t1:
        te = min(t + delta, t1)
        r = te * tan_a
        px, py, pz = ex + t * ax, ey + t * ay, ez + t * az
        qx, qy, qz = ex + te * ax, ey + te * ay, ez + te * az
        lox, loy, loz = min(px, qx) - r, min(py, qy) - r, min(pz, qz) - r
        hix, hiy, hiz = max(px, qx) + r, max(py, qy) + r, max(pz, qz) + r
        box = (lox, loy, loz, hix, hiy, hiz)
        if values:
            _, lam, below, _ = bound_box_at(prog, box, (px, py, pz), (0.0, 0.0, 0.0, -1.0),
                                            True, st)
        else:  # the plain bound, and the field only where it is needed (the bound is not 0)
            lam = lipschitz_box(prog, box, st)
            below = 0.0
            if lam > 0.0:
                below = (ISO - eval_point(prog, (px, py, pz, VALUE), st)) / lam
        step = te - t
        if lam > 0.0:
            step = min(step, (below - t * tan_a) / (1.0 + tan_a))
            if step < CONE_STOP * t * tan_a:
                return t
        t += step
        delta = GROWTH * step
    return np.inf


@kernel(nrt=True, nogil=True)
def intersect_rays(start, stop, prog, depth, rays, bounds, tmax, eps_abs, out):
    """First hit distance of rays start..stop - 1 of rays = (origins, directions) into out, NaN
    on a miss (directions need not be unit; t is in units of |d|); bounds = (lo, hi), the
    scene's box."""
    origins, directions = rays
    lo, hi = bounds
    st = scratch(depth)
    for i in range(start, stop):
        out[i] = np.nan
        dx, dy, dz = directions[i, 0], directions[i, 1], directions[i, 2]
        norm = np.sqrt(dx * dx + dy * dy + dz * dz)
        dx /= norm
        dy /= norm
        dz /= norm
        ox, oy, oz = origins[i, 0], origins[i, 1], origins[i, 2]
        t0, t1 = clip_box(ox, oy, oz, dx, dy, dz, lo, hi, 0.0, tmax[i] * norm)
        if t0 > t1:
            continue
        t = trace(prog, (ox, oy, oz, dx, dy, dz), (t0, t1), (eps_abs, 0.0),
                  0.05 * (t1 - t0) + eps_abs, st)
        if t >= 0.0:
            out[i] = t / norm
