"""Placing vertices on the surface along their lattice edges: numba kernels over vertices.

Each vertex lies on a lattice edge p0 + t h e_axis, 0 <= t <= 1, with the field minus the
iso-value changing sign between its ends.  Regula falsi with the Anderson-Bjorck weighting
(Anderson & Bjorck, BIT 13, 1973) shrinks the bracket [ta, tb] around the root, keeping the
root inside it; ``polygonizer._refine`` runs the steps, the field batched over the vertices
still refining.  Every kernel takes its part ``(start, stop)`` of the rows for
:func:`parallel.parallel_for`.
"""

from __future__ import annotations

import math

from ..runtime.jit import cached


@cached(inline="always")
def _secant(ta, tb, ga, gb):
    """Root of the line through (ta, ga), (tb, gb) (ga, gb of opposite signs, ga may be 0),
    kept inside [ta, tb]."""
    den = ga - gb
    t = ta + (tb - ta) * (ga / den if den != 0.0 else 0.5)
    return min(max(t, min(ta, tb)), max(ta, tb))


@cached(inline="always")
def _on_edge(p0, axis, h, r, t, out, q):
    """out[q] = vertex r's edge point at parameter t: p0[r] + t h along its axis."""
    for c in range(3):
        out[q, c] = p0[r, c]
    out[q, axis[r]] += t * h


@cached(nogil=True)
def edge_starts(start, stop, keys, dims, origin, h, p0, axis):
    """For vertices start..stop - 1: the lower lattice point p0 (origin + index * h) and the
    axis of each one's lattice edge, from its key (point index * 3 + axis, the point's index
    running over ``dims`` in C order)."""
    for r in range(start, stop):
        point = keys[r] // 3
        axis[r] = keys[r] % 3
        for c in range(2, -1, -1):
            p0[r, c] = origin[c] + (point % dims[c]) * h
            point //= dims[c]


@cached(nogil=True)
def secant_points(start, stop, rows, p0, axis, h, ta, tb, ga, gb, t, out):
    """For vertices ``rows[start:stop]``: the secant root of each bracket into ``t`` and its
    point on the edge into ``out[start:stop]``."""
    for q in range(start, stop):
        r = rows[q]
        t[r] = _secant(ta[r], tb[r], ga[r], gb[r])
        _on_edge(p0, axis, h, r, t[r], out, q)


@cached(nogil=True)
def bracket_step(start, stop, rows, g, t, ta, tb, ga, gb, last, tol, done):
    """One regula-falsi step for vertices ``rows[start:stop]`` given g = f - iso at their
    secant roots ``t``: the root replaces the bracket's end on its side; an end kept twice in
    a row has its value weighted by 1 - g / g(end replaced), or by 1/2 (Anderson-Bjorck).
    ``last[r]``: the end replaced last (1: a, 2: b, 0: none yet).  ``done[q]``: the secant
    through the bracket (before the step) put the root within ``tol`` of the edge's length of
    t (|g| / slope), so a further step would gain little."""
    for q in range(start, stop):
        r = rows[q]
        gq = g[q]
        done[q] = abs(gq) * abs(tb[r] - ta[r]) <= tol * abs(gb[r] - ga[r])
        if (ga[r] >= 0.0) == (gq >= 0.0):  # t lies on a's side: it replaces a
            if last[r] == 1:
                m = 1.0 - gq / ga[r] if ga[r] != 0.0 else 1.0
                gb[r] *= m if m > 0.0 else 0.5
            ta[r], ga[r], last[r] = t[r], gq, 1
        else:
            if last[r] == 2:
                m = 1.0 - gq / gb[r] if gb[r] != 0.0 else 1.0
                ga[r] *= m if m > 0.0 else 0.5
            tb[r], gb[r], last[r] = t[r], gq, 2


@cached(nogil=True)
def final_roots(start, stop, bracket, t, t_lo, t_hi, edges, out):
    """The bracket = (ta, tb, ga, gb) (kept ``1e-4`` from the edge's ends, so that no two
    edges' vertices meet) into t_lo, t_hi, the secant root inside it into t, and its point on
    edges = (p0, axis, h) into out."""
    ta, tb, ga, gb = bracket
    p0, axis, h = edges
    for r in range(start, stop):
        t_lo[r] = max(min(ta[r], tb[r]), 1e-4)
        t_hi[r] = min(max(ta[r], tb[r]), 1.0 - 1e-4)
        t[r] = min(max(_secant(ta[r], tb[r], ga[r], gb[r]), t_lo[r]), t_hi[r])
        _on_edge(p0, axis, h, r, t[r], out, r)


@cached(nogil=True)
def newton_step(start, stop, f, grad, iso, axis, h, t, t_lo, t_hi, movable, verts):
    """A last Newton step along each edge from the field and gradient at its vertex, taken only
    where it stays inside the bracket (t_lo, t_hi) and ``movable``."""
    for r in range(start, stop):
        slope = grad[r, axis[r]] * h
        if slope == 0.0 or not movable[r]:
            continue
        t_new = t[r] - (f[r] - iso) / slope
        if t_lo[r] < t_new < t_hi[r]:
            verts[r, axis[r]] += (t_new - t[r]) * h


@cached(nogil=True)
def outward_normals(start, stop, grad, out, flat):
    """Unit outward normals -grad f / ``|grad f|`` of vertices start..stop - 1 into out; where
    ``|grad f|`` < 1e-12, ``flat`` is set and out left at 0 (the caller puts a face normal
    there)."""
    for r in range(start, stop):
        gx, gy, gz = -grad[r, 0], -grad[r, 1], -grad[r, 2]
        length = math.sqrt(gx * gx + gy * gy + gz * gz)
        flat[r] = length < 1e-12
        scale = 0.0 if flat[r] else 1.0 / length
        out[r, 0], out[r, 1], out[r, 2] = gx * scale, gy * scale, gz * scale
