"""A shell's parts kept between builds: a part is built again only when a spec value it read
changed.

Modelling live changes one spec number at a time, and most parts of a shell do not read it: a
change of the canal's tilt leaves the bumps, the varices and their spines as they were.  Each
part is built from a :class:`Reads` view of the spec, which records every attribute the build
asks for and its value; the part is kept with those reads (and the build's other arguments), and
a later build whose spec gives equal values for all of them gets the same nodes back, their
structural keys and boxes already computed.  What a part depends on is what it read, not a list
kept by hand, so a new spec field or a new use of one cannot leave a stale part behind.

The parts are kept by a :class:`Parts` that the one changing a spec owns (``LiveShell``, and so
the explorer and ``blobtree watch``) and passes to every build; a build without one keeps
nothing (the Murex's kept builds take about 8 MB each).
"""

from __future__ import annotations

import dataclasses
import threading
from collections import OrderedDict
from collections.abc import Callable
from typing import Any

import numpy as np

from .spec import ShellSpec


class Reads:
    """A spec that records each attribute read from it (name -> value): pass it where the spec
    goes; ``read`` holds what the build asked for."""

    __slots__ = ("_spec", "_read")

    def __init__(self, spec: ShellSpec) -> None:
        self._spec = spec
        self._read: dict[str, Any] = {}

    @property
    def read(self) -> dict[str, Any]:
        """The attributes read so far and their values."""
        return self._read

    def __getattr__(self, name: str) -> Any:
        value = getattr(self._spec, name)
        self._read[name] = value
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


class Parts:
    """The parts of the shells built with it, kept between builds (the last ``kept`` builds of
    each part): pass one to :func:`~blobtree.models.shell` for every build of a spec being
    changed (``blobtree.live.LiveShell`` does).  Nodes are values, so sharing them between
    trees is safe; ``kept=0`` keeps nothing."""

    def __init__(self, kept: int) -> None:
        self.kept = kept
        self._builds: dict[str, OrderedDict[int, tuple[tuple, dict[str, Any], Any]]] = {}
        self._lock = threading.Lock()
        self._count = 0

    def part(self, name: str, build: Callable[..., Any], spec: ShellSpec, *args: Any) -> Any:
        """``build(spec, *args)``, or the result of an earlier build of part ``name`` whose
        ``args`` and every spec value it read are the :func:`same` as now."""
        if not self.kept:
            return build(spec, *args)
        with self._lock:
            kept = list(self._builds.get(name, {}).items())
        for entry, (was, read, result) in reversed(kept):  # the latest first
            if same(was, args) and all(same(getattr(spec, k), v) for k, v in read.items()):
                with self._lock:
                    if entry in self._builds.get(name, {}):
                        self._builds[name].move_to_end(entry)
                return result
        reads = Reads(spec)
        result = build(reads, *args)
        with self._lock:
            builds = self._builds.setdefault(name, OrderedDict())
            self._count += 1
            builds[self._count] = (args, dict(reads.read), result)
            while len(builds) > self.kept:
                builds.popitem(last=False)
        return result


#: Parts built afresh every time (what a build without its own :class:`Parts` uses).
FRESH = Parts(kept=0)


__all__ = ["FRESH", "Parts", "Reads", "same"]
