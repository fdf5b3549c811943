"""Gradient-based blend (after Gourmel, Barthe, Cani, Wyvill et al., "A gradient-based implicit
blend", ACM TOG 32(2), 2013): two shapes blend where their surfaces meet at an angle, and stay a
union where their gradients are aligned (one shape on top of the other: no bulge, no small detail
blown up) or opposed (two shapes facing each other across a gap: no blending at a distance).

Their paper's key idea, kept here: the composition depends on the children's field values *and*
on the angle between their gradients.  Its operators are built for the GPU from a family of 2D
curves; ours is a simpler member of the same idea, fitted to our [0, 1] fields with iso-value
0.5 and to the ray tracer's need for sound Lipschitz bounds:

    h = max(f_a, f_b) + W(c) t(min(f_a, f_b)),   W(c) = (1 - c^2)^power,   c = n_a . n_b

(``power`` >= 1; t the lower field's share: itself, at most 1, from ISO up, falling linearly to
0 at ``contact`` below it; with contact 0, t = min(f_a, f_b, 1)).  W = 1 gives the plain blend
f_a + f_b (Eq. 4 with n = 1) and W = 0 the union (Eq. 5): perpendicular gradients (the crease
where two surfaces cross) blend fully, parallel or opposed ones not at all.  h >= max(f_a, f_b)
everywhere, and h is the union wherever either field is at most ``contact``, so nothing blends
away from where the two overlap; a small shape whose field reaches far (the paper's bumps on a
whorl, which needed n = 400) blends only where it touches with ``contact`` near ISO.

The gradient directions are taken by forward differences over a ``step`` s:
D = (f(x + s e_k) - f(x)) / s, n = D / max(|D|, floor).  The program evaluates each child at
x and at the three shifted points (four copies, their shifts folded into the primitives), so
the operator needs no second derivatives: its field is a Lipschitz function of eight field
values, its gradient follows exactly by the chain rule, and its Lipschitz bound follows from
the children's (the ``bound`` kernel and the ``scaled`` rule below).  Below ``floor`` the
gradient's direction counts as unknown (n shrinks with |D|, W tends to 1: full blend), as deep
inside a shape, where blending more changes no surface.
"""

from __future__ import annotations

import math

import numpy as np

from ..checks import Number
from ..runtime.jit import kernel
from . import kernel_math
from .kernels import OperatorKernels
from .kinds import Operator, operator_function
from .layout import BOUND, COLOR, FIELD, GRAD, GRADIENT
from .node import ISO, Node, register
from .params import Param
from .reference import TIE

#: The automatic step is at least this fraction of the smaller child's box diagonal.
MIN_STEP = 1e-3
#: A step (floor) given must be at least this fraction of the smaller child's box diagonal (of
#: the gentler child's Lipschitz bound): below it the differences are rounding noise.
SMALLEST = 1e-6
#: params[o + ...]: the plain rule's factor, step, floor, power, max |W'(c)|, contact
FACTOR, STEP, FLOOR, POWER, SLOPE_W, CONTACT = range(6)


@kernel
def share(low, contact):
    """(t, dt/dlow): the part of the lower field the blend adds, t = min(low, 1) from ISO up,
    falling linearly below it to 0 at ``contact`` (0: t = min(low, 1) everywhere), so that
    nothing blends where either field is below ``contact``."""
    if low >= 1.0:
        return 1.0, 0.0
    if low >= ISO:
        return low, 1.0
    if low <= contact:
        return 0.0, 0.0
    slope = 1.0 / (1.0 - 2.0 * contact)
    return (low - contact) * slope, slope


@kernel
def _direction(vs, j, h, floor):
    """(D / max(|D|, floor), |D|) for the child whose four copies start at value-stack row j."""
    f = vs[j, FIELD]
    dx, dy, dz = (vs[j + 1, FIELD] - f) / h, (vs[j + 2, FIELD] - f) / h, (vs[j + 3, FIELD] - f) / h
    g = math.sqrt(dx * dx + dy * dy + dz * dz)
    s = max(g, floor)
    return dx / s, dy / s, dz / s, g


