"""Compiled kernels: numba's ``njit`` with an on-disk cache that knows the whole engine.

numba caches each compiled function on disk keyed on its own source file only.  A kernel that
calls kernels of other modules (the interpreter calls every node type's kernel) would then keep
stale machine code after one of those modules changed.  :func:`kernel` keys every cached
function on a digest of all the package's compiled sources as well (:func:`engine_key`), so a
change anywhere, a new node type included, recompiles what depends on it, and nothing stale is
ever loaded.

``tag`` tells apart the closures one factory makes (numba's own key would pickle the functions
they capture, which differs in every process, so they would never be found in the cache).

Kernels are compiled on first call, so importing the package compiles nothing;
:func:`on_compile` lets the command line say once that it is compiling.
"""

from __future__ import annotations

import functools
import hashlib
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import numba
from numba.core import event, types
from numba.core.caching import FunctionCache
from numba.core.runtime import rtsys

from . import partner
from .linked import Linked, register_cached

_PACKAGE = Path(__file__).resolve().parents[1]
#: Parts of the package no kernel depends on: code numba never compiles, and the mesher, whose
#: kernels (:func:`cached`) are keyed on their own source file, as they call no engine kernel.
_NOT_COMPILED = {"cli", "mesh", "models", "texture/pigment.py", "texture/shell.py"}


@functools.cache
def engine_key() -> str:
    """A digest of every source file of the package numba may compile."""
    h = hashlib.sha256(numba.__version__.encode())
    for path in sorted(_PACKAGE.rglob("*.py")):
        rel = path.relative_to(_PACKAGE)
        if rel.parts[0] in _NOT_COMPILED or rel.as_posix() in _NOT_COMPILED:
            continue
        h.update(str(rel).encode())
        h.update(path.read_bytes())
    return h.hexdigest()[:24]


class _QuickCache(FunctionCache):
    """numba's function cache, loading without first refreshing the target context; ``tag``
    (if any) in every key tells apart the kernels compiled from one function (see
    :func:`_twin_njit`)."""

    def __init__(self, py_func: Callable, tag: str = "") -> None:
        super().__init__(py_func)
        self._tag = tag

    def _index_key(self, sig, codegen):
        key = super()._index_key(sig, codegen)
        return (*key, self._tag) if self._tag else key

    def load_overload(self, sig, target_context):
        """numba's, without the refresh: it imports and installs every registry numba has
        (0.25-0.5 s on the first call of a process, SciPy's BLAS check included), which only
        compiling needs, and numba's compiler refreshes before it compiles.  Loading needs
        only the runtime's symbols (``rtsys``) and those of the linked kernels
        (:meth:`_load_overload`).  A kernel a partner process is compiling
        (``runtime.partner``) is waited for."""
        rtsys.initialize(target_context)
        partner.wait(partner.kernel_key(self._py_func))
        with self._guard_against_spurious_io_errors():
            return self._load_overload(sig, target_context)

    def _load_overload(self, sig, target_context):
        """numba's, registering the linked kernels a kernel found in the cache calls by symbol
        (``runtime.linked``) before it is loaded (compiling one the cache lacks).  (``data[0]``
        is numba's serialised library: its name, its kind, then its object code first.)"""
        if not self._enabled:
            return None
        data = self._cache_file.load(self._index_key(sig, target_context.codegen()))
        if data is None:
            return None
        register_cached(data[0][2][0])
        return self._impl.rebuild(target_context, data)


class _EngineCache(_QuickCache):
    """The quick-loading cache, with the engine's digest and the tag in every key."""

    def _index_key(self, sig, codegen):
        code = hashlib.sha256(self._py_func.__code__.co_code).hexdigest()
        return (sig, codegen.magic_tuple(), (engine_key(), code, self._tag))


class _LazyCache:
    """A numba cache made on its first use.  Making one probes the cache directory (a mkdir and
    a test file per kernel: 20-40 ms for the package's 225 at import), and a process
    loads few of its kernels by name: the rest are compiled into their callers."""

    def __init__(self, make: Callable[[], FunctionCache]) -> None:
        self._make = make
        self._real: FunctionCache | None = None

    def __getattr__(self, name: str):
        if self._real is None:
            self._real = self._make()
        return getattr(self._real, name)


def cached(fn: Callable | None = None, **options):
    """``numba.njit(cache=True, **options)``, its cache loading without numba's registry refresh
    (:class:`_QuickCache`), compiled callers calling its wrapperless twin (:func:`_twin_njit`):
    for kernels that call no engine kernel (the mesher's), so that their own source file is key
    enough."""

    def wrap(f: Callable):
        return _twin_njit(f, options, functools.partial(_QuickCache, f), literal=True)

    return wrap(fn) if fn is not None else wrap


