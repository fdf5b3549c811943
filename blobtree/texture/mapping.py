"""2D texture mapping of BlobTrees (paper Section 3.4): images and the two mapping methods.

* **Field-interpolated texturing** (Tigges & Wyvill, CGI 99; the paper's ref. [10]): every
  primitive has its own (u, v) — point: spherical angles; segment and cone: angle around and
  distance along the axis; torus: both angles; disc: angle and radius; cylinder: angle and height
  — and a primitive below a texture node takes its colour from the texture at its own (u, v).
  Blends then mix the colours weighted by the children's fields, as for every colour, so
  textured parts blend automatically where they join.  Colours (never raw angles) are mixed, so
  the wrap-around of an angle shows no seam with a texture that repeats across u.
* **Bounding-surface texturing** (Tigges & Wyvill, Implicit Surfaces 98; ref. [9]): the texture
  lives on a bounding parametric surface S with a known (u, v).  A point of the implicit surface
  moves along a combination of the field gradient (taken at the point) and the normal of S until
  it reaches S, and takes the (u, v) found there.  For the shell, S is a tube around the
  helico-spiral (:class:`HelicoSurface`): u runs along the spiral (one texture copy per
  ``u_period`` degrees, a section of the paper), v around the tube in the generating plane.

Images are kept as 8-bit RGB (so scene files round-trip them exactly) and sampled bilinearly with
"repeat" or "clamp" wrapping.  A function of (u, v) is sampled once onto a grid.
"""

from __future__ import annotations

import base64
import hashlib
import io
import math
import os
import weakref
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from ..checks import Integer, Number, positive, short_repr
from ..helico import HelicoSpiral

__all__ = ["HelicoSurface", "image_from_text", "image_to_text", "load_image", "parse_mapping",
           "perpendicular_frame", "sample", "turn"]

#: A field gradient shorter than this gives the bounding-surface search no direction: where the
#: field is flat (inside a cylinder's core, f = 1) rounding leaves gradients of ~1e-16 whose
#: direction is noise, and the reference and the engine would follow different noise.
MIN_GRADIENT = 1e-9
#: Largest theta_max of a bounding surface, in degrees (100 turns: the nearest-whorl search
#: looks at theta_max / 360 + 2 whorls per step).
MAX_THETA = 36000.0
#: Grid on which a texture given as a function of (u, v) is sampled.
FUNCTION_SIZE = 256
WRAPS = {"repeat": 0, "clamp": 1}
MAX_SIDE = 4096

TextureSource = (str | os.PathLike | io.BytesIO | np.ndarray
                 | Callable[[np.ndarray, np.ndarray], Any])


def load_image(source: TextureSource) -> np.ndarray:
    """An (H, W, 3) uint8 image from a PNG/JPEG path, an array, or a function of (u, v)."""
    if callable(source):
        n = FUNCTION_SIZE
        u, v = np.meshgrid((np.arange(n) + 0.5) / n, (np.arange(n) + 0.5) / n)
        rgb = np.asarray(source(u, v), dtype=float)
        if rgb.shape != (n, n, 3):
            raise ValueError(f"a texture function must map (u, v) arrays of shape ({n}, {n}) "
                             f"to colours of shape ({n}, {n}, 3), got {rgb.shape}")
        arr = rgb
    elif isinstance(source, str | os.PathLike) or hasattr(source, "read"):
        from PIL import Image, UnidentifiedImageError

        try:
            with Image.open(source) as im:
                if max(im.size) > MAX_SIDE or min(im.size) < 1:  # checked before decoding
                    raise ValueError(f"image must have sides in [1, {MAX_SIDE}] pixels, got "
                                     f"{im.size[0]}x{im.size[1]}")
                arr = np.asarray(im.convert("RGB"))
        except Image.DecompressionBombError:
            raise ValueError(f"image must have sides in [1, {MAX_SIDE}] pixels; this one claims "
                             "far more") from None
        except (FileNotFoundError, UnidentifiedImageError, OSError) as e:
            name = source if isinstance(source, str | os.PathLike) else "the image data"
            raise ValueError(f"image: cannot read {str(name)[:80]}: {e}") from None
    else:
        arr = np.asarray(source)
    if arr.ndim == 2:
        arr = np.repeat(arr[:, :, None], 3, axis=2)
    if arr.ndim != 3 or arr.shape[2] not in (3, 4) or min(arr.shape[:2]) < 1 \
            or max(arr.shape[:2]) > MAX_SIDE:
        raise ValueError(f"image must be (H, W), (H, W, 3) or (H, W, 4) with sides in "
                         f"[1, {MAX_SIDE}], got shape {arr.shape}")
    arr = arr[:, :, :3]
    if arr.dtype == np.uint8:
        return np.ascontiguousarray(arr)
    arr = arr.astype(float)
    if not np.all(np.isfinite(arr)) or arr.min() < 0.0 or arr.max() > 1.0:
        raise ValueError("image values must be finite and lie in [0, 1] (or be uint8)")
    return np.round(arr * 255.0).astype(np.uint8)


