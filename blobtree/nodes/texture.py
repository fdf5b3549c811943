"""The 2D texture map m of Section 3.4, with the paper's two methods (see
``blobtree.texture.mapping``): field-interpolated (each primitive's own (u, v)) and bounding
surface (a tube around the helico-spiral, reached by following the field's gradient)."""

from __future__ import annotations

import math
from functools import cached_property
from typing import Any

import numpy as np

from .. import geometry as geo
from ..checks import Choice
from ..runtime.jit import kernel
from ..texture import mapping as tex
from . import kernel_math
from .kernels import PaintKernels
from .kinds import Paint
from .layout import Layout
from .node import register
from .params import Image, Mapping, Param

LAYOUT = Layout(0, to_local=12, normal_map=9, r0=1, rho=1, cot_beta=1, d_over_r=1,
                theta_max=1, u_period=1, u_start=1, radius_factor=1, gradient_weight=1, step=1,
                max_steps=1, image=1)
(TO_LOCAL, NORMAL_MAP, R0, RHO, COT_BETA, D_OVER_R, THETA_MAX, U_PERIOD, U_START, RADIUS_FACTOR,
 GRADIENT_WEIGHT, STEP, MAX_STEPS, IMAGE) = LAYOUT.offsets


@kernel
def helico_locate(p, o, x, y, z):
    """Nearest whorl of the spiral (as ``HelicoSurface.locate``): theta, dr, dy, the radial
    unit vector (rx, rz) and D."""
    r0, rho_, cot = p[o + R0], p[o + RHO], p[o + COT_BETA]
    rho = math.sqrt(x * x + z * z)
    phi = math.degrees(kernel_math.atan2(-z, x))
    if phi < 0.0:
        phi += 360.0
    best_t, best_d, best_r = 0.0, np.inf, 0.0
    r = r0 * rho_ ** (phi / 360.0)  # the radius at phi; each whorl out, rho times larger
    for k in range(int(p[o + THETA_MAX] // 360.0) + 2):
        d = ((rho - r) ** 2 + (y - r * cot) ** 2) / (r * r)  # relative to the whorl's size
        if d < best_d:
            best_t, best_d, best_r = phi + 360.0 * k, d, r
        r *= rho_
    rx, rz = (x / rho, z / rho) if rho > 0.0 else (0.0, 0.0)
    return best_t, rho - best_r, y - best_r * cot, rx, rz, p[o + D_OVER_R] * best_r


@kernel
def texture_paint(p, o, px, py, pz, gx, gy, gz):
    """Move the point toward the bounding surface (as ``HelicoSurface.uv``), then sample."""
    x, y, z = kernel_math.map_point(p, o + TO_LOCAL, px, py, pz)
    m = o + NORMAL_MAP
    lx = p[m] * gx + p[m + 1] * gy + p[m + 2] * gz
    ly = p[m + 3] * gx + p[m + 4] * gy + p[m + 5] * gz
    lz = p[m + 6] * gx + p[m + 7] * gy + p[m + 8] * gz
    gn = math.sqrt(lx * lx + ly * ly + lz * lz)
    if gn > tex.MIN_GRADIENT:
        lx, ly, lz = -lx / gn, -ly / gn, -lz / gn  # the field falls outward
    else:
        lx, ly, lz = 0.0, 0.0, 0.0  # flat field: no direction (as the reference)
    factor, wgt, step = p[o + RADIUS_FACTOR], p[o + GRADIENT_WEIGHT], p[o + STEP]
    for _ in range(int(p[o + MAX_STEPS])):
        theta, dr, dy, rx, rz, d = helico_locate(p, o, x, y, z)
        dist = math.sqrt(dr * dr + dy * dy)
        if dist >= factor * d:
            break
        nx, ny, nz = 0.0, 0.0, 0.0
        if dist > 0.0:
            nx, ny, nz = dr / dist * rx, dy / dist, dr / dist * rz
        sx = wgt * lx + (1.0 - wgt) * nx
        sy = wgt * ly + (1.0 - wgt) * ny
        sz = wgt * lz + (1.0 - wgt) * nz
        sn = math.sqrt(sx * sx + sy * sy + sz * sz)
        if sn > 0.0:
            h = step * d / sn
            x, y, z = x + h * sx, y + h * sy, z + h * sz
    theta, dr, dy, rx, rz, d = helico_locate(p, o, x, y, z)
    return kernel_math.texel(p, int(p[o + IMAGE]), (theta - p[o + U_START]) / p[o + U_PERIOD],
                             kernel_math.turn(dy, dr))


@register
class Texture(Paint):
    """The 2D texture-map operator m (Section 3.4) with one of the paper's two methods:
    ``mapping="primitive"`` (field-interpolated: each primitive below uses its own (u, v)) or a
    :class:`~blobtree.texture.mapping.HelicoSurface` (bounding surface).  ``image``: a PNG/JPEG
    path, an (H, W, 3) array (uint8, or floats in [0, 1]) or a function of (u, v) arrays returning
    (..., 3) colours.

    Which paint wins: colour nodes and bounding-surface textures paint their whole subtree (the
    outermost wins); a field-interpolated texture paints the primitives below it that no nearer
    field-interpolated texture paints."""

    TYPE = "texture"
    METHOD = "texture"
    PARAMS = (
        Param("image", Image()),
        Param("mapping", Mapping(), "primitive"),
        Param("wrap", Choice(tuple(tex.WRAPS)), "repeat"),
    )
    KERNELS = PaintKernels(paint=texture_paint)

    @property
    def sets_look(self) -> bool:
        """True for the field-interpolated mapping (``mapping="primitive"``)."""
        return self.mapping == "primitive"

    @cached_property
    def digest(self) -> str:
        """Content key of the image (programs and scene files store each distinct image once)."""
        return tex.image_digest(self.image)

    @property
    def image_key(self) -> str:
        """Key of the image block in a program: equal keys share one copy."""
        return f"{self.digest}:{self.wrap}"

    def pack(self, frame, image_offset):
        ms = self.mapping
        sp = ms.spiral
        return LAYOUT.pack(
            to_local=geo.invert(frame), normal_map=frame[:, :3].T, r0=sp.r0, rho=sp.rho,
            cot_beta=1.0 / math.tan(math.radians(sp.beta)), d_over_r=sp.d_over_r,
            theta_max=ms.theta_max, u_period=ms.u_period, u_start=ms.u_start,
            radius_factor=ms.radius_factor,
            gradient_weight=ms.gradient_weight, step=ms.step, max_steps=ms.max_steps,
            image=image_offset(self))

    def image_block(self) -> np.ndarray:
        """The image in the program (stored once per ``image_key``): width, height, wrap id, then
        the rgb rows in [0, 1] (read by ``kernel_math.texel``)."""
        h, w = self.image.shape[:2]
        head = [w, h, tex.WRAPS[self.wrap]]
        return np.concatenate([head, self.image.reshape(-1) / 255.0])

    def paint(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Texture colours at (u, v)."""
        return tex.sample(self.image, u, v, self.wrap)

    def _ref(self, P, look: Any = None):
        if self.sets_look:
            return self.child._ref(P, self)
        f, g, _ = self.child._ref(P, look)
        return f, g, self.paint(*self.mapping.uv(P, g))
