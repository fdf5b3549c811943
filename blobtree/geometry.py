"""Small geometric helpers shared by the nodes and the compiler: axes, affine maps, boxes."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .checks import Vec3, angle

AXES = {"x": 0, "y": 1, "z": 2}

#: An axis-aligned box as (lo, hi), each a (3,) float array; empty when any lo > hi.
Box = tuple[np.ndarray, np.ndarray]


def axis_vector(axis: str | Sequence[float], name: str = "axis") -> np.ndarray:
    """Unit vector for "x", "y", "z" or any non-zero finite 3-vector (ValueError naming
    ``name`` otherwise)."""
    if isinstance(axis, str):
        if axis not in AXES:
            raise ValueError(f"{name} must be 'x', 'y', 'z' or a 3-vector, got {axis!r}")
        v = np.zeros(3)
        v[AXES[axis]] = 1.0
        return v
    v = Vec3().check(name, axis)
    n = np.linalg.norm(v)
    if n == 0.0:
        raise ValueError(f"{name} must be a non-zero vector, got (0, 0, 0)")
    return v / n


_DEGREES = angle()
_EYE = np.eye(3)
_EYE.setflags(write=False)


def _cross_matrix(axis: str | Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """K, the cross-product matrix of the unit axis (K x = u x x), and K @ K."""
    u = axis_vector(axis)
    k = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    return k, k @ k


#: :func:`_cross_matrix` of "x", "y" and "z" (most rotations are about one of them).
_CROSS = {a: _cross_matrix(a) for a in AXES}
for _k in _CROSS.values():
    for _m in _k:
        _m.setflags(write=False)


def rotation_matrix(axis: str | Sequence[float], degrees: float) -> np.ndarray:
    """3x3 rotation by ``degrees`` about ``axis`` (right-hand rule), Rodrigues' formula."""
    k, kk = _CROSS[axis] if isinstance(axis, str) and axis in _CROSS else _cross_matrix(axis)
    t = math.radians(_DEGREES.check("degrees", degrees))
    return _EYE + math.sin(t) * k + (1.0 - math.cos(t)) * kk


def rotation_onto(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The 3x3 rotation taking the unit vector ``a`` onto the unit vector ``b`` by the smallest
    angle (about a x b; half a turn about an axis across ``a`` when they are opposite)."""
    c = float(a @ b)
    if c < -1.0 + 1e-12:
        across = np.cross(a, np.eye(3)[np.argmin(np.abs(a))])
        across /= np.linalg.norm(across)
        return 2.0 * np.outer(across, across) - np.eye(3)
    v = np.cross(a, b)
    k = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + k + k @ k / (1.0 + c)


def affine(linear: np.ndarray, offset: np.ndarray | None = None) -> np.ndarray:
    """A 3x4 affine map [A | b] (x -> A x + b)."""
    m = np.zeros((3, 4))
    m[:, :3] = linear
    if offset is not None:
        m[:, 3] = offset
    return m


IDENTITY = affine(np.eye(3))


def compose(outer: np.ndarray, inner: np.ndarray) -> np.ndarray:
    """The affine map x -> outer(inner(x)): [A_o A_i | A_o b_i + b_o] (one product of
    A_o with [A_i | b_i], then b_o added: half the time of two)."""
    m = outer[:, :3] @ inner
    m[:, 3] += outer[:, 3]
    return m


def invert(m: np.ndarray) -> np.ndarray:
    """Inverse of a 3x4 affine map."""
    a = np.linalg.inv(m[:, :3])
    return affine(a, -a @ m[:, 3])


def apply(m: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Apply a 3x4 affine map to (N, 3) points."""
    return p @ m[:, :3].T + m[:, 3]


def empty_box() -> Box:
    return np.full(3, np.inf), np.full(3, -np.inf)


def is_empty(box: Box) -> bool:
    lo, hi = box
    return bool(lo[0] > hi[0] or lo[1] > hi[1] or lo[2] > hi[2])


def box_union(boxes: Sequence[Box]) -> Box:
    lo, hi = empty_box()
    for b in boxes:
        lo = np.minimum(lo, b[0])
        hi = np.maximum(hi, b[1])
    return lo, hi


def box_intersection(boxes: Sequence[Box]) -> Box:
    lo, hi = np.full(3, -np.inf), np.full(3, np.inf)
    for b in boxes:
        lo = np.maximum(lo, b[0])
        hi = np.minimum(hi, b[1])
    return lo, hi


def transform_box(m: np.ndarray, box: Box) -> Box:
    """AABB of the image of a box under the affine map m."""
    if is_empty(box):
        return box
    c = 0.5 * (box[0] + box[1])
    h = 0.5 * (box[1] - box[0])
    center = m[:, :3] @ c + m[:, 3]
    half = np.abs(m[:, :3]) @ h
    return center - half, center + half


def ellipsoid_half(m: np.ndarray, radius: float) -> np.ndarray:
    """Half-extents of the image of a ball of ``radius`` under the linear part of m (exact)."""
    return radius * np.sqrt((m[:, :3] ** 2).sum(axis=1))


def spectral_norm(a: np.ndarray) -> float:
    """Largest singular value of a 3x3 matrix."""
    return float(np.linalg.svd(a, compute_uv=False)[0])
