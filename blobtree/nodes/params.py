"""Parameter kinds of node specs: validation, scene-file form and sampling ranges, in one place.

A node type declares its parameters as :class:`Param` (name, kind, default).  Each kind checks a
value (``ValueError`` naming the parameter, the value and what is allowed), converts it to and
from its scene-file form, and carries the range tests and generators sample it from
(``sample``), so validation, ``params()``, the scene schema and the test strategies all derive
from the same declaration.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..checks import AXES, Kind, Number, Vec3, frozen, is_vector, short_repr
from ..texture import mapping as tex

#: Marks a parameter without a default.
REQUIRED: Any = object()



@dataclass(frozen=True)
class Axis(Kind):
    """A rotation axis: "x", "y", "z" or a non-zero 3-vector."""

    schema = "axis ('x', 'y', 'z' or a 3-vector)"

    def check(self, name: str, value: Any) -> str | tuple[float, float, float]:
        if isinstance(value, str):
            return AXES.check(name, value)
        v = Vec3().check(name, value) if is_vector(value) else None
        if v is None or not np.any(v != 0.0):
            raise ValueError(f"{name} must be 'x', 'y', 'z' or a non-zero 3-vector, got "
                             f"{short_repr(value)}")
        return tuple(float(x) for x in v)

    def to_json(self, value, images):
        return value if isinstance(value, str) else list(value)


@dataclass(frozen=True)
class Pairs(Kind):
    """Pairs of child indices (the controlled blend's b_i of Eq. 6)."""

    schema = "list of index pairs"

    def check(self, name: str, value: Any) -> tuple[tuple[int, int], ...]:
        if isinstance(value, str | bytes):
            raise ValueError(f"{name} must be a list of index pairs, got {short_repr(value)}")
        try:
            items = list(value)
        except TypeError:
            raise ValueError(f"{name} must be a list of index pairs, got {short_repr(value)}") \
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
                raise ValueError(f"{name}[{k}] must be two child indices, got {short_repr(pair)}")
            out.append((int(pair[0]), int(pair[1])))
        return tuple(out)

    def to_json(self, value, images):
        return [list(p) for p in value]


#: Largest exponent of a super-elliptic blend (beyond it the blend is the union to 1e-6).
LARGEST_N = 1e6
_EXPONENT = Number(lo=1.0, hi=LARGEST_N)


@dataclass(frozen=True)
class Groups(Kind):
    """Groups of child indices that blend together, each with its own super-elliptic exponent or
    None for the node's ``n``: given as index lists ``[0, 1, 2]`` or as ``([0, 1, 2], 4.0)``."""

    schema = "list of index groups, each [indices] or [[indices], n]"

    def check(self, name: str, value: Any) -> tuple[tuple[tuple[int, ...], float | None], ...]:
        if isinstance(value, str | bytes) or not _iterable(value):
            raise ValueError(f"{name} must be a list of index groups, got {short_repr(value)}")
        out = []
        for k, group in enumerate(value):
            n = None
            if _iterable(group) and not isinstance(group, str) and len(group) == 2 \
                    and _iterable(group[0]) and not isinstance(group[0], str):
                group, n = group
                n = None if n is None else _EXPONENT.check(f"{name}[{k}] exponent", n)
            members = list(group) if _iterable(group) and not isinstance(group, str) else None
            if not members or not all(isinstance(v, numbers.Integral)
                                      and not isinstance(v, bool | np.bool_) for v in members):
                raise ValueError(f"{name}[{k}] must be a non-empty list of child indices, "
                                 f"optionally with an exponent: [indices] or [[indices], n], "
                                 f"got {short_repr(group)}")
            out.append((tuple(int(v) for v in members), n))
        return tuple(out)

    def to_json(self, value, images):
        return [[list(members), n] for members, n in value]


def _iterable(value: Any) -> bool:
    try:
        iter(value)
    except TypeError:
        return False
    return True


@dataclass(frozen=True)
class Image(Kind):
    """A texture image: an (H, W, 3) uint8 array (from a path, an array or a function of
    (u, v), see :func:`blobtree.texture.mapping.load_image`); scene files store each image once."""

    schema = "image (a key of $.images)"

    def check(self, name: str, value: Any) -> np.ndarray:
        if isinstance(value, np.ndarray) and value.dtype == np.uint8 and value.ndim == 3 \
                and value.shape[2] == 3 and not value.flags.writeable \
                and value.flags.c_contiguous:
            return value
        return frozen(tex.load_image(value))

    def to_json(self, value, images):
        key = tex.image_digest(value)
        images[key] = value
        return key

    def from_json(self, name, value, images):
        if not isinstance(value, str) or value not in images:
            raise ValueError(f"{name}: {short_repr(value)} is not in $.images")
        return images[value]

    def key(self, value) -> str:
        return tex.image_digest(value)


@dataclass(frozen=True)
class Mapping(Kind):
    """A texture mapping: "primitive" (field-interpolated) or a
    :class:`blobtree.texture.mapping.HelicoSurface` (bounding surface)."""

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
        raise ValueError(f"{name}: expected {self.schema}, got {short_repr(value)}")


@dataclass(frozen=True)
class Param:
    """One declared parameter of a node type."""

    name: str
    kind: Kind
    default: Any = REQUIRED
    doc: str = field(default="", compare=False)
    #: The scene-file version that added it: older files may lack it (it takes its default).
    since: int = field(default=1, compare=False)
