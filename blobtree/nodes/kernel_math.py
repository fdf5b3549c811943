"""Small compiled helpers shared by the node types' kernels (scalars in, scalars out).

The falloffs are ``fields.py``'s plain functions, compiled here, so the numpy reference and the
kernels evaluate the very same formulas.
"""

from __future__ import annotations

import math

import numpy as np

from ..fields import SLOPE_BY_ID, falloff, falloff_ds, falloff_peak
from ..runtime.jit import kernel
from .layout import ABOVE, BELOW, BOUND, COLOR, FALLOFF, FIELD, GRAD, LEAST, MAP_NORM, MOST
from .node import ISO
from .reference import TIE

fo = kernel(falloff)
fo_ds = kernel(falloff_ds)
fo_peak = kernel(falloff_peak)


@kernel(inline="always")
def affine(p, o):
    """The 3x4 affine map at params[o:o + 12], row by row, as a tuple: read once before a loop
    over many points (:func:`map_with`), so that the loop vectorises."""
    return (p[o], p[o + 1], p[o + 2], p[o + 3], p[o + 4], p[o + 5], p[o + 6], p[o + 7],
            p[o + 8], p[o + 9], p[o + 10], p[o + 11])


@kernel(inline="always")
def map_with(a, x, y, z):
    """The affine map ``a`` (:func:`affine`) applied to (x, y, z)."""
    return (a[0] * x + a[1] * y + a[2] * z + a[3],
            a[4] * x + a[5] * y + a[6] * z + a[7],
            a[8] * x + a[9] * y + a[10] * z + a[11])


@kernel
def map_point(p, o, x, y, z):
    """The 3x4 affine map at params[o:o + 12] applied to (x, y, z)."""
    return map_with(affine(p, o), x, y, z)


@kernel(inline="always")
def permutation(p, o):
    """A warp's signed permutation Pm (frame axes to its canonical axes) at params[o:o + 9], row
    by row, read once for many points."""
    return (p[o], p[o + 1], p[o + 2], p[o + 3], p[o + 4], p[o + 5], p[o + 6], p[o + 7], p[o + 8])


@kernel(inline="always")
def to_canonical_with(m, x, y, z):
    """A warp's frame point in its canonical axes: X = Pm x (m: :func:`permutation`)."""
    return (m[0] * x + m[1] * y + m[2] * z, m[3] * x + m[4] * y + m[5] * z,
            m[6] * x + m[7] * y + m[8] * z)


@kernel(inline="always")
def from_canonical_with(m, qx, qy, qz):
    """A canonical point back in the warp's frame: Pm^T q."""
    return (m[0] * qx + m[3] * qy + m[6] * qz, m[1] * qx + m[4] * qy + m[7] * qz,
            m[2] * qx + m[5] * qy + m[8] * qz)


@kernel(inline="always")
def to_canonical(p, o, x, y, z):
    """:func:`to_canonical_with` the permutation at params[o:o + 9]."""
    return to_canonical_with(permutation(p, o), x, y, z)


@kernel(inline="always")
def from_canonical(p, o, qx, qy, qz):
    """:func:`from_canonical_with` the permutation at params[o:o + 9]."""
    return from_canonical_with(permutation(p, o), qx, qy, qz)


@kernel
def map_box(p, o, lox, loy, loz, hix, hiy, hiz):
    """Centre and half extents of the box around the image of [lo, hi] under the 3x4 affine map
    at params[o:o + 12]."""
    cx, cy, cz = map_point(p, o, 0.5 * (lox + hix), 0.5 * (loy + hiy), 0.5 * (loz + hiz))
    ex, ey, ez = 0.5 * (hix - lox), 0.5 * (hiy - loy), 0.5 * (hiz - loz)
    return (cx, cy, cz,
            abs(p[o]) * ex + abs(p[o + 1]) * ey + abs(p[o + 2]) * ez,
            abs(p[o + 4]) * ex + abs(p[o + 5]) * ey + abs(p[o + 6]) * ez,
            abs(p[o + 8]) * ex + abs(p[o + 9]) * ey + abs(p[o + 10]) * ez)


