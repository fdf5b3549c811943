"""Difference: B_1 - B_2 - ... (CSG), min(f_1, 2 * 0.5 - f_2, ...) clamped at 0."""

from __future__ import annotations

import numpy as np

from ..jit import kernel
from . import kmath
from .base import ISO, Node, Operator, OperatorKernels, pick, register


@kernel
def difference_combine(vs, b, k, p, o, mode):
    best = b
    bf = vs[b, 0]
    for j in range(b + 1, b + k):
        f = 1.0 - vs[j, 0]  # 2 * iso - f_j, iso = 0.5
        if f < bf:
            best, bf = j, f
    if best != b:
        if vs[best, 0] > 0.0:
            kmath.copy_entry(vs, best, b, -1.0)
        else:  # a subtrahend absent here only caps f_1 at 1: the colour stays f_1's
            vs[b, 0] = 1.0
            vs[b, 1] = vs[b, 2] = vs[b, 3] = 0.0
    if vs[b, 0] < 0.0:  # a subtrahend above 1 (a blend): clamp to 0, as the reference does
        vs[b, 0] = 0.0
        vs[b, 1] = vs[b, 2] = vs[b, 3] = 0.0


@kernel
def difference_rows(vs, b, k, p, o, nb):
    for j in range(b + 1, b + k):
        for m in range(nb):
            vs[b, m] = min(vs[b, m], 1.0 - vs[j, m])
    for m in range(nb):
        vs[b, m] = max(vs[b, m], 0.0)


@register
class Difference(Operator):
    """B_1 - B_2 - ...: max(0, min(f_1, 2*0.5 - f_2, ...)); the box is B_1's.

    Under specialisation a zero first child makes it zero, but a zero subtrahend is kept: it
    still caps the result at 1 (min(f_1, 1 - 0)).  Colour: the child that sets the value, except
    a subtrahend with no field there (it only caps f_1): then f_1's."""

    TYPE = "difference"
    ARITY = (2, None)
    ZERO_FIRST, ZERO_REST = "kill", "keep"
    LIPSCHITZ = "max"
    KERNELS = OperatorKernels(combine=difference_combine, rows=difference_rows)

    def _ref(self, P, look=None):
        f, g, c = self._refs(P, look)
        absent = np.concatenate([np.zeros_like(f[:1], dtype=bool), f[1:] <= 0.0])
        f = np.concatenate([f[:1], 2.0 * ISO - f[1:]])
        g = np.concatenate([g[:1], -g[1:]])
        i = np.argmin(f, axis=0)
        # a subtrahend with no field here only caps f_1 at 1: it does not paint (as under
        # specialisation, where a subtrahend outside its box is a placeholder with no colour)
        paint = np.where(np.take_along_axis(absent, i[None], 0)[0], 0, i)
        value = f.min(axis=0)
        # a subtrahend whose field exceeds 1 (a blend) would push the result below 0: clamp,
        # so the field stays in [0, 1] and is 0 outside the first child's box
        neg = (value < 0.0)[:, None]
        return np.maximum(value, 0.0), np.where(neg, 0.0, pick(i, g)), pick(paint, c)

    def combine_boxes(self, boxes):
        return boxes[0]


def difference(*nodes: Node) -> Difference:
    """B_1 - B_2 - ... (CSG difference)."""
    return Difference(*nodes)
