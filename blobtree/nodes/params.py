"""Parameter kinds of node specs: validation, scene-file form and sampling ranges, in one place.

A node type declares its parameters as :class:`Param` (name, kind, default).  Each kind checks a
value (``ValueError`` naming the parameter, the value and what is allowed), converts it to and
from its scene-file form, and carries the range tests and generators sample it from
(``sample``), so validation, ``params()``, the scene schema and the test strategies all derive
from the same declaration.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import texture as tex

#: Marks a parameter without a default.
REQUIRED: Any = object()

# ----- the documented limits (docs/limits.md) -------------------------------------------------
#: Coordinates (centres, axis ends, offsets): |x| at most this, in scene units.
MAX_COORD = 1e6
#: Radii, lengths, scale factors: within [MIN_SIZE, MAX_SIZE] (magnitude, for scale factors).
MIN_SIZE, MAX_SIZE = 1e-6, 1e6
#: Angles and angle rates, in degrees: |a| at most this.
MAX_ANGLE = 1e6


def _short(value: Any) -> str:
    """repr of a value, cut to a readable length."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _is_number(v: Any) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, bool | np.bool_)


def frozen(a: np.ndarray) -> np.ndarray:
    """A read-only copy of an array (nodes are immutable)."""
    a = np.array(a)
    a.setflags(write=False)
    return a


class Kind:
    """How one parameter is checked and stored; subclasses fill in the rules."""

    #: What the scene schema and error messages call it.
    schema = "value"

    def check(self, name: str, value: Any) -> Any:
        """The value as the node keeps it, or ValueError naming ``name``."""
        raise NotImplementedError

    def to_json(self, value: Any, images: dict[str, np.ndarray]) -> Any:
        """The JSON form (texture images go into ``images`` under their digest)."""
        return value

    def from_json(self, name: str, value: Any, images: dict[str, np.ndarray]) -> Any:
        """The constructor argument for a JSON value (then checked by :meth:`check`)."""
        return value

    def key(self, value: Any) -> str:
        """An exact text form for structural identity (see ``Node.key``)."""
        return repr(self.to_json(value, {}))


@dataclass(frozen=True)
class Number(Kind):
    """A finite real number within [lo, hi] (ends open where ``lo_open`` / ``hi_open``)."""

    lo: float = -math.inf
    hi: float = math.inf
    lo_open: bool = False
    hi_open: bool = False
    sample: tuple[float, float] = (-1.0, 1.0)
    schema = "number"

    def allowed(self) -> str:
        parts = []
        if self.lo > -math.inf:
            parts.append(f"{'>' if self.lo_open else '>='} {self.lo:g}")
        if self.hi < math.inf:
            parts.append(f"{'<' if self.hi_open else '<='} {self.hi:g}")
        return "a finite number" + (" " + " and ".join(parts) if parts else "")

    def check(self, name: str, value: Any) -> float:
        try:
            v = float(value) if _is_number(value) else math.nan
        except OverflowError:
            v = math.inf
        ok = math.isfinite(v) and (v > self.lo if self.lo_open else v >= self.lo) \
            and (v < self.hi if self.hi_open else v <= self.hi)
        if not ok:
            raise ValueError(f"{name} must be {self.allowed()}, got {_short(value)}")
        return v

    def key(self, value: float) -> str:
        return float(value).hex()


@dataclass(frozen=True)
class Integer(Kind):
    """A whole number within [lo, hi] (not a bool, not a float)."""

    lo: int = 0
    hi: int = 2**63 - 1
    schema = "integer"

    def check(self, name: str, value: Any) -> int:
        if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Integral) \
                or not self.lo <= value <= self.hi:
            raise ValueError(f"{name} must be an integer in [{self.lo}, {self.hi}], got "
                             f"{_short(value)}")
        return int(value)


def positive(sample: tuple[float, float] = (0.3, 1.2)) -> Number:
    """A size: a number in [MIN_SIZE, MAX_SIZE]."""
    return Number(lo=MIN_SIZE, hi=MAX_SIZE, sample=sample)


def angle(sample: tuple[float, float] = (-180.0, 180.0)) -> Number:
    """An angle (or an angle per unit length) in degrees, |a| <= MAX_ANGLE."""
    return Number(lo=-MAX_ANGLE, hi=MAX_ANGLE, sample=sample)


@dataclass(frozen=True)
class Vec3(Kind):
    """A 3-vector of finite numbers, each of magnitude within [least, limit], kept as a
    read-only float array."""

    sample: tuple[float, float] = (-1.0, 1.0)
    limit: float = MAX_COORD
    least: float = 0.0
    schema = "3-vector"

    def allowed(self) -> str:
        rule = f"|x| <= {self.limit:g}" if not self.least else \
            f"{self.least:g} <= |x| <= {self.limit:g}"
        return f"three finite numbers with {rule}"

    def check(self, name: str, value: Any) -> np.ndarray:
        items = None
        if not isinstance(value, str) and _is_vector(value):
            try:
                items = np.array([float(v) for v in value])
            except OverflowError:
                items = None
        if items is None or not np.all(np.isfinite(items)) or np.any(np.abs(items) > self.limit) \
                or np.any(np.abs(items) < self.least):
            raise ValueError(f"{name} must be {self.allowed()}, got {_short(value)}")
        return frozen(items)

    def to_json(self, value, images):
        return [float(v) for v in value]

    def key(self, value) -> str:
        return ",".join(float(v).hex() for v in value)