@kernel
def quadric_rise(p, o, centre, k, box, d, spread):
    """How fast the field f(s) of s = sum_i k_i (q_i - c_i)^2 (a point's or an ellipsoid's;
    ``centre`` = (c_x, c_y, c_z), ``k`` = (k_x, k_y, k_z)) can rise in the frame box ``box`` =
    (lo_x, lo_y, lo_z, hi_x, hi_y, hi_z) along unit directions d' within ``spread`` of the unit
    vector ``d`` = (d_x, d_y, d_z); q = M x + t is the local point of frame point x (the map at
    params[o:o + 12], its norm at MAP_NORM).  df/dt = f'(s) ds/dt with f' <= 0, so only where s
    falls: -ds/dt / 2 = -sum_i k_i (q_i - c_i) e_i - sum_i k_i (q_i - c_i) (e'_i - e_i), e = M d;
    the first term is linear in x (its largest over the box is exact), the second at most
    max k |q - c| |M| spread.  |f'| is largest at the box's least s (both falloffs' slopes fall
    with s).  0 where the whole box moves away from the centre: rays there only leave the
    primitive."""
    cx, cy, cz = centre
    kx, ky, kz = k
    lox, loy, loz, hix, hiy, hiz = box
    dx, dy, dz = d
    ex = p[o] * dx + p[o + 1] * dy + p[o + 2] * dz
    ey = p[o + 4] * dx + p[o + 5] * dy + p[o + 6] * dz
    ez = p[o + 8] * dx + p[o + 9] * dy + p[o + 10] * dz
    ax, ay, az = kx * ex, ky * ey, kz * ez  # -ds/dt / 2 is -(M x + t - c) . a, plus the spread
    hx, hy, hz = 0.5 * (hix - lox), 0.5 * (hiy - loy), 0.5 * (hiz - loz)
    # the local image of the box's centre, and the half extents of the box around its image
    qx, qy, qz, ux, uy, uz = map_box(p, o, lox, loy, loz, hix, hiy, hiz)
    qx, qy, qz = qx - cx, qy - cy, qz - cz
    fall = -(qx * ax + qy * ay + qz * az)
    for j in range(3):  # plus the box's reach along the linear term's gradient M^T a
        fall += abs(p[o + j] * ax + p[o + 4 + j] * ay + p[o + 8 + j] * az) * (hx, hy, hz)[j]
    if spread > 0.0:
        norm = p[o + MAP_NORM]
        far = math.sqrt(qx * qx + qy * qy + qz * qz) + norm * math.sqrt(hx * hx + hy * hy
                                                                         + hz * hz)
        fall += max(kx, ky, kz) * far * norm * spread
    if fall <= 0.0:
        return 0.0
    least = 0.0  # the least s over the box around the region's image
    for off, half, k in ((qx, ux, kx), (qy, uy, ky), (qz, uz, kz)):
        gap = max(abs(off) - half, 0.0)
        least += k * gap * gap
    if least >= 1.0:
        return 0.0
    return 2.0 * fall * abs(fo_ds(int(p[o + FALLOFF]), least))


#: atan t = t + t^3 h(t^2) for |t| <= tan(pi/8): h's coefficients, lowest power first (the
#: Chebyshev interpolant of degree 9 of h on [0, tan^2(pi/8)], in powers; within 1.2e-16 of
#: atan there, as tests/test_nodes.py checks against numpy)
H0, H1, H2, H3, H4 = (-0.33333333333331516, 0.19999999999802026, -0.14285714274322206,
                      0.11111110319015749, -0.09090872281504862)
H5, H6, H7, H8, H9 = (0.07691354281266516, -0.0665223787093906, 0.057497483410760664,
                      -0.04520512595442775, 0.023182787692348546)
TAN_PI_8 = math.tan(math.pi / 8.0)


@kernel(inline="always")
def by_squaring(n):
    """Does :func:`power` take x ** n by repeated squaring (n a whole number below 2^16)?"""
    return n == np.floor(n) and n < 65536.0


@kernel(inline="always")
def power(x, n):
    """x ** n, by repeated squaring where n is a whole number below 2^16 (a few ulps from
    ``**``, and several times faster: the paper's n = 400 blends, the looks' shininess), else
    by ``**``."""
    if not by_squaring(n):
        return x ** n
    k = int(n)
    r = 1.0
    while k:
        if k & 1:
            r *= x
        x *= x
        k >>= 1
    return r


@kernel(inline="always")
def root(s, n):
    """s ** (1 / n), without calling pow where s is 1: an n-norm's sum of (x / largest)^n is
    exactly 1 where only its largest term counts (most points, for the paper's n = 400)."""
    return 1.0 if s == 1.0 else s ** (1.0 / n)


@kernel(inline="always")
def atan2(y, x):
    """math.atan2(y, x) without branches, so that loops over many points vectorise: t, the
    smaller of |x|, |y| over the larger, reduced to |t| <= tan(pi/8) by atan t = pi/4 +
    atan((t - 1) / (t + 1)), then the polynomial (H0..H9), then the octant from the signs.
    Within 4.5e-16 and 1e-15 relative of math.atan2 (tests/test_nodes.py); atan2(-0.0, x < 0)
    gives pi, not -pi."""
    ax, ay = abs(x), abs(y)
    hi = max(ax, ay)
    t = min(ax, ay) / hi if hi > 0.0 else 0.0
    big = t > TAN_PI_8
    t = (t - 1.0) / (t + 1.0) if big else t
    s = t * t
    h = H9
    h = h * s + H8
    h = h * s + H7
    h = h * s + H6
    h = h * s + H5
    h = h * s + H4
    h = h * s + H3
    h = h * s + H2
    h = h * s + H1
    h = h * s + H0
    a = (0.25 * math.pi if big else 0.0) + (t + t * s * h)
    a = 0.5 * math.pi - a if ay > ax else a
    a = math.pi - a if x < 0.0 else a
    return -a if y < 0.0 else a


