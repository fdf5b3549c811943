"""Colour: one colour for a whole subtree (the texture map m with a constant texture)."""

from __future__ import annotations

import numpy as np

from ..checks import RGB
from ..runtime.jit import kernel
from .kernels import PaintKernels
from .kinds import Paint
from .layout import Layout
from .node import register
from .params import Param

LAYOUT = Layout(0, rgb=3)
(COLOR,) = LAYOUT.offsets


@kernel
def color_paint(p, o, px, py, pz, gx, gy, gz):
    return p[o + COLOR], p[o + COLOR + 1], p[o + COLOR + 2]


@register
class Color(Paint):
    """A constant colour for the whole subtree."""

    TYPE = "color"
    METHOD = "color"
    PARAMS = (Param("rgb", RGB(), doc="colour, three numbers in [0, 1]"),)
    KERNELS = PaintKernels(paint=color_paint)

    def pack(self, frame, image_offset):
        return LAYOUT.pack(rgb=self.rgb)

    def _ref(self, P, look=None):
        f, g, _ = self.child._ref(P, look)
        return f, g, np.broadcast_to(self.rgb, P.shape).copy()
