"""Cylinder primitive: a solid cylinder skeleton (axis a-b, radius ``cylinder_radius``)."""

from __future__ import annotations

import math

import numpy as np

from .. import geometry as geo
from ..checks import Vec3, positive
from ..runtime.jit import kernel
from ..texture import mapping as tex
from . import kernel_math
from .kernels import PrimitiveKernels
from .kinds import FALLOFF_PARAM, Primitive
from .layout import GEOMETRY, RADIUS, Layout
from .node import register
from .params import Param

LAYOUT = Layout(GEOMETRY, a=3, b=3, cylinder_radius=1, frame=6)
A, B, CYL, FRAME = LAYOUT.offsets


@kernel
def cylinder_s(p, o, qx, qy, qz):
    a = o + A
    ax, ay, az = p[a], p[a + 1], p[a + 2]
    ux, uy, uz = p[o + B] - ax, p[o + B + 1] - ay, p[o + B + 2] - az
    length = math.sqrt(ux * ux + uy * uy + uz * uz)
    ux, uy, uz = ux / length, uy / length, uz / length
    wx, wy, wz = qx - ax, qy - ay, qz - az
    hh = wx * ux + wy * uy + wz * uz
    rx, ry, rz = wx - hh * ux, wy - hh * uy, wz - hh * uz
    rho = math.sqrt(rx * rx + ry * ry + rz * rz)
    sc = min(rho, p[o + CYL]) / rho if rho > 0.0 else 0.0
    t = min(max(hh, 0.0), length)
    return kernel_math.squared(qx - (ax + t * ux + sc * rx), qy - (ay + t * uy + sc * ry),
                               qz - (az + t * uz + sc * rz), p[o + RADIUS])


@kernel
def cylinder_uv(p, o, qx, qy, qz):
    return kernel_math.axis_uv(p, o + A, o + FRAME, qx, qy, qz, False)


@register
class Cylinder(Primitive):
    """Solid cylinder skeleton of radius ``cylinder_radius`` with axis a-b."""

    TYPE = "cylinder"
    PARAMS = (
        Param("a", Vec3()),
        Param("b", Vec3()),
        Param("cylinder_radius", positive(sample=(0.1, 0.6)), 0.5, "radius of the skeleton"),
        Param("radius", positive(), 0.2, "field radius R"),
        FALLOFF_PARAM,
    )
    LAYOUT = LAYOUT
    KERNELS = PrimitiveKernels(s=cylinder_s, uv=cylinder_uv)

    def _check(self):
        if np.linalg.norm(self.b - self.a) == 0.0:
            raise ValueError(f"a and b must differ (zero-length axis at {tuple(self.a)})")

    def pack(self):
        return LAYOUT.pack(a=self.a, b=self.b, cylinder_radius=self.cylinder_radius,
                           frame=np.concatenate(tex.perpendicular_frame(self.b - self.a)))

    def _delta(self, q):
        axis = self.b - self.a
        length = np.linalg.norm(axis)
        u = axis / length
        w = q - self.a
        h = w @ u
        radial = w - h[:, None] * u
        rho = np.linalg.norm(radial, axis=1)
        scale = np.where(rho > 0.0, np.minimum(rho, self.cylinder_radius) / np.where(
            rho > 0.0, rho, 1.0), 0.0)
        closest = self.a + np.clip(h, 0.0, length)[:, None] * u + scale[:, None] * radial
        return q - closest

    def uv(self, q):
        """u = angle around the axis, v = height along it / length."""
        axis = self.b - self.a
        w = q - self.a
        e1, e2 = tex.perpendicular_frame(axis)
        return tex.turn(w @ e2, w @ e1), np.clip(w @ axis / (axis @ axis), 0.0, 1.0)

    def _box(self, L):
        u = (self.b - self.a) / np.linalg.norm(self.b - self.a)
        rows = L[:, :3]
        disc = self.cylinder_radius * np.sqrt(
            np.maximum((rows**2).sum(axis=1) - (rows @ u) ** 2, 0.0))
        h = disc + geo.ellipsoid_half(L, self.radius)
        ends = []
        for p in (self.a, self.b):
            c = rows @ p + L[:, 3]
            ends.append((c - h, c + h))
        return geo.box_union(ends)
