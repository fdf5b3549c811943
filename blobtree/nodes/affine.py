"""Affine transforms t, s and r of Section 2.2.  They have no kernels: the compiler folds each
chain of them into the primitives below (one 3x4 map per primitive)."""

from __future__ import annotations

from collections.abc import Sequence
from functools import cached_property

import numpy as np

from .. import geometry as geo
from ..checks import MAX_SIZE, MIN_SIZE, Vec3, angle
from .kinds import Affine
from .node import Node, register
from .params import Axis, Param


@register
class Translate(Affine):
    """t(x, y, z)(B)."""

    TYPE = "translate"
    METHOD = "translate"
    PARAMS = (Param("offset", Vec3()),)

    @classmethod
    def chain(cls, child: Node, x: float | Sequence[float], y: float = 0.0,
              z: float = 0.0) -> Translate:
        """t(x, y, z)(B): move by (x, y, z) (or by one 3-vector x)."""
        offset = x if isinstance(x, Sequence | np.ndarray) else (x, y, z)
        return cls(child, offset)

    @cached_property
    def matrix(self):
        """The 3x4 map x -> x + offset."""
        return geo.affine(np.eye(3), self.offset)


@register
class Scale(Affine):
    """s(x, y, z)(B); factors must be non-zero."""

    TYPE = "scale"
    METHOD = "scale"
    PARAMS = (Param("factors", Vec3(sample=(0.5, 2.0), limit=MAX_SIZE, least=MIN_SIZE)),)

    @classmethod
    def chain(cls, child: Node, sx: float, sy: float | None = None,
              sz: float | None = None) -> Scale:
        """s(x, y, z)(B); one argument scales uniformly."""
        if sy is None and sz is None:
            return cls(child, (sx, sx, sx))
        if sy is None or sz is None:
            raise ValueError("scale takes one factor (uniform) or three (sx, sy, sz)")
        return cls(child, (sx, sy, sz))

    @cached_property
    def matrix(self):
        """The 3x4 map x -> diag(factors) x."""
        return geo.affine(np.diag(self.factors))


@register
class Rotate(Affine):
    """r(axis, theta)(B): right-hand rule, degrees."""

    TYPE = "rotate"
    METHOD = "rotate"
    PARAMS = (Param("axis", Axis()), Param("degrees", angle()))

    @cached_property
    def matrix(self):
        """The 3x4 rotation by ``degrees`` about ``axis`` (right-hand rule)."""
        return geo.affine(geo.rotation_matrix(self.axis, self.degrees))