#: Digests of read-only images that own their pixels, by array (the nodes sharing one image,
#: e.g. a grown pattern kept between builds, hash it once).
_DIGESTS: dict[int, tuple[weakref.ref, str]] = {}


def image_digest(image: np.ndarray) -> str:
    """A content key for an image: equal images share one copy in programs and scene files."""
    fixed = not image.flags.writeable and image.flags.owndata
    if fixed:
        known = _DIGESTS.get(id(image))
        if known is not None and known[0]() is image:
            return known[1]
    h = hashlib.sha256(np.ascontiguousarray(image).tobytes())
    h.update(str(image.shape).encode())
    digest = "sha256:" + h.hexdigest()[:32]
    if fixed:
        key = id(image)
        _DIGESTS[key] = (weakref.ref(image, lambda _, key=key: _DIGESTS.pop(key, None)), digest)
    return digest


def image_to_text(image: np.ndarray) -> str:
    """An image as base64 PNG (exact for 8-bit RGB)."""
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(image, "RGB").save(buf, format="PNG")
    return base64.b64encode(buf.getvalue()).decode("ascii")


def image_from_text(text: str) -> np.ndarray:
    """Inverse of :func:`image_to_text`."""
    try:
        data = base64.b64decode(text.encode("ascii"), validate=True)
    except (ValueError, UnicodeEncodeError):
        raise ValueError("image: not base64 text") from None
    return load_image(io.BytesIO(data))


def sample(image: np.ndarray, u: np.ndarray, v: np.ndarray, wrap: str) -> np.ndarray:
    """Bilinear colours (N, 3) in [0, 1] at (u, v); texel centres at ((i + .5)/W, (j + .5)/H),
    v = 0 at the first row."""
    h, w = image.shape[:2]
    img = image.astype(float) / 255.0
    x = np.asarray(u, dtype=float) * w - 0.5
    y = np.asarray(v, dtype=float) * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    x0, y0 = x0.astype(np.int64), y0.astype(np.int64)

    def idx(i, n):
        return np.mod(i, n) if wrap == "repeat" else np.clip(i, 0, n - 1)

    xa, xb, ya, yb = idx(x0, w), idx(x0 + 1, w), idx(y0, h), idx(y0 + 1, h)
    top = img[ya, xa] * (1 - fx) + img[ya, xb] * fx
    bottom = img[yb, xa] * (1 - fx) + img[yb, xb] * fx
    return top * (1 - fy) + bottom * fy