def _twin_njit(f: Callable, options: dict, make_cache: Callable[[str], FunctionCache], *,
               literal: bool):
    """``numba.njit(**options)(f)`` with the cache ``make_cache(tag)``, which compiled callers
    do not call: their calls are typed and linked to a twin compiled without numba's Python and
    C wrappers.  Only a call from Python needs a wrapper, yet numba makes both for every kernel
    it compiles and optimises and emits them, though most kernels are only ever called by
    other kernels (a first ``render murex`` compiles some 150): building the wrappers took a
    tenth of a cold point walk's compiling, and a first render takes a fifth less time without
    them (docs/benchmarks.md).  A kernel called both ways is compiled once for each.  Without
    ``literal``, constant arguments of compiled calls are typed as plain values
    (:func:`_call_template`)."""
    dispatcher = numba.njit(**options)(f)
    dispatcher._cache = _LazyCache(lambda: make_cache(""))
    twin = numba.njit(no_cpython_wrapper=True, no_cfunc_wrapper=True, **options)(f)
    twin._cache = _LazyCache(lambda: make_cache("twin"))
    dispatcher.get_call_template = (twin.get_call_template if literal else
                                    functools.partial(_call_template, twin))
    dispatcher.get_overload = twin.get_overload  # (what a compiled call links to)
    return dispatcher


def kernel(fn: Callable | None = None, *, tag: str = "", nrt: bool = False, **options):
    """``numba.njit(**options)`` with the engine-keyed cache and numpy's error model (a division
    by zero gives inf or NaN instead of raising, and loops without such checks vectorise).

    By default kernels are compiled without numba's reference counting (see docs/engine.md:
    such a kernel must not allocate); ``nrt=True`` for one that allocates.  Constants a
    compiled caller passes are typed as plain values, so the kernel is compiled once rather
    than once per constant (:func:`_call_template`); compiled callers call its wrapperless twin
    (:func:`_twin_njit`).  ``tag`` names a closure made by a factory (see the module doc).
    """

    def wrap(f: Callable):
        opts = {"error_model": "numpy", **options}
        if opts.get("inline", "never") == "never":  # (numba's callees inherit the flag)
            opts.setdefault("forceinline", False)
        if not nrt:
            opts["_nrt"] = False
        return _twin_njit(f, opts, lambda twin: _EngineCache(f, f"{tag}:{twin}"),
                          literal=False)

    return wrap(fn) if fn is not None else wrap


def linked(signature, **options) -> Callable[[Callable], Linked]:
    """A kernel compiled once on its own with ``signature`` (numba types) and called by symbol
    from other kernels through its ``.call`` (see ``runtime.linked``): for the program walks,
    which many kernels call.  Keyed on the whole engine like :func:`kernel`; numpy's error
    model, no reference counting."""

    def wrap(f: Callable) -> Linked:
        opts = {"error_model": "numpy", "_nrt": False, **options}
        return Linked(f, signature, opts, lambda: _LazyCache(lambda: _EngineCache(f, "linked")),
                      lambda: kernel(f, tag="python"))

    return wrap


def _call_template(dispatcher, args, kws):
    """Type a call from compiled code with its constant arguments as plain types.

    numba compiles a separate copy of a function for each constant it is called with from
    compiled code (``eval_point(..., mode=0)`` and ``(..., mode=2)``, and every kernel below
    them); typing those arguments as plain ints and floats compiles each kernel once.
    """
    args = tuple(types.unliteral(a) for a in args)
    kws = {k: types.unliteral(v) for k, v in kws.items()}
    return type(dispatcher).get_call_template(dispatcher, args, kws)


class _CompileListener(event.Listener):
    def __init__(self, callback: Callable[[], None]) -> None:
        self.callback = callback
        self.fired = False

    def on_start(self, ev) -> None:
        if not self.fired:
            self.fired = True
            self.callback()

    def on_end(self, ev) -> None:
        pass


@contextmanager
def on_compile(callback: Callable[[], None]) -> Iterator[_CompileListener]:
    """Within the block, call ``callback`` once when numba starts compiling anything (a first
    run, or the first after the package changed); ``listener.fired`` tells whether it did."""
    listener = _CompileListener(callback)
    event.register("numba:compile", listener)
    try:
        yield listener
    finally:
        event.unregister("numba:compile", listener)