@kernel
def _chain(vs, j, h, floor, g, a, b, scale, direct):
    """The gradient of ``scale`` * c + ``direct`` * f_j through child j's four copies:
    dc/dD = (b - (a.b) a) / |D| for |D| > floor (else b / floor), a = (a_x, a_y, a_z) this
    child's direction and b the other's, and dD/df(x + s e_k) = e_k / s, dD/df(x) = -(1, 1, 1)
    / s."""
    ax, ay, az = a
    bx, by, bz = b
    if g > floor:
        ab = ax * bx + ay * by + az * bz
        qx, qy, qz = (bx - ab * ax) / g, (by - ab * ay) / g, (bz - ab * az) / g
    else:
        qx, qy, qz = bx / floor, by / floor, bz / floor
    w0 = direct - scale * (qx + qy + qz) / h
    wx, wy, wz = scale * qx / h, scale * qy / h, scale * qz / h
    gx = w0 * vs[j, GRAD] + wx * vs[j + 1, GRAD] + wy * vs[j + 2, GRAD] + wz * vs[j + 3, GRAD]
    gy = (w0 * vs[j, GRAD + 1] + wx * vs[j + 1, GRAD + 1] + wy * vs[j + 2, GRAD + 1]
          + wz * vs[j + 3, GRAD + 1])
    gz = (w0 * vs[j, GRAD + 2] + wx * vs[j + 1, GRAD + 2] + wy * vs[j + 2, GRAD + 2]
          + wz * vs[j + 3, GRAD + 2])
    return gx, gy, gz


@kernel
def gradient_combine(vs, b, k, p, o, mode):
    """h = max(f_a, f_b) + (1 - c^2)^power t(min(f_a, f_b)) over rows b .. b + 7 (f_a and its
    three shifted copies, then f_b's); with mode >= GRADIENT the exact gradient (chain rule over the
    eight values) and the colour, weighted by each child's part of h."""
    h, floor, power = p[o + STEP], p[o + FLOOR], p[o + POWER]
    fa, fb = vs[b, FIELD], vs[b + 4, FIELD]
    ax, ay, az, ga = _direction(vs, b, h, floor)
    bx, by, bz, gb = _direction(vs, b + 4, h, floor)
    c = min(max(ax * bx + ay * by + az * bz, -1.0), 1.0)
    w = (1.0 - c * c) ** power
    a_wins = not fb > fa + TIE  # ties (base.TIE) go to the first child, as in the reference
    top, low = (fa, fb) if a_wins else (fb, fa)
    m, dm = share(low, p[o + CONTACT])
    value = top + w * m
    if mode >= GRADIENT:
        scale = -2.0 * power * c * (1.0 - c * c) ** (power - 1.0) * m  # dh/dc
        clamp = w * dm  # dh/d(low)
        da, db = (1.0, clamp) if a_wins else (clamp, 1.0)
        x0, y0, z0 = _chain(vs, b, h, floor, ga, (ax, ay, az), (bx, by, bz), scale, da)
        x1, y1, z1 = _chain(vs, b + 4, h, floor, gb, (bx, by, bz), (ax, ay, az), scale, db)
        wa, wb = (top, w * m) if a_wins else (w * m, top)
        total = wa + wb
        for col in range(COLOR, COLOR + 3):
            vs[b, col] = (wa * vs[b, col] + wb * vs[b + 4, col]) / total if total > 0.0 \
                else vs[b, col]
        vs[b, GRAD], vs[b, GRAD + 1], vs[b, GRAD + 2] = x0 + x1, y0 + y1, z0 + z1
    vs[b, FIELD] = value


@kernel
def _angle_slope(vs, j, reach, h, floor):
    """A bound on |grad c|'s share from child j over a region of diameter reach: |dc/dD| <=
    1 / max(|D|, floor) and |grad D| <= sqrt(sum_k (L_k + L_0)^2) / s (Frobenius), where |D|
    stays above its value at the point less the most D can change in the region."""
    spread = 0.0
    for k in range(1, 4):
        spread += (vs[j + k, BOUND] + vs[j, BOUND]) ** 2
    spread = math.sqrt(spread) / h
    g = _direction(vs, j, h, floor)[3]
    return spread / max(g - spread * reach, floor)


