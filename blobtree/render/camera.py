"""The pinhole camera, its default three-quarter framing, and argument checks shared by render."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..checks import RGB, Number, Vec3
from ..nodes import Node

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
#: Share of the image's width or height the framed model spans.
FILL = 0.85


def surface_points(prog, n: int = 24) -> np.ndarray:
    """Points inside the surface (f >= 0.5) on an n^3 grid over ``prog.bounds``, with the
    corners of their grid cells, so that they cover the solid; the bounds' corners if the grid
    finds none."""
    lo, hi = (np.asarray(b, dtype=np.float64) for b in prog.bounds)
    axes = [np.linspace(lo[k], hi[k], n) for k in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    inside = grid[prog.field(grid) >= 0.5]
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    if len(inside) == 0:
        return lo + corners * (hi - lo)
    half = 0.5 * (hi - lo) / (n - 1)
    return (inside[:, None, :] + (2.0 * corners - 1.0) * half).reshape(-1, 3)


def framed_camera(prog, width: int, height: int, view: tuple[float, float, float],
                  up: tuple[float, float, float] = (0.0, 1.0, 0.0), fov: float = _DEFAULT_FOV,
                  fill: float = FILL) -> Camera:
    """A camera looking along ``view`` whose image the solid spans to ``fill`` of its width or
    height (whichever binds), centred: measured on the solid's projection in perspective, not
    on its bounding box (whose corners leave a spiky shell small in a wide frame)."""
    return frame_points(surface_points(prog), width / height, view, up, fov, fill)


def frame_points(pts: np.ndarray, aspect: float, view: tuple[float, float, float],
                 up: tuple[float, float, float] = (0.0, 1.0, 0.0), fov: float = _DEFAULT_FOV,
                 fill: float = FILL) -> Camera:
    """:func:`framed_camera` for points (N, 3) and an image of width / height ``aspect``."""
    fwd = as_vec3("view", view)
    fwd = fwd / np.linalg.norm(fwd)
    right = np.cross(fwd, as_vec3("up", up))
    if not np.linalg.norm(right) > 1e-9:
        raise ValueError(f"up must not be parallel to view, got up={up!r}, view={view!r}")
    right /= np.linalg.norm(right)
    upv = np.cross(right, fwd)
    tan_h = math.tan(math.radians(fov) / 2.0)
    tan_w = tan_h * aspect
    target = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
    extent = max(np.abs((pts - target) @ right).max() / tan_w,
                 np.abs((pts - target) @ upv).max() / tan_h)
    depth = np.abs((pts - target) @ fwd).max()
    distance = extent / fill + depth
    for _ in range(8):  # perspective: re-centre and re-scale on the projected extent
        rel = pts - (target - distance * fwd)
        z = rel @ fwd
        sx, sy = (rel @ right) / (z * tan_w), (rel @ upv) / (z * tan_h)
        cx, cy = 0.5 * (sx.min() + sx.max()), 0.5 * (sy.min() + sy.max())
        span = max(sx.max() - sx.min(), sy.max() - sy.min()) / 2.0
        target = target + distance * (cx * tan_w * right + cy * tan_h * upv)
        distance = max(distance * span / fill, depth * 1.05 + 1e-12)
    return Camera(eye=tuple(target - distance * fwd), target=tuple(target), up=tuple(upv),
                  fov=fov)


def default_camera(prog, width: int, height: int, up: tuple[float, float, float] = (0, 1, 0)
                   ) -> Camera:
    """A three-quarter view from above (``up`` is up in the image) framing the solid to
    :data:`FILL` of the image."""
    up = as_vec3("up", up) / np.linalg.norm(as_vec3("up", up))
    az, el = math.radians(_AZIMUTH), math.radians(_ELEVATION)
    # azimuth around ``up`` from a side direction, elevation toward ``up``
    side = np.cross([1.0, 0.0, 0.0] if abs(up[0]) < 0.9 else [0.0, 1.0, 0.0], up)
    side /= np.linalg.norm(side)
    other = np.cross(up, side)
    toward_eye = (math.cos(el) * (math.cos(az) * side + math.sin(az) * other)
                  + math.sin(el) * up)
    return framed_camera(prog, width, height, view=tuple(-toward_eye), up=tuple(up))


def seen_camera(tree, prog, width: int, height: int) -> Camera:
    """The camera a tree is best seen from: framed along the view :meth:`Node.shown` gave it (a
    shell: apex up, facing its aperture), else :func:`default_camera`; ``tree`` may also be a
    program, which carries no view."""
    up, view = tree.display if isinstance(tree, Node) else ((0.0, 1.0, 0.0), None)
    return (default_camera(prog, width, height, up=up) if view is None
            else framed_camera(prog, width, height, view=view, up=up))