def _is_vector(value: Any) -> bool:
    try:
        items = list(value)
    except TypeError:
        return False
    return len(items) == 3 and all(_is_number(v) for v in items)


@dataclass(frozen=True)
class RGB(Vec3):
    """A colour: three numbers in [0, 1]."""

    sample: tuple[float, float] = (0.0, 1.0)
    schema = "rgb (3 numbers in [0, 1])"

    def check(self, name: str, value: Any) -> np.ndarray:
        v = super().check(name, value)
        if np.any(v < 0.0) or np.any(v > 1.0):
            raise ValueError(f"{name} components must lie in [0, 1], got {_short(value)}")
        return v


@dataclass(frozen=True)
class Choice(Kind):
    """One of a fixed set of strings."""

    options: tuple[str, ...] = ()
    schema = "string"

    def check(self, name: str, value: Any) -> str:
        if not isinstance(value, str) or value not in self.options:
            raise ValueError(f"{name} must be one of {list(self.options)}, got {_short(value)}")
        return value


AXES = Choice(("x", "y", "z"))


@dataclass(frozen=True)
class Axis(Kind):
    """A rotation axis: "x", "y", "z" or a non-zero 3-vector."""

    schema = "axis ('x', 'y', 'z' or a 3-vector)"

    def check(self, name: str, value: Any) -> str | tuple[float, float, float]:
        if isinstance(value, str):
            return AXES.check(name, value)
        v = Vec3().check(name, value) if _is_vector(value) else None
        if v is None or not np.any(v != 0.0):
            raise ValueError(f"{name} must be 'x', 'y', 'z' or a non-zero 3-vector, got "
                             f"{_short(value)}")
        return tuple(float(x) for x in v)

    def to_json(self, value, images):
        return value if isinstance(value, str) else list(value)


@dataclass(frozen=True)
class Pairs(Kind):
    """Pairs of child indices (the controlled blend's b_i of Eq. 6)."""

    schema = "list of index pairs"

    def check(self, name: str, value: Any) -> tuple[tuple[int, int], ...]:
        if isinstance(value, str | bytes):
            raise ValueError(f"{name} must be a list of index pairs, got {_short(value)}")
        try:
            items = list(value)
        except TypeError:
            raise ValueError(f"{name} must be a list of index pairs, got {_short(value)}") \
                from None
        out = []
        for k, pair in enumerate(items):
            try:
                ok = not isinstance(pair, str) and len(pair) == 2 and all(
                    isinstance(v, numbers.Integral) and not isinstance(v, bool | np.bool_)
                    for v in pair)
            except TypeError:
                ok = False
            if not ok:
                raise ValueError(f"{name}[{k}] must be two child indices, got {_short(pair)}")
            out.append((int(pair[0]), int(pair[1])))
        return tuple(out)

    def to_json(self, value, images):
        return [list(p) for p in value]


@dataclass(frozen=True)
class Image(Kind):
    """A texture image: an (H, W, 3) uint8 array (from a path, an array or a function of
    (u, v), see :func:`blobtree.texture.load_image`); scene files store each image once."""

    schema = "image (a key of $.images)"

    def check(self, name: str, value: Any) -> np.ndarray:
        if isinstance(value, np.ndarray) and value.dtype == np.uint8 and value.ndim == 3 \
                and value.shape[2] == 3 and not value.flags.writeable:
            return value
        return frozen(tex.load_image(value))

    def to_json(self, value, images):
        key = tex.image_digest(value)
        images[key] = value
        return key

    def from_json(self, name, value, images):
        if not isinstance(value, str) or value not in images:
            raise ValueError(f"{name}: {_short(value)} is not in $.images")
        return images[value]

    def key(self, value) -> str:
        return tex.image_digest(value)


@dataclass(frozen=True)
class Mapping(Kind):
    """A texture mapping: "primitive" (field-interpolated) or a
    :class:`blobtree.texture.HelicoSurface` (bounding surface)."""

    schema = "mapping ('primitive' or {\"helico\": {...}})"

    def check(self, name: str, value: Any):
        return tex.parse_mapping(value)

    def to_json(self, value, images):
        return value if value == "primitive" else {"helico": value.to_dict()}

    def from_json(self, name, value, images):
        if value == "primitive":
            return value
        if isinstance(value, dict) and list(value) == ["helico"] and isinstance(
                value["helico"], dict):
            return tex.HelicoSurface.from_dict(value["helico"])
        raise ValueError(f"{name}: expected {self.schema}, got {_short(value)}")


@dataclass(frozen=True)
class Param:
    """One declared parameter of a node type."""

    name: str
    kind: Kind
    default: Any = REQUIRED
    doc: str = field(default="", compare=False)