def perpendicular_frame(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors e1, e2 with (e1, e2, axis) right-handed, for angles around an axis."""
    a = axis / np.linalg.norm(axis)
    ref = np.array([0.0, 1.0, 0.0]) if abs(a[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(ref, a)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(a, e1)


def turn(y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """atan2(y, x) as a fraction of a turn in [0, 1)."""
    return np.mod(np.arctan2(y, x) / (2.0 * math.pi), 1.0)


#: What each number of a bounding-surface mapping may be.
_SURFACE_KINDS = {"u_period": positive(), "u_start": Number(-1e6, 1e6),
                  "radius_factor": Number(1e-3, 1e3), "theta_max": Number(1e-6, MAX_THETA),
                  "step": Number(1e-6, 1e3), "gradient_weight": Number(0.0, 1.0),
                  "max_steps": Integer(0, 10_000)}


@dataclass(frozen=True)
class HelicoSurface:
    """A bounding surface for :class:`~blobtree.Texture`: a tube of radius ``radius_factor *
    D(theta)`` around a helico-spiral (Eqs. 1-3), for the shell's body whorl (Section 3.4).

    u = (theta - u_start) / u_period (one texture copy per section: 116 degrees in the paper,
    starting at a join between sections, so the texture's seams fall under the varices), v =
    angle around the tube in the generating plane.
    A point moves by steps of ``step * D`` along (gradient_weight * outward field gradient +
    (1 - gradient_weight) * normal of S) until it reaches S.
    """

    spiral: HelicoSpiral = HelicoSpiral(d_ratio=0.341)
    u_period: float = 116.0
    u_start: float = 0.0
    radius_factor: float = 1.5
    gradient_weight: float = 0.5
    theta_max: float = 2520.0
    step: float = 0.05
    max_steps: int = 64

    def __post_init__(self) -> None:
        if not isinstance(self.spiral, HelicoSpiral):
            raise ValueError(f"spiral must be a HelicoSpiral, got {type(self.spiral).__name__}")
        for name, kind in _SURFACE_KINDS.items():
            object.__setattr__(self, name, kind.check(name, getattr(self, name)))

    def to_dict(self) -> dict[str, Any]:
        """Its parameters as JSON-ready values (scene files)."""
        d = asdict(self)
        d["spiral"] = asdict(self.spiral)
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> HelicoSurface:
        """From :meth:`to_dict`'s form; ValueError naming what is missing or unknown."""
        d = dict(d)
        fields = set(cls.__dataclass_fields__)
        if set(d) != fields:
            raise ValueError(f"a helico mapping needs exactly the fields {sorted(fields)}, got "
                             f"{short_repr(sorted(d))}")
        spiral = d["spiral"]
        sfields = set(HelicoSpiral.__dataclass_fields__)
        if not isinstance(spiral, dict) or set(spiral) != sfields:
            raise ValueError(f"spiral must be an object with exactly the fields {sorted(sfields)},"
                             f" got {short_repr(spiral)}")
        d["spiral"] = HelicoSpiral(**spiral)
        return cls(**d)

    # ----- reference maths (numpy) ------------------------------------------------------------
    def locate(self, q: np.ndarray) -> tuple[np.ndarray, ...]:
        """Nearest whorl (distance relative to the whorl's size D, so the tubes of consecutive
        whorls meet where their circles touch): theta (deg), the in-plane offset (dr, dy),
        the outward radial unit vector of the point's generating plane, and D(theta)."""
        sp = self.spiral
        rho = np.hypot(q[:, 0], q[:, 2])
        phi = np.degrees(np.mod(np.arctan2(-q[:, 2], q[:, 0]), 2 * math.pi))
        cot = 1.0 / math.tan(math.radians(sp.beta))
        best_t = np.zeros(len(q))
        best_d = np.full(len(q), np.inf)
        for k in range(int(self.theta_max // 360.0) + 2):
            t = phi + 360.0 * k
            r = sp.r0 * sp.rho ** (t / 360.0)
            d = ((rho - r) ** 2 + (q[:, 1] - r * cot) ** 2) / (r * r)  # distance in units of D
            better = d < best_d
            best_t = np.where(better, t, best_t)
            best_d = np.where(better, d, best_d)
        r = sp.r0 * sp.rho ** (best_t / 360.0)
        dr, dy = rho - r, q[:, 1] - r * cot
        safe = np.where(rho > 0.0, rho, 1.0)
        radial = np.stack([q[:, 0] / safe, np.zeros(len(q)), q[:, 2] / safe], axis=1)
        return best_t, dr, dy, radial, sp.d_over_r * r

    def uv(self, q: np.ndarray, grad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(u, v) for points q with field gradients grad (both in the surface's frame)."""
        q = q.copy()
        gn = np.linalg.norm(grad, axis=1, keepdims=True)
        out = np.where(gn > MIN_GRADIENT, -grad / np.where(gn > 0.0, gn, 1.0), 0.0)  # falls out
        for _ in range(self.max_steps):
            theta, dr, dy, radial, d = self.locate(q)
            dist = np.hypot(dr, dy)
            moving = dist < self.radius_factor * d
            if not moving.any():
                break
            safe = np.where(dist > 0.0, dist, 1.0)
            normal = (dr / safe)[:, None] * radial + (dy / safe)[:, None] * np.array([0, 1, 0])
            step = self.gradient_weight * out + (1.0 - self.gradient_weight) * normal
            sn = np.linalg.norm(step, axis=1, keepdims=True)
            step = step / np.where(sn > 0.0, sn, 1.0)
            q = q + np.where(moving[:, None], self.step * d[:, None] * step, 0.0)
        theta, dr, dy, _, _ = self.locate(q)
        return (theta - self.u_start) / self.u_period, turn(dy, dr)


def parse_mapping(mapping: Any) -> str | HelicoSurface:
    """"primitive" (field-interpolated) or a :class:`HelicoSurface` (bounding surface)."""
    if mapping == "primitive" or isinstance(mapping, HelicoSurface):
        return mapping
    raise ValueError(f"mapping must be 'primitive' or a HelicoSurface, got {mapping!r}")
