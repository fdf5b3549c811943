"""Difference: B_1 - B_2 - ... (CSG), min(f_1, 2 * 0.5 - f_2, ...) clamped at 0; optionally with
rounded edges (a polynomial smooth minimum over a band of field values)."""

from __future__ import annotations

import numpy as np

from ..checks import Number
from ..runtime.jit import kernel
from . import kernel_math
from .kernels import OperatorKernels
from .kinds import Operator, operator_function
from .layout import BOUND, COLOR, FIELD, GRAD, GRADIENT
from .node import ISO, register
from .params import Param


@kernel
def rounded_min(x, y, r):
    """min(x, y) - r h^2 / 4 with h = max(r - ``|x - y|``, 0) / r (a polynomial smooth minimum, 0 <=
    h <= 1) and the weights of x and y in its gradient, (1 - h / 2, h / 2) where x is the smaller,
    summing to 1; r = 0 is the plain minimum."""
    h = max(r - abs(x - y), 0.0) / r if r > 0.0 else 0.0
    small, large = 1.0 - 0.5 * h, 0.5 * h
    if x <= y:
        return x - 0.25 * r * h * h, small, large
    return y - 0.25 * r * h * h, large, small


@kernel
def difference_combine(vs, b, k, p, o, mode):
    """Left to right: f <- rounded_min(f, 1 - f_j) (1 - f_j = 2 * iso - f_j, iso = 0.5); the
    colour is the smaller term's, except a subtrahend absent here (f_j = 0), which only caps f_1
    at 1 and does not paint."""
    r = p[o]
    for j in range(b + 1, b + k):
        y = 1.0 - vs[j, FIELD]
        f, wx, wy = rounded_min(vs[b, FIELD], y, r)
        if mode >= GRADIENT:
            for c in range(GRAD, GRAD + 3):
                vs[b, c] = wx * vs[b, c] - wy * vs[j, c]
            if y < vs[b, FIELD] and vs[j, FIELD] > 0.0:
                for c in range(COLOR, COLOR + 3):
                    vs[b, c] = vs[j, c]
        vs[b, FIELD] = f
    if vs[b, FIELD] < 0.0:  # a subtrahend above 1 (a blend): clamp to 0, as the reference does
        vs[b, FIELD] = 0.0
        vs[b, GRAD] = vs[b, GRAD + 1] = vs[b, GRAD + 2] = 0.0


@kernel
def difference_bound(vs, b, k, p, o, reach):
    """Left to right, as :func:`difference_combine`: over the region the running min f and the
    next term y = 1 - f_j stay within their ranges (``kernel_math.field_range``; the running
    min's also within its value +- its bound times reach, and at most r / 4 below the min of
    its terms' ranges); a term that stays at least the rounding band above f leaves f as it is
    (its bound is dropped), one that stays that far below replaces it (so does its bound),
    otherwise the bound is the larger of the two.  The result stays below ISO as far as any
    term does (1 - f_j as far as f_j stays above)."""
    r = p[o]
    f, bound = vs[b, FIELD], vs[b, BOUND]
    f_lo, f_hi = kernel_math.field_range(vs, b, reach)
    below, above = kernel_math.safe_distances(vs, b)
    for j in range(b + 1, b + k):
        y, bound_y = 1.0 - vs[j, FIELD], vs[j, BOUND]
        least, most = kernel_math.field_range(vs, j, reach)
        y_lo, y_hi = 1.0 - most, 1.0 - least
        if y_lo >= f_hi + r:
            pass
        elif f_lo >= y_hi + r:
            bound = bound_y
        else:
            bound = max(bound, bound_y)
        f = rounded_min(f, y, r)[0]
        f_lo = max(min(f_lo, y_lo) - 0.25 * r, f - bound * reach)
        f_hi = min(f_hi, y_hi, f + bound * reach)
        below_j, above_j = kernel_math.safe_distances(vs, j)
        # the (rounded) min stays above ISO as far as all terms do, if sharp (rounding lowers it)
        below, above = max(below, above_j), min(above, below_j)
    return bound, below, above if r == 0.0 else 0.0


@kernel
def difference_rows(vs, b, k, p, o, nb):
    r = p[o]
    for j in range(b + 1, b + k):
        for m in range(nb):
            vs[b, m] = rounded_min(vs[b, m], 1.0 - vs[j, m], r)[0]
    for m in range(nb):
        vs[b, m] = max(vs[b, m], 0.0)


@register
class Difference(Operator):
    """B_1 - B_2 - ...: max(0, min(f_1, 2*0.5 - f_2, ...)); the box is B_1's.

    ``smooth`` > 0 rounds the edges where the surfaces meet: each min becomes the polynomial
    smooth minimum ``min(x, y) - smooth h^2 / 4``, h = max(smooth - ``|x - y|``, 0) / smooth, which
    is at most the min (it only removes material, within the band ``|x - y|`` < smooth), C1, and has
    gradient weights in [0, 1] summing to 1, so the Lipschitz bound stays the larger child's.  A
    knife edge of the sharp difference (two surfaces meeting at a small angle) loses the part
    thinner than about smooth / (2 ``|grad f|``), which is what keeps a carved lip printable and
    sampled whole by the mesher.  0 (the default) is the paper's CSG difference.

    Under specialisation a zero first child makes it zero, but a zero subtrahend is kept: it
    still caps the result at 1 (min(f_1, 1 - 0)).  Colour: the child that sets the value, except
    a subtrahend with no field there (it only caps f_1): then f_1's."""

    TYPE = "difference"
    ARITY = (2, None)
    PARAMS = (Param("smooth", Number(lo=0.0, hi=0.5, sample=(0.0, 0.2)), 0.0,
                    "width of the rounding band in field value: 0 = the sharp CSG difference",
                    since=4),)
    ZERO_FIRST, ZERO_REST = "kill", "keep"
    LIPSCHITZ = "max"
    MONOTONE = (1, -1)  # min(f_1, 1 - f_j) clamped at 0
    KERNELS = OperatorKernels(combine=difference_combine, rows=difference_rows,
                              bound=difference_bound)

    def op_params(self):
        return [self.smooth]

    def _ref(self, P, look=None):
        f, g, c = self._refs(P, look)
        value, grad, colour = f[0], g[0], c[0]
        r = self.smooth
        for fj, gj, cj in zip(f[1:], g[1:], c[1:], strict=True):
            y = 2.0 * ISO - fj
            h = np.maximum(r - np.abs(value - y), 0.0) / r if r > 0.0 else np.zeros_like(y)
            x_smaller = (value <= y)[:, None]
            wx = np.where(x_smaller, 1.0 - h[:, None] / 2, h[:, None] / 2)
            grad = wx * grad - (1.0 - wx) * gj
            # a subtrahend with no field here only caps f_1 at 1: it does not paint (as under
            # specialisation, where a subtrahend outside its box is a placeholder with no colour)
            colour = np.where(((y < value) & (fj > 0.0))[:, None], cj, colour)
            value = np.minimum(value, y) - 0.25 * r * h * h
        # a subtrahend whose field exceeds 1 (a blend) would push the result below 0: clamp,
        # so the field stays in [0, 1] and is 0 outside the first child's box
        neg = (value < 0.0)[:, None]
        return np.maximum(value, 0.0), np.where(neg, 0.0, grad), colour

    def combine_boxes(self, boxes):
        return boxes[0]


difference = operator_function(
    Difference,
    """B_1 - B_2 - ... (CSG difference); ``smooth`` > 0 rounds its edges (a band of field values,
    see :class:`Difference`).""")
