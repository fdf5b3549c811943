"""Lights and shading: Blinn-Phong with shadows (hard, or soft from the field), ambient occlusion
from the field, in linear RGB, encoded to sRGB at the end."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..checks import Number
from ..engine import interp
from ..jit import kernel
from .camera import Camera, as_color, as_vec3
from .trace import clip_box, trace_from_local

#: Row layout of the packed light array: kind (0 directional, 1 point), xyz, linear rgb.
DIRECTIONAL, POINT = 0.0, 1.0


@dataclass(frozen=True)
class Light:
    """A light: ``direction`` (the way the light travels, e.g. (0, -1, 0) shines straight down)
    or ``position`` (a point light, no falloff), with an RGB ``color`` in [0, 1] and an
    ``intensity`` multiplier."""

    direction: tuple[float, float, float] | None = None
    position: tuple[float, float, float] | None = None
    color: tuple[float, float, float] = (1.0, 1.0, 1.0)
    intensity: float = 1.0

    def __post_init__(self) -> None:
        if (self.direction is None) == (self.position is None):
            raise ValueError(
                f"Light needs exactly one of direction or position, got direction="
                f"{self.direction!r}, position={self.position!r}"
            )
        if self.direction is not None:
            d = as_vec3("direction", self.direction)
            if not np.linalg.norm(d) > 0.0:
                raise ValueError(f"direction must be a non-zero vector, got {self.direction!r}")
        else:
            as_vec3("position", self.position)
        as_color("color", self.color)
        Number(lo=0.0, hi=1e6).check("intensity", self.intensity)

    def packed(self) -> np.ndarray:
        """The light as one kernel row: kind, toward-light direction (unit) or position, rgb."""
        rgb = srgb_to_linear_array(as_color("color", self.color)) * self.intensity
        if self.direction is not None:
            d = -as_vec3("direction", self.direction)
            return np.concatenate([[DIRECTIONAL], d / np.linalg.norm(d), rgb])
        return np.concatenate([[POINT], as_vec3("position", self.position), rgb])


def default_lights(camera: Camera) -> list[Light]:
    """One white key light from above, to the left of and behind the camera."""
    fwd, right, up = camera.basis()
    toward = -fwd * 1.0 - right * 0.7 + up * 0.8
    return [Light(direction=tuple(-toward / np.linalg.norm(toward)))]


def pack_lights(lights: list[Light]) -> np.ndarray:
    """(n, 7) float64 array of the lights for the kernels."""
    if len(lights) == 0:
        return np.zeros((0, 7))
    for i, light in enumerate(lights):
        if not isinstance(light, Light):
            raise ValueError(f"lights[{i}] must be a blobtree Light, got "
                             f"{type(light).__name__[:60]}")
    return np.stack([light.packed() for light in lights])


def srgb_to_linear_array(c: np.ndarray) -> np.ndarray:
    """sRGB-encoded [0, 1] values to linear light (IEC 61966-2-1)."""
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


@kernel
def srgb_to_linear(c):
    """Scalar version of :func:`srgb_to_linear_array`."""
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


@kernel
def linear_to_srgb_byte(c):
    """Linear [0, 1] (clamped) to an 8-bit sRGB value, rounded."""
    c = min(max(c, 0.0), 1.0)
    s = 12.92 * c if c <= 0.0031308 else 1.055 * c ** (1.0 / 2.4) - 0.055
    return np.uint8(int(s * 255.0 + 0.5))


#: Layout of the packed look (``RenderSettings.packed_look``): ambient, specular, shininess,
#: occlusion strength, occlusion radius (scene units), tan of the lights' angular radius, sky.
AMBIENT, SPECULAR, SHININESS, OCCLUSION, OCCLUSION_RADIUS, LIGHT_TAN, SKY = range(7)
#: Field samples along the normal for ambient occlusion.
OCCLUSION_SAMPLES = 4


@kernel(inline="always")
def _field_at(code, params, boxes, local, llo, lhi, x, y, z, vstack, pstack):
    """The field at (x, y, z): on the local program inside its box, on the full one outside."""
    if llo[0] <= x <= lhi[0] and llo[1] <= y <= lhi[1] and llo[2] <= z <= lhi[2]:
        return interp.eval_point(local[0], params, local[1], x, y, z, 0, vstack, pstack)
    return interp.eval_point(code, params, boxes, x, y, z, 0, vstack, pstack)


@kernel(inline="always")
def occlusion(code, params, boxes, local, llo, lhi, px, py, pz, nx, ny, nz, slope, radius,
              vstack, pstack):
    """Ambient occlusion in [0, 1] at surface point p with outward normal n, from the field
    alone: a lone surface falls off along its normal as 0.5 - slope * d (slope = |grad f| at p),
    so whatever the samples at d = radius * k / OCCLUSION_SAMPLES exceed that by is other
    surface nearby (a crease, the inside of the aperture); nearer samples weigh more."""
    occ = 0.0
    total = 0.0
    for k in range(1, OCCLUSION_SAMPLES + 1):
        d = radius * k / OCCLUSION_SAMPLES
        f = _field_at(code, params, boxes, local, llo, lhi, px + d * nx, py + d * ny,
                      pz + d * nz, vstack, pstack)
        weight = 1.0 / k
        occ += weight * min(max(f - max(0.5 - slope * d, 0.0), 0.0) / 0.5, 1.0)
        total += weight
    return occ / total


@kernel(inline="always")
def penumbra(code, params, boxes, x, y, z, t, light_tan, vstack, pstack):
    """How much of an area light of angular radius atan(light_tan) a shadow ray that missed
    still sees, from the point (x, y, z) at distance t where it passed nearest another surface:
    that surface lies about d = (0.5 - f) / |grad f| away (the field's first-order Taylor
    estimate), and the light's disc, t * light_tan wide there, is seen in full once d exceeds
    it (the penumbra of an area light, estimated from one ray)."""
    interp.eval_point(code, params, boxes, x, y, z, 1, vstack, pstack)  # value and gradient
    g = np.sqrt(vstack[0, 1] ** 2 + vstack[0, 2] ** 2 + vstack[0, 3] ** 2)
    if g <= 0.0 or t <= 0.0:
        return 1.0
    return _smoothstep((0.5 - vstack[0, 0]) / (g * t * light_tan))


@kernel(inline="always")
def _smoothstep(x):
    """0 below 0, 1 above 1, the cubic 3x^2 - 2x^3 between."""
    x = min(max(x, 0.0), 1.0)
    return x * x * (3.0 - 2.0 * x)


@kernel
def shade(code, params, boxes, lips, local, llo, lhi, px, py, pz, vx, vy, vz, lights, lo, hi,
          shadows, look, shadow_eps, out, vstack, pstack):
    """Linear RGB at surface point p seen along view direction v (unit, toward the surface),
    written into out[0:3].  ``local = (code, boxes, lips)`` is the program specialised to the box
    [llo, lhi] around p (or the full program and its bounds): it gives the normal and albedo,
    and carries each shadow ray while it stays in that box; the full program takes it on.

    ``look`` (see :data:`AMBIENT` ...): the ambient light, brighter from above by ``SKY`` and
    darkened by the field's :func:`occlusion`; Blinn-Phong lights of angular radius
    atan(``LIGHT_TAN``), whose shadow rays, when they miss, still darken by :func:`penumbra`."""
    interp.eval_point(local[0], params, local[1], px, py, pz, 2, vstack, pstack)
    # The field decreases outward, so the outward normal is -grad f.
    nx, ny, nz = -vstack[0, 1], -vstack[0, 2], -vstack[0, 3]
    nn = np.sqrt(nx * nx + ny * ny + nz * nz)
    if nn > 0.0:
        nx, ny, nz = nx / nn, ny / nn, nz / nn
    else:
        nx, ny, nz = -vx, -vy, -vz
    ar = srgb_to_linear(min(max(vstack[0, 4], 0.0), 1.0))
    ag = srgb_to_linear(min(max(vstack[0, 5], 0.0), 1.0))
    ab = srgb_to_linear(min(max(vstack[0, 6], 0.0), 1.0))
    ambient = look[AMBIENT] * (1.0 - look[SKY] * 0.5 * (1.0 - ny))
    if look[OCCLUSION] > 0.0:
        ambient *= 1.0 - look[OCCLUSION] * occlusion(
            code, params, boxes, local, llo, lhi, px, py, pz, nx, ny, nz, nn,
            look[OCCLUSION_RADIUS], vstack, pstack)
    specular, shininess, light_tan = look[SPECULAR], look[SHININESS], look[LIGHT_TAN]
    r = ambient * ar
    g = ambient * ag
    b = ambient * ab
    for k in range(lights.shape[0]):
        if lights[k, 0] == DIRECTIONAL:
            lx, ly, lz = lights[k, 1], lights[k, 2], lights[k, 3]
            dist = np.inf
        else:
            lx, ly, lz = lights[k, 1] - px, lights[k, 2] - py, lights[k, 3] - pz
            dist = np.sqrt(lx * lx + ly * ly + lz * lz)
            if dist == 0.0:
                continue
            lx, ly, lz = lx / dist, ly / dist, lz / dist
        ndl = nx * lx + ny * ly + nz * lz
        if ndl <= 0.0:
            continue
        lit = 1.0
        if shadows:
            # Start the shadow ray off the surface along the normal, so it cannot re-hit it.
            sx = px + shadow_eps * nx
            sy = py + shadow_eps * ny
            sz = pz + shadow_eps * nz
            t0, t1 = clip_box(sx, sy, sz, lx, ly, lz, lo, hi, 0.0, dist)
            if t0 <= t1:
                ta, tb = clip_box(sx, sy, sz, lx, ly, lz, llo, lhi, t0, t1)
                t_split = tb if ta == t0 and ta <= tb else -np.inf  # starts in the local box?
                t, _, rise, t_peak = trace_from_local(
                    code, params, boxes, lips, local, sx, sy, sz, lx, ly, lz, t0, t_split, t1,
                    0.5 * shadow_eps, 0.0, 0.05 * (tb - t0) + shadow_eps, 0.05, shadow_eps,
                    vstack, pstack)
                if t >= 0.0:
                    continue
                if light_tan > 0.0 and rise > 0.0:
                    lit = penumbra(code, params, boxes, sx + t_peak * lx, sy + t_peak * ly,
                                   sz + t_peak * lz, t_peak, light_tan, vstack, pstack)
        hx, hy, hz = lx - vx, ly - vy, lz - vz
        hn = np.sqrt(hx * hx + hy * hy + hz * hz)
        spec = 0.0
        if hn > 0.0:
            ndh = (nx * hx + ny * hy + nz * hz) / hn
            if ndh > 0.0:
                spec = specular * ndh ** shininess
        r += lit * lights[k, 4] * (ar * ndl + spec)
        g += lit * lights[k, 5] * (ag * ndl + spec)
        b += lit * lights[k, 6] * (ab * ndl + spec)
    out[0] = r
    out[1] = g
    out[2] = b
