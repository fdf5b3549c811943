"""Checking values: the kinds of value parameters take, with their documented limits.

Each kind checks a value (``ValueError`` naming the parameter, the value, shortened, and what is
allowed), converts it to and from its scene-file form, and carries the range tests and generators
sample it from (``sample``).  Node parameters (``blobtree.nodes.params``), texture mappings,
spirals, cameras, lights and the polygonizer's arguments are all checked by these, so the API,
the scene loader and the command line share one validation path and one set of limits
(docs/limits.md).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any

import numpy as np


def short_repr(value: Any, limit: int = 60) -> str:
    """repr of a value, cut to at most ``limit`` characters (a megabyte-long name or list is
    quoted by its start)."""
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


# ----- the documented limits (docs/limits.md) -------------------------------------------------
#: Coordinates (centres, axis ends, offsets): |x| at most this, in scene units.
MAX_COORD = 1e6
#: Radii, lengths, scale factors: within [MIN_SIZE, MAX_SIZE] (magnitude, for scale factors).
MIN_SIZE, MAX_SIZE = 1e-6, 1e6
#: Angles and angle rates, in degrees: |a| at most this.
MAX_ANGLE = 1e6


def is_number(v: Any) -> bool:
    return type(v) is float or (isinstance(v, numbers.Real) and not isinstance(v, bool | np.bool_))


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
            v = float(value) if is_number(value) else math.nan
        except OverflowError:
            v = math.inf
        ok = math.isfinite(v) and (v > self.lo if self.lo_open else v >= self.lo) \
            and (v < self.hi if self.hi_open else v <= self.hi)
        if not ok:
            raise ValueError(f"{name} must be {self.allowed()}, got {short_repr(value)}")
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
                             f"{short_repr(value)}")
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
        if not isinstance(value, str) and is_vector(value):
            try:
                items = [float(v) for v in value]
            except OverflowError:
                items = None
        # |x| <= limit is False for NaN and inf: every item is finite and within the limit
        if items is None or not all(self.least <= abs(x) <= self.limit for x in items):
            raise ValueError(f"{name} must be {self.allowed()}, got {short_repr(value)}")
        return frozen(items)

    def to_json(self, value, images):
        return [float(v) for v in value]

    def key(self, value) -> str:
        return ",".join([float(v).hex() for v in value])


def is_vector(value: Any) -> bool:
    try:
        items = list(value)
    except TypeError:
        return False
    return len(items) == 3 and all(is_number(v) for v in items)


@dataclass(frozen=True)
class RGB(Vec3):
    """A colour: three numbers in [0, 1]."""

    sample: tuple[float, float] = (0.0, 1.0)
    schema = "rgb (3 numbers in [0, 1])"

    def check(self, name: str, value: Any) -> np.ndarray:
        v = super().check(name, value)
        if np.any(v < 0.0) or np.any(v > 1.0):
            raise ValueError(f"{name} components must lie in [0, 1], got {short_repr(value)}")
        return v


@dataclass(frozen=True)
class Choice(Kind):
    """One of a fixed set of strings."""

    options: tuple[str, ...] = ()
    schema = "string"

    def check(self, name: str, value: Any) -> str:
        if not isinstance(value, str) or value not in self.options:
            raise ValueError(f"{name} must be one of {list(self.options)}, got {short_repr(value)}")
        return value


AXES = Choice(("x", "y", "z"))
