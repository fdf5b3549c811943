"""Torus and disc primitives: a circle (the paper's varix tori, Section 3.2) or a solid disc in
the xz plane, sharing their geometry."""

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

LAYOUT = Layout(GEOMETRY, ring=1, center=3)
RING, CENTER = LAYOUT.offsets


@kernel
def torus_s(p, o, qx, qy, qz):
    c = o + CENTER
    dx, dy, dz = kernel_math.ring_delta(qx - p[c], qy - p[c + 1], qz - p[c + 2], p[o + RING], False)
    return kernel_math.squared(dx, dy, dz, p[o + RADIUS])


@kernel
def disc_s(p, o, qx, qy, qz):
    c = o + CENTER
    dx, dy, dz = kernel_math.ring_delta(qx - p[c], qy - p[c + 1], qz - p[c + 2], p[o + RING], True)
    return kernel_math.squared(dx, dy, dz, p[o + RADIUS])


@kernel
def torus_uv(p, o, qx, qy, qz):
    c = o + CENTER
    dx, dy, dz = qx - p[c], qy - p[c + 1], qz - p[c + 2]
    rho = math.sqrt(dx * dx + dz * dz) - p[o + RING]
    return kernel_math.turn(-dz, dx), kernel_math.turn(dy, rho)


@kernel
def disc_uv(p, o, qx, qy, qz):
    c = o + CENTER
    dx, dz = qx - p[c], qz - p[c + 2]
    return kernel_math.turn(-dz, dx), min(math.sqrt(dx * dx + dz * dz) / p[o + RING], 1.0)


class _Ring(Primitive):
    """Shared geometry: a circle of radius ``ring`` about ``center`` in the xz plane."""

    LAYOUT = LAYOUT
    SOLID = False

    @property
    def ring(self) -> float:
        """The radius of the skeleton circle (torus) or disc."""
        raise NotImplementedError

    def pack(self):
        return LAYOUT.pack(ring=self.ring, center=self.center)

    def _delta(self, q):
        q = q - self.center
        rho = np.hypot(q[:, 0], q[:, 2])
        safe = np.where(rho > 0.0, rho, 1.0)
        cx = np.where(rho > 0.0, q[:, 0] / safe, 1.0) * self.ring
        cz = np.where(rho > 0.0, q[:, 2] / safe, 0.0) * self.ring
        closest = np.stack([cx, np.zeros_like(cx), cz], axis=1)
        if self.SOLID:
            flat = np.stack([q[:, 0], np.zeros(len(q)), q[:, 2]], axis=1)
            closest = np.where((rho <= self.ring)[:, None], flat, closest)
        return q - closest

    def _box(self, L):
        c = L[:, :3] @ self.center + L[:, 3]
        h = self.ring * np.hypot(L[:, 0], L[:, 2]) + geo.ellipsoid_half(L, self.radius)
        return c - h, c + h


@register
class Torus(_Ring):
    """Circle skeleton of radius ``major_radius`` in the xz plane."""

    TYPE = "torus"
    PARAMS = (
        Param("major_radius", positive(sample=(0.2, 1.0)), 1.0, "radius of the circle"),
        Param("radius", positive(), 0.2, "field radius R"),
        Param("center", Vec3(), (0.0, 0.0, 0.0)),
        FALLOFF_PARAM,
    )
    KERNELS = PrimitiveKernels(s=torus_s, uv=torus_uv)

    @property
    def ring(self) -> float:
        return self.major_radius

    def uv(self, q):
        """u = angle around +y, v = angle around the tube."""
        d = q - self.center
        rho = np.hypot(d[:, 0], d[:, 2])
        return tex.turn(-d[:, 2], d[:, 0]), tex.turn(d[:, 1], rho - self.ring)


@register
class Disc(_Ring):
    """Solid disc skeleton of radius ``disc_radius`` in the xz plane."""

    TYPE = "disc"
    SOLID = True
    PARAMS = (
        Param("disc_radius", positive(sample=(0.2, 1.0)), 1.0, "radius of the disc"),
        Param("radius", positive(), 0.2, "field radius R"),
        Param("center", Vec3(), (0.0, 0.0, 0.0)),
        FALLOFF_PARAM,
    )
    KERNELS = PrimitiveKernels(s=disc_s, uv=disc_uv)

    @property
    def ring(self) -> float:
        return self.disc_radius

    def uv(self, q):
        """u = angle around +y, v = distance from the centre / disc radius."""
        d = q - self.center
        rho = np.hypot(d[:, 0], d[:, 2])
        return tex.turn(-d[:, 2], d[:, 0]), np.minimum(rho / self.ring, 1.0)