@kernel
def gradient_bound(vs, b, k, p, o, reach):
    """Over a region of diameter reach: |grad h| <= (L_a + L_b) / (1 - 2 contact) (the max and
    the share of the min, W <= 1) + max t max|W'| |grad c|, each child's value within f +- L
    reach; h stays below ISO while f_a + f_b does (t(m) <= m), and above it while either child
    does (h >= the union)."""
    h, floor = p[o + STEP], p[o + FLOOR]
    la, lb = vs[b, BOUND], vs[b + 4, BOUND]
    contact = p[o + CONTACT]
    m = share(min(vs[b, FIELD] + la * reach, vs[b + 4, FIELD] + lb * reach), contact)[0]
    turn = _angle_slope(vs, b, reach, h, floor) + _angle_slope(vs, b + 4, reach, h, floor)
    bound = (la + lb) / (1.0 - 2.0 * contact) + m * p[o + SLOPE_W] * turn
    total, slope = vs[b, FIELD] + vs[b + 4, FIELD], la + lb
    below = (ISO - total) / slope if total < ISO and slope > 0.0 else 0.0
    above = max(kernel_math.safe_distances(vs, b)[1], kernel_math.safe_distances(vs, b + 4)[1])
    return bound, below, above


def _slope_w(power: float) -> float:
    """max over c in [-1, 1] of |W'(c)| = 2 power |c| (1 - c^2)^(power - 1): at c^2 =
    1 / (2 power - 1)."""
    c2 = 1.0 / (2.0 * power - 1.0)
    return 2.0 * power * math.sqrt(c2) * (1.0 - c2) ** (power - 1.0)