@kernel
def turn(y, x):
    """atan2(y, x) as a fraction of a turn in [0, 1) (as ``texture.mapping.turn``)."""
    t = atan2(y, x) / (2.0 * math.pi)
    if t < 0.0:
        t += 1.0
    return 0.0 if t >= 1.0 else t


def _slope_peak(fid: int) -> float:
    """r/R where falloff ``fid`` is steepest: its slope |df/dr| R = 2 (r/R) |f'(s)| rises from 0
    at the skeleton to one peak and falls to 0 at R (ternary search)."""
    lo, hi = 0.0, 1.0
    for _ in range(200):
        a, b = lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0
        if abs(falloff_ds(fid, a * a)) * a < abs(falloff_ds(fid, b * b)) * b:
            lo = a
        else:
            hi = b
    return lo


#: Per falloff id: where the slope peaks (r/R), and the peak slope |df/dr| R.
SLOPE_PEAK = np.array([_slope_peak(fid) for fid in range(len(SLOPE_BY_ID))])
PEAK_SLOPE = np.array([2.0 * r * abs(falloff_ds(fid, r * r)) for fid, r in enumerate(SLOPE_PEAK)])


@kernel
def slope_at(fid, rmin, rmax):
    """max |df/dr| R of falloff fid over r/R in [rmin, rmax], as a fraction of its peak (the
    slope rises from 0 at the skeleton to one peak and falls to 0 at R)."""
    if rmin >= 1.0:
        return 0.0
    r = min(max(SLOPE_PEAK[fid], rmin), rmax)
    return 2.0 * r * abs(fo_ds(fid, r * r)) / PEAK_SLOPE[fid]


@kernel
def _wrap(i, n, mode):
    if mode == 0:
        return i % n
    return min(max(i, 0), n - 1)


