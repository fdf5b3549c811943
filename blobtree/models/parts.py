"""A shell's parts kept between builds: a part is built again only when a spec value it read
changed.

Modelling live changes one spec number at a time, and most parts of a shell do not read it: a
change of the canal's tilt leaves the bumps, the varices and their spines as they were.  Each
part is built from a :class:`Reads` view of the spec, which records every attribute the build
asks for and its value; the part is kept with those reads (and the build's other arguments), and
a later build whose spec gives equal values for all of them gets the same nodes back, their
structural keys and boxes already computed.  What a part depends on is what it read, not a list
kept by hand, so a new spec field or a new use of one cannot leave a stale part behind.
"""

from __future__ import annotations

import dataclasses
import threading
from collections import OrderedDict
from collections.abc import Callable
from typing import Any

import numpy as np

from .spec import ShellSpec

#: Builds kept per part (as many as the live explorer keeps trees).
KEPT = 8


class Reads:
    """A spec that records each attribute read from it (name -> value): pass it where the spec
    goes; ``read`` holds what the build asked for."""

    __slots__ = ("_spec", "read")

    def __init__(self, spec: ShellSpec) -> None:
        self._spec = spec
        self.read: dict[str, Any] = {}

    def __getattr__(self, name: str) -> Any:
        value = getattr(self._spec, name)
        self.read[name] = value
        return value


def same(a: Any, b: Any) -> bool:
    """Whether two spec values are the same to the bit (0.0 and -0.0 differ, as in node keys):
    floats by their exact text, sequences, arrays and dataclasses item by item."""
    if a is b:
        return True
    if type(a) is not type(b):
        return False
    if isinstance(a, float):
        return a.hex() == b.hex()
    if isinstance(a, tuple | list):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, np.ndarray):
        return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    if dataclasses.is_dataclass(a):
        return all(same(getattr(a, f.name), getattr(b, f.name))
                   for f in dataclasses.fields(a))
    return bool(a == b)


_KEPT: dict[str, OrderedDict[int, tuple[tuple, dict[str, Any], Any]]] = {}
_LOCK = threading.Lock()
_COUNT = iter(range(1 << 62))


def part(name: str, build: Callable[..., Any], spec: ShellSpec, *args: Any) -> Any:
    """``build(spec, *args)``, or the result of an earlier build of part ``name`` whose ``args``
    and every spec value it read are the :func:`same` as now.  Nodes are values, so sharing
    them between trees is safe."""
    with _LOCK:
        kept = list(_KEPT.get(name, {}).items())
    for entry, (was, read, result) in reversed(kept):  # the latest first
        if same(was, args) and all(same(getattr(spec, k), v) for k, v in read.items()):
            with _LOCK:
                if entry in _KEPT.get(name, {}):
                    _KEPT[name].move_to_end(entry)
            return result
    reads = Reads(spec)
    result = build(reads, *args)
    with _LOCK:
        kept_now = _KEPT.setdefault(name, OrderedDict())
        kept_now[next(_COUNT)] = (args, dict(reads.read), result)
        while len(kept_now) > KEPT:
            kept_now.popitem(last=False)
    return result


def forget() -> None:
    """Drop every kept part (the next builds start afresh)."""
    with _LOCK:
        _KEPT.clear()