@register
class GradientBlend(Operator):
    """Gradient-based blend of two shapes (Gourmel et al. 2013, adapted; see the module
    docstring): the plain blend where their gradients are perpendicular, the union where they
    are parallel or opposed.  ``step``: the forward-difference step of the gradient directions
    (0: a fifth of the steeper child's 1 / Lipschitz bound, at least ``MIN_STEP`` of the smaller
    child's box diagonal); ``floor``: the gradient magnitude
    below which a direction counts as unknown (0: a twentieth of the gentler child's Lipschitz
    bound); ``power``: W = (1 - c^2)^power, higher blends only nearer perpendicular;
    ``contact``: the field value below which the lower field adds nothing (a small shape whose
    field reaches far, such as a bump on a whorl, then blends only where it touches)."""

    TYPE = "gradient_blend"
    ARITY = (2, 2)
    PARAMS = (
        Param("step", Number(lo=0.0, hi=1e6, sample=(0.0, 0.0)), 0.0,
              "forward-difference step of the gradients (0: automatic)"),
        Param("floor", Number(lo=0.0, hi=1e9, sample=(0.0, 0.0)), 0.0,
              "gradient magnitude below which the direction is unknown (0: automatic)"),
        Param("power", Number(lo=1.0, hi=16.0, sample=(1.0, 4.0)), 1.0,
              "W = (1 - cos^2)^power: higher blends only nearer perpendicular"),
        Param("contact", Number(lo=0.0, hi=0.45, sample=(0.0, 0.4)), 0.0,
              "no blending where either field is below this (0: wherever both are > 0)"),
    )
    ZERO_FIRST = "keep"
    ZERO_REST = "keep"
    LIPSCHITZ = "scaled"
    WANTS_VALUES = True
    KERNELS = OperatorKernels(combine=gradient_combine, bound=gradient_bound)

    def _check(self) -> None:
        la, lb = (c.lipschitz() for c in self.children)
        # the automatic step: a fifth of 1 / L, but never below a thousandth of the smaller
        # child's box (a child's L can be far above its slopes, e.g. a gradient blend's own:
        # a step at the rounding level would make the differences noise)
        sizes = [float(np.linalg.norm(hi - lo)) for lo, hi in (c.bounds() for c in self.children)]
        size = min((d for d in sizes if math.isfinite(d) and d > 0.0), default=1.0)
        gentle = max(min(la, lb), 1e-12)
        if 0.0 < self.step < SMALLEST * size:  # differences over it would be rounding noise
            raise ValueError(f"step must be 0 (automatic) or at least {SMALLEST * size:.3g} "
                             f"({SMALLEST:g} of the smaller child's box), got {self.step!r}")
        if 0.0 < self.floor < SMALLEST * gentle:
            raise ValueError(f"floor must be 0 (automatic) or at least {SMALLEST * gentle:.3g} "
                             f"({SMALLEST:g} of the gentler child's Lipschitz bound), got "
                             f"{self.floor!r}")
        self._set("used_step", self.step if self.step > 0.0 else
                  max(0.2 / max(la, lb, 1e-12), MIN_STEP * size))
        self._set("used_floor", self.floor if self.floor > 0.0 else 0.05 * gentle)
        # without field values: |grad h| <= (1 / (1 - 2 contact) + 3 max|W'| / (floor step))
        # times the sum of the eight children's bounds (|grad D| <= 3 max L / step per child,
        # |dc/dD| <= 1 / floor, t <= 1 and dt/dlow <= 1 / (1 - 2 contact))
        self._set("factor", 1.0 / (1.0 - 2.0 * self.contact)
                  + 3.0 * _slope_w(self.power) / (self.used_floor * self.used_step))

    def op_params(self) -> list[float]:
        return [self.factor, self.used_step, self.used_floor, self.power, _slope_w(self.power),
                self.contact]

    def program_children(self) -> list[Node]:
        """Each child at x and shifted by the step along x, y and z (f(x + s e_k)); the same
        node objects each time (the compiler knows a subtree by its identity)."""
        def shifted() -> list[Node]:
            s = self.used_step
            return [n for c in self.children
                    for n in (c, c.translate(-s, 0, 0), c.translate(0, -s, 0),
                              c.translate(0, 0, -s))]

        return list(self.memo("_shifted", shifted))

    def _ref(self, P, look=None):
        s, floor, power = self.used_step, self.used_floor, self.power
        parts = []
        for child in self.children:  # f, grad f and colour at x, f and grad f at x + s e_k
            f, g, col = child._ref(P, look)
            shifted = [child._ref(P + s * e, look)[:2] for e in np.eye(3)]
            D = np.stack([fk - f for fk, _ in shifted], axis=1) / s
            norm = np.linalg.norm(D, axis=1)
            n = D / np.maximum(norm, floor)[:, None]
            # dD_k/dx = (grad f(x + s e_k) - grad f(x)) / s, row k
            dD = (np.stack([gk for _, gk in shifted], axis=1) - g[:, None, :]) / s
            parts.append((f, g, col, n, norm, dD))
        (fa, ga, ca, na, norm_a, dDa), (fb, gb, cb, nb, norm_b, dDb) = parts
        c = np.clip((na * nb).sum(axis=1), -1.0, 1.0)
        w = (1.0 - c * c) ** power
        a_wins = ~(fb > fa + TIE)  # ties go to the first child (base.TIE)
        top, low = np.where(a_wins, fa, fb), np.where(a_wins, fb, fa)
        m0 = self.contact  # the share t of the lower field, and dt/dlow
        ramp = np.maximum(low - m0, 0.0) / (1.0 - 2.0 * m0)
        m = np.where(low >= 1.0, 1.0, np.where(low >= ISO, low, ramp))
        dm = np.where(low >= 1.0, 0.0, np.where(low >= ISO, 1.0, np.where(
            low > m0, 1.0 / (1.0 - 2.0 * m0), 0.0)))
        value = top + w * m

        def dn(n, norm, other):  # dc/dD through n = D / max(|D|, floor)
            ab = (n * other).sum(axis=1, keepdims=True)
            return np.where((norm > floor)[:, None],
                            (other - ab * n) / np.where(norm > floor, norm, 1.0)[:, None],
                            other / floor)

        grad_c = (np.einsum("nk,nkc->nc", dn(na, norm_a, nb), dDa)
                  + np.einsum("nk,nkc->nc", dn(nb, norm_b, na), dDb))
        dw = -2.0 * power * c * (1.0 - c * c) ** (power - 1.0)
        clamp = w * dm
        g_top, g_low = np.where(a_wins[:, None], ga, gb), np.where(a_wins[:, None], gb, ga)
        grad = g_top + clamp[:, None] * g_low + (m * dw)[:, None] * grad_c
        wa, wb = np.where(a_wins, top, w * m), np.where(a_wins, w * m, top)
        total = wa + wb
        safe = np.where(total > 0.0, total, 1.0)[:, None]
        color = np.where((total > 0.0)[:, None], (wa[:, None] * ca + wb[:, None] * cb) / safe, ca)
        return value, grad, color


gradient_blend = operator_function(
    GradientBlend,
    """Gradient-based blend of a and b (Gourmel et al. 2013, adapted): blended where their
    surfaces cross, a union where their gradients are parallel or opposed.""")
