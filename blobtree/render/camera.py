"""The pinhole camera, its default three-quarter framing, and argument checks shared by render."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..checks import RGB, Number, Vec3

#: Camera and light positions may lie this far from the origin.
MAX_POSITION = 1e9
_POSITION = Vec3(limit=MAX_POSITION)
_FOV = Number(lo=0.0, hi=180.0, lo_open=True, hi_open=True)


def as_vec3(name: str, value) -> np.ndarray:
    """``value`` as a finite float64 3-vector, or ValueError naming ``name``."""
    return np.array(_POSITION.check(name, value))


def as_color(name: str, value) -> np.ndarray:
    """``value`` as an RGB triple in [0, 1], or ValueError naming ``name``."""
    return np.array(RGB().check(name, value))


@dataclass(frozen=True)
class Camera:
    """A pinhole camera at ``eye`` looking at ``target``; ``fov`` is the vertical field of view
    in degrees, in (0, 180)."""

    eye: tuple[float, float, float]
    target: tuple[float, float, float] = (0.0, 0.0, 0.0)
    up: tuple[float, float, float] = (0.0, 1.0, 0.0)
    fov: float = 40.0

    def __post_init__(self) -> None:
        eye = as_vec3("eye", self.eye)
        target = as_vec3("target", self.target)
        up = as_vec3("up", self.up)
        fov = _FOV.check("fov", self.fov)
        if np.linalg.norm(target - eye) <= 1e-9 * max(np.abs(eye).max(), np.abs(target).max(),
                                                      1.0):
            raise ValueError(f"eye must differ from target, got eye={tuple(eye.tolist())}, "
                             f"target={tuple(target.tolist())}")
        fwd = (target - eye) / np.linalg.norm(target - eye)
        if np.linalg.norm(np.cross(fwd, up)) < 1e-9 * max(np.linalg.norm(up), 1e-300):
            raise ValueError(f"up must not be parallel to the view direction, got up="
                             f"{tuple(up.tolist())}")
        # Store plain float tuples so the camera hashes, pickles and prints cleanly.
        object.__setattr__(self, "eye", tuple(float(x) for x in eye))
        object.__setattr__(self, "target", tuple(float(x) for x in target))
        object.__setattr__(self, "up", tuple(float(x) for x in up))
        object.__setattr__(self, "fov", fov)

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Unit (forward, right, up) vectors of the image plane."""
        eye, target = np.array(self.eye), np.array(self.target)
        fwd = (target - eye) / np.linalg.norm(target - eye)
        right = np.cross(fwd, np.array(self.up))
        right /= np.linalg.norm(right)
        return fwd, right, np.cross(right, fwd)

    def packed(self, width: int, height: int) -> np.ndarray:
        """Kernel layout: eye, forward, right and up scaled to the image-plane half extents."""
        fwd, right, up = self.basis()
        half_h = math.tan(math.radians(self.fov) / 2.0)
        half_w = half_h * width / height
        return np.concatenate([self.eye, fwd, right * half_w, up * half_h])


#: Direction from the target to the eye of the default view: 35 deg around y, 25 deg up.
_AZIMUTH, _ELEVATION, _DEFAULT_FOV = 35.0, 25.0, 35.0


def surface_sphere(prog, n: int = 40) -> tuple[np.ndarray, float]:
    """A sphere (centre, radius) around the visible surface (f >= 0.5), found on an n^3 grid over
    ``prog.bounds`` (the support boxes are up to twice the surface); the bounds' own sphere if the
    grid finds no inside point."""
    lo, hi = (np.asarray(b, dtype=np.float64) for b in prog.bounds)
    axes = [np.linspace(lo[k], hi[k], n) for k in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    inside = grid[prog.field(grid) >= 0.5]
    if len(inside) == 0:
        return (lo + hi) / 2.0, float(np.linalg.norm(hi - lo)) / 2.0
    cell = float(np.linalg.norm((hi - lo) / (n - 1)))
    a, b = inside.min(axis=0), inside.max(axis=0)
    centre = (a + b) / 2.0
    return centre, float(np.sqrt(((inside - centre) ** 2).sum(axis=1).max())) + cell


def default_camera(prog, width: int, height: int) -> Camera:
    """A three-quarter view from above that fits the whole surface into the image."""
    centre, radius = surface_sphere(prog)
    az, el = math.radians(_AZIMUTH), math.radians(_ELEVATION)
    view = np.array([math.sin(az) * math.cos(el), math.sin(el), math.cos(az) * math.cos(el)])
    half_v = math.radians(_DEFAULT_FOV) / 2.0
    half = min(half_v, math.atan(math.tan(half_v) * width / height))
    distance = 1.05 * max(radius, 1e-12) / math.sin(half)
    return Camera(eye=tuple(centre + distance * view), target=tuple(centre), fov=_DEFAULT_FOV)
