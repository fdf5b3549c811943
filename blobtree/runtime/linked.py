"""Kernels compiled once and called by symbol: the program walks every other kernel calls.

numba compiles a kernel together with everything it calls: each caller links the callee's code
into its own and optimises and emits all of it again.  The program walks (a point's value, the
bound passes, a batch's rows) are large, and the ray tracer, the mesher and the batches call
them from a dozen kernels, so a first run compiled each walk a dozen times.  A :func:`linked`
kernel is compiled once on its own, with a fixed signature, as a C function; kernels call it
through an external symbol (numba's ``intrinsic``: a declaration and a call), which the process
resolves to that function's address (``llvmlite.binding.add_symbol``), in every run, whether
the caller was compiled now or loaded from the cache.

Before a kernel is loaded from the cache, the walks its code calls are loaded and their symbols
registered (:func:`register_cached`); one missing from the cache is compiled first (a call to a
symbol never registered would jump to nothing).  A walk not yet
compiled is compiled when the first kernel calling it is (its call is typed).  The walks are
cached like every kernel, keyed on the whole engine (``jit.engine_key``).
"""

from __future__ import annotations

from collections.abc import Callable

import llvmlite.binding as llvm
from llvmlite import ir
from numba.core import cgutils, event
from numba.core.ccallback import CFunc
from numba.core.compiler_lock import global_compiler_lock
from numba.extending import intrinsic

from . import partner

#: Every linked kernel, in the order they were made.
LINKED: list[Linked] = []


class Linked:
    """A kernel with a fixed signature, compiled on its own as a C function and registered as
    the external symbol ``blobtree_<name>`` (see the module doc).  ``call`` is what kernels
    call; calling the object from Python runs the same function compiled as an ordinary
    kernel (for tests and tools)."""

    def __init__(self, fn: Callable, signature, options: dict, make_cache: Callable,
                 make_python: Callable[[], Callable]) -> None:
        self.py_func = fn
        self.signature = signature
        self.symbol = f"blobtree_{fn.__module__.rsplit('.', 1)[-1]}_{fn.__name__}"
        self._options = options
        self._make_cache = make_cache
        self._make_python = make_python
        self._cfunc: CFunc | None = None
        self._python: Callable | None = None
        self.call = _intrinsic(self)
        LINKED.append(self)

    @property
    def address(self) -> int:
        """The C function's address (compiling or loading it first)."""
        self.ensure()
        return self._cfunc.address

    @global_compiler_lock
    def ensure(self, compile: bool = True) -> bool:
        """Load the C function from the cache, or compile it (with ``compile``), and register its
        symbol; whether it is registered."""
        if self._cfunc is not None:
            return True
        partner.wait(self.symbol)
        cf = CFunc(self.py_func, (self.signature.args, self.signature.return_type), {},
                   self._options)
        cf._cache = self._make_cache()
        cres = cf._cache.load_overload(cf._sig, cf._targetdescr.target_context)
        if cres is None:
            if not compile:
                return False
            address = partner.placeholder(self.symbol)
            if address is not None:  # (a partner process: compiles, never runs)
                llvm.add_symbol(self.symbol, address)
                return True
            with event.trigger_event("numba:compile", data={"dispatcher": self}):
                cres = cf._compile_uncached()
            cf._cache.save_overload(cf._sig, cres)
        cf._library = cres.library
        cf._wrapper_name = cres.fndesc.llvm_cfunc_wrapper_name
        cf._wrapper_address = cres.library.get_pointer_to_function(cf._wrapper_name)
        llvm.add_symbol(self.symbol, cf._wrapper_address)
        self._cfunc = cf
        return True

    def __call__(self, *args):
        if self._python is None:
            self._python = self._make_python()
        return self._python(*args)


def _intrinsic(target: Linked):
    """numba's intrinsic calling ``target`` by its symbol, with the argument count of its
    signature; a call whose argument types do not match is refused while it is typed."""
    sig = target.signature
    names = ", ".join(f"a{k}" for k in range(len(sig.args)))

    def typing(typingctx, *args):
        for k, (got, want) in enumerate(zip(args, sig.args, strict=True)):
            if got != want and typingctx.can_convert(got, want) is None:
                raise TypeError(f"{target.symbol}: argument {k} is {got}, its signature takes "
                                f"{want}")
        target.ensure()

        def codegen(context, builder, signature, llargs):
            fnty = ir.FunctionType(context.get_value_type(sig.return_type),
                                   [context.get_value_type(a) for a in sig.args])
            fn = cgutils.get_or_insert_function(builder.module, fnty, target.symbol)
            values = [context.cast(builder, v, got, want)
                      for v, got, want in zip(llargs, signature.args, sig.args, strict=True)]
            return builder.call(fn, values)

        return sig.return_type(*args), codegen

    namespace = {"typing": typing}
    exec(f"def {target.py_func.__name__}(typingctx, {names}):\n"  # noqa: S102 (fixed text)
         f"    return typing(typingctx, {names})\n", namespace)
    return intrinsic(namespace[target.py_func.__name__])


def register_cached(code: bytes) -> None:
    """Register the linked kernels that the object ``code`` of a kernel in the cache names (its
    calls to them) before that kernel is loaded: loaded from the cache, or compiled where the
    cache lacks one (a call to a symbol never registered would jump to nothing)."""
    for target in LINKED:
        if target.symbol.encode() in code:
            target.ensure()