@kernel
def texel(p, t, u, v):
    """Bilinear colour of the texture block at params[t:] ([w, h, wrap, rgb rows in [0, 1]]),
    as ``texture.mapping.sample``."""
    w, h, wrap = int(p[t]), int(p[t + 1]), int(p[t + 2])
    x = u * w - 0.5
    y = v * h - 0.5
    fx0, fy0 = math.floor(x), math.floor(y)
    fx, fy = x - fx0, y - fy0
    x0, y0 = int(fx0), int(fy0)
    xa, xb = _wrap(x0, w, wrap), _wrap(x0 + 1, w, wrap)
    ya, yb = _wrap(y0, h, wrap), _wrap(y0 + 1, h, wrap)
    a, b = t + 3 + 3 * (ya * w + xa), t + 3 + 3 * (ya * w + xb)
    c, d = t + 3 + 3 * (yb * w + xa), t + 3 + 3 * (yb * w + xb)
    wa, wb, wc, wd = (1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy
    return (wa * p[a] + wb * p[b] + wc * p[c] + wd * p[d],
            wa * p[a + 1] + wb * p[b + 1] + wc * p[c + 1] + wd * p[d + 1],
            wa * p[a + 2] + wb * p[b + 2] + wc * p[c + 2] + wd * p[d + 2])


@kernel
def axis_uv(p, a, e, qx, qy, qz, on_axis):
    """(u, v) around the axis a -> b (a at params[a:a + 3], b at [a + 3:a + 6]) with the
    perpendicular frame e1, e2 at params[e:e + 6] (``texture.mapping.perpendicular_frame``): u is
    the angle about the axis, v the clamped position along it.  The angle is measured from the
    closest axis point (``on_axis``) or from a."""
    ax, ay, az = p[a], p[a + 1], p[a + 2]
    ux, uy, uz = p[a + 3] - ax, p[a + 4] - ay, p[a + 5] - az
    t = min(max(((qx - ax) * ux + (qy - ay) * uy + (qz - az) * uz)
                / (ux * ux + uy * uy + uz * uz), 0.0), 1.0)
    dx, dy, dz = qx - ax, qy - ay, qz - az
    if on_axis:
        dx, dy, dz = dx - t * ux, dy - t * uy, dz - t * uz
    d1 = dx * p[e] + dy * p[e + 1] + dz * p[e + 2]
    d2 = dx * p[e + 3] + dy * p[e + 4] + dz * p[e + 5]
    return turn(d2, d1), t


@kernel
def ring_delta(qx, qy, qz, ring, solid):
    """q minus the closest point of a circle (or solid disc) of radius ``ring`` in the xz plane."""
    rho = math.sqrt(qx * qx + qz * qz)
    if solid and rho <= ring:
        return 0.0, qy, 0.0
    if rho > 0.0:
        return qx - ring * qx / rho, qy, qz - ring * qz / rho
    return qx - ring, qy, qz


@kernel
def squared(dx, dy, dz, radius):
    """s = |d|^2 / R^2 and ds/dq = 2 d / R^2 for a constant field radius R."""
    k = 1.0 / (radius * radius)
    return (dx * dx + dy * dy + dz * dz) * k, 2.0 * k * dx, 2.0 * k * dy, 2.0 * k * dz


@kernel
def select(vs, b, k, largest):
    """The child with the largest (or smallest) field among value-stack rows b .. b + k - 1
    becomes row b: union and intersection (ties within ``TIE`` keep the first)."""
    best = b
    for j in range(b + 1, b + k):
        fj, fb = vs[j, FIELD], vs[best, FIELD]
        if ((fj > fb + TIE or (fb == 0.0 and fj > 0.0)) if largest
                else (fj < fb - TIE or (fj == 0.0 and fb > 0.0))):
            best = j
    if best != b:
        copy_entry(vs, best, b, 1.0)


@kernel
def gaps(f, bound):
    """How far from a point a field of value f there and gradient bound L around it surely stays
    below and above ISO: |ISO - f| / L on the side f is on (infinite for L = 0), 0 on the other."""
    gap = abs(f - ISO) / bound if bound > 0.0 else math.inf
    return (gap if f < ISO else 0.0), (gap if f > ISO else 0.0)


@kernel
def safe_distances(vs, j):
    """How far from the region's point the field of value-stack row j surely stays below and
    above ISO: the larger of what its operator proved (vs[j, BELOW], vs[j, ABOVE]) and what its
    value and bound give (:func:`gaps`)."""
    below, above = gaps(vs[j, FIELD], vs[j, BOUND])
    return max(below, vs[j, BELOW]), max(above, vs[j, ABOVE])


@kernel(inline="always")
def field_range(vs, j, reach):
    """The least and the most the field of value-stack row j can be over a region of diameter
    reach in the value-aware bound pass: within f_j +- L_j reach, and within the range the pass
    found for it (vs[j, LEAST], vs[j, MOST]: from its primitives' distances)."""
    f, spread = vs[j, FIELD], vs[j, BOUND] * reach
    return max(f - spread, vs[j, LEAST]), min(f + spread, vs[j, MOST])


@kernel
def select_bound(vs, b, k, reach, largest):
    """Union's and intersection's bound over a region of diameter reach: child j stays within
    its range there (:func:`field_range`), so a child whose highest stays below another's
    lowest (union; the reverse for intersection) never wins in the region and its bound L_j is
    dropped.  A max stays below ISO as far as all its children do and above as far as any does
    (a min the reverse)."""
    edge = -math.inf if largest else math.inf  # the best of the children's worst cases
    all_below = all_above = math.inf
    any_below = any_above = 0.0
    for j in range(b, b + k):
        low, high = field_range(vs, j, reach)
        edge = max(edge, low) if largest else min(edge, high)
        below, above = safe_distances(vs, j)
        all_below, any_below = min(all_below, below), max(any_below, below)
        all_above, any_above = min(all_above, above), max(any_above, above)
    bound = 0.0
    for j in range(b, b + k):
        low, high = field_range(vs, j, reach)
        if (high >= edge) if largest else (low <= edge):
            bound = max(bound, vs[j, BOUND])
    if largest:
        return bound, all_below, any_above
    return bound, any_below, all_above


@kernel
def norm_of(vs, b, e, col, n):
    """The n-norm (sum x^n)^(1/n) of the non-negative vs[b:e, col], as m (sum (x / m)^n)^(1/n)
    with m the largest, so that no power overflows (n >= 1; at most their sum, and their largest
    for n -> infinity)."""
    m = 0.0
    for j in range(b, e):
        m = max(m, vs[j, col])
    if m <= 0.0:
        return 0.0
    s = 0.0
    for j in range(b, e):
        s += power(vs[j, col] / m, n)
    return m * root(s, n)


@kernel
def copy_entry(vs, src, dst, sign):
    """Value-stack row src into row dst; sign -1 stores 1 - f and the negated gradient."""
    vs[dst, FIELD] = vs[src, FIELD] if sign > 0 else 1.0 - vs[src, FIELD]
    for c in range(GRAD, GRAD + 3):
        vs[dst, c] = sign * vs[src, c]
    for c in range(COLOR, COLOR + 3):
        vs[dst, c] = vs[src, c]
