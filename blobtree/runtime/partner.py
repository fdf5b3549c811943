"""A first run's compiling shared with a second process.

With an empty numba cache a command compiles some 150 kernel signatures one after another:
numba's compiler holds a lock, so a process compiles on one core.  :func:`start` launches a
partner process that compiles some *units* (a linked walk, or a kernel with everything it calls)
into the same cache while this process compiles the rest.  Where this process reaches a unit the
partner owns (a walk it links, a kernel it calls), it waits for the partner to finish that unit
and loads it from the cache (:func:`wait`, called by the cache and by ``Linked.ensure``).  If the
partner fails or is killed, the waiting process compiles the unit itself: nothing is lost but
the time.

The partner only compiles, it never runs a kernel: a walk that this process compiles and the
partner's kernels call by symbol (``runtime.linked``) is registered there at a placeholder
address (libc's ``abort``) when the cache does not hold it yet; the cached code names the walk,
and the process loading that code resolves the name to the real walk.

The partner runs :func:`compile_units` on its units ``KEY=MODULE:NAME``: it compiles each in
order and prints ``done KEY`` (or ``failed KEY``) after each; ``NAME`` is a linked walk
(compiled) or a function (called: it compiles its kernels).
"""

from __future__ import annotations

import ctypes
import importlib
import subprocess
import sys
import threading
from collections.abc import Callable, Mapping

from .threads import threads

#: The partner process's program.
_PARTNER = f"import sys; from {__name__} import compile_units; compile_units(sys.argv[1:])"
_lock = threading.Lock()
#: Units the running partner owns, by key: set once the partner finished (or failed) them.
_pending: dict[str, threading.Event] = {}
#: In the partner: the placeholder address, and the symbols of the walks it compiles itself.
_placeholder: list = []


def start(units: Mapping[str, str]) -> subprocess.Popen | None:
    """Launch a partner process compiling ``units`` (key -> ``"module:name"``, in order) into
    numba's cache, and return it; this process then waits for a unit's key (:func:`wait`)
    before compiling it.  Starts none (None) while another partner runs, or where the kernels
    run on one thread (``NUMBA_NUM_THREADS=1``: one core to use)."""
    if threads() < 2:
        return None
    with _lock:
        if any(not e.is_set() for e in _pending.values()):
            return None
        try:
            proc = subprocess.Popen(
                [sys.executable, "-c", _PARTNER, *(f"{k}={v}" for k, v in units.items())],
                stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                text=True)
        except OSError:
            return None
        events = {key: threading.Event() for key in units}
        _pending.clear()
        _pending.update(events)
    threading.Thread(target=_follow, args=(proc, events), name="blobtree-partner",
                     daemon=True).start()
    return proc


def _follow(proc: subprocess.Popen, events: dict[str, threading.Event]) -> None:
    """Set each unit's event as the partner reports it; all of them when it ends."""
    try:
        for line in proc.stdout:
            word, _, key = line.strip().partition(" ")
            if word in ("done", "failed") and key in events:
                events[key].set()
    finally:
        proc.wait()
        for e in events.values():
            e.set()


def kernel_key(fn: Callable) -> str:
    """The key of a unit that compiles the kernel of Python function ``fn`` (what the cache
    waits for before loading that kernel)."""
    return f"{fn.__module__}.{fn.__qualname__}"


def wait(key: str) -> None:
    """If a partner owns the unit ``key`` and has not finished it, wait until it has."""
    event = _pending.get(key)
    if event is not None:
        event.wait()


def placeholder(symbol: str) -> int | None:
    """In a partner process, the address to register for the linked walk ``symbol`` when the
    cache lacks it (None: compile it, as every other process does)."""
    if _placeholder and symbol not in _placeholder[1]:
        return _placeholder[0]
    return None


def compile_units(units: list[str]) -> None:
    """The partner's side: compile each unit (``KEY=MODULE:NAME``), reporting on stdout."""
    targets = {}
    for unit in units:
        key, _, where = unit.partition("=")
        module, _, name = where.partition(":")
        try:
            targets[key] = getattr(importlib.import_module(module), name)
        except (ImportError, AttributeError):
            print("failed", key, flush=True)
    linked = {key for key, t in targets.items() if hasattr(t, "ensure")}  # (a linked walk)
    _placeholder[:] = [ctypes.cast(ctypes.CDLL(None).abort, ctypes.c_void_p).value,
                       {targets[key].symbol for key in linked}]
    for key, target in targets.items():
        try:
            target.ensure() if key in linked else target()
            word = "done"
        except Exception:  # the waiting process compiles it and reports its errors
            word = "failed"
        print(word, key, flush=True)
