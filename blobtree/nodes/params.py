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

from .. import geometry as geo
from .. import texture as tex

#: Marks a parameter without a default.
REQUIRED: Any = object()


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


def positive(sample: tuple[float, float] = (0.3, 1.2)) -> Number:
    """A finite number > 0."""
    return Number(lo=0.0, lo_open=True, sample=sample)


@dataclass(frozen=True)
class Vec3(Kind):
    """A finite 3-vector, kept as a read-only float array."""

    sample: tuple[float, float] = (-1.0, 1.0)
    schema = "3-vector"

    def check(self, name: str, value: Any) -> np.ndarray:
        if isinstance(value, str) or not _is_vector(value):
            raise ValueError(f"{name} must be a 3-vector of finite numbers, got {_short(value)}")
        try:
            items = [float(v) for v in value]
        except OverflowError:
            items = [math.inf]
        return frozen(geo.check_vec3(name, items))

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
            raise ValueError(f"{name} components must lie in [0, 1], got {tuple(v.tolist())}")
        return v


@dataclass(frozen=True)
class Choice(Kind):
    """One of a fixed set of strings."""

    options: tuple[str, ...] = ()
    schema = "string"

    def check(self, name: str, value: Any) -> str:
        if not isinstance(value, str) or value not in self.options:
            raise ValueError(f"{name} must be one of {list(self.options)}, got {value!r}")
        return value


AXES = Choice(("x", "y", "z"))


@dataclass(frozen=True)
class Axis(Kind):
    """A rotation axis: "x", "y", "z" or a non-zero 3-vector."""

    schema = "axis ('x', 'y', 'z' or a 3-vector)"

    def check(self, name: str, value: Any) -> str | tuple[float, float, float]:
        if isinstance(value, str):
            return AXES.check(name, value)
        if not _is_vector(value):
            raise ValueError(f"{name} must be 'x', 'y', 'z' or a 3-vector, got {value!r}")
        v = geo.check_vec3(name, [float(x) for x in value])
        if not np.any(v != 0.0):
            raise ValueError(f"{name} must be a non-zero vector, got (0, 0, 0)")
        return tuple(float(x) for x in v)

    def to_json(self, value, images):
        return value if isinstance(value, str) else list(value)


@dataclass(frozen=True)
class Pairs(Kind):
    """Pairs of child indices (the controlled blend's b_i of Eq. 6)."""

    schema = "list of index pairs"

    def check(self, name: str, value: Any) -> tuple[tuple[int, int], ...]:
        if isinstance(value, str | bytes):
            raise ValueError(f"{name} must be a list of index pairs, got {value!r}")
        try:
            items = list(value)
        except TypeError:
            raise ValueError(f"{name} must be a list of index pairs, got {value!r}") from None
        out = []
        for k, pair in enumerate(items):
            try:
                ok = not isinstance(pair, str) and len(pair) == 2 and all(
                    isinstance(v, numbers.Integral) and not isinstance(v, bool | np.bool_)
                    for v in pair)
            except TypeError:
                ok = False
            if not ok:
                raise ValueError(f"{name}[{k}] must be two child indices, got {pair!r}")
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
            raise ValueError(f"{name}: {value!r} is not in $.images")
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
        raise ValueError(f"{name}: expected {self.schema}, got {value!r}")


@dataclass(frozen=True)
class Param:
    """One declared parameter of a node type."""

    name: str
    kind: Kind
    default: Any = REQUIRED
    doc: str = field(default="", compare=False)
