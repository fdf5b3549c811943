"""The program walk, written once: every evaluation mode runs a program through :func:`walk`.

A program is postfix (``program.py``): primitives push a row on a value stack, operators pop
their children's rows and push their own, paint nodes colour the top row, and a subtree behind a
box (BOX, and PUSHPT and warps, which also move the point) is skipped, as one zero row, when its
box misses what is being evaluated.  PUSHPT enters a warp's frame (one level deeper on the point
stack), a warp moves the point within it, POPPT leaves it.  That control flow is the same for
every evaluation; what differs is the work of each kind, which a :class:`Mode` supplies as small
kernels (compiled into the walk):

=============  ==================================================  =========================
hook           called                                              returns
=============  ==================================================  =========================
``start``      ``(prog, at, st)`` before the first instruction     the walk's state ``cur``
``primitive``  ``(prog, at, i, cur, pp, st, sp)``: push row sp
``operator``   ``(prog, at, i, cur, st, b, k)``: rows b .. b+k-1
               into row b
``misses``     ``(prog, at, i, cur, pp, st)``: does instruction    bool
               i's box miss?
``zero``       ``(at, st, sp)``: push a zero row at sp
``enter``      ``(prog, at, i, cur, st, pp)``: PUSHPT, pp the new  ``cur`` in the frame
               level
``warp``       ``(prog, at, i, cur, st, pp)``                      ``cur`` moved by the warp
``leave``      ``(prog, at, i, cur, st, top, pp)``: POPPT, top     ``cur`` of the outer frame
               the row on top, pp the level left
``paint``      ``(prog, at, i, cur, st, top)``
``finish``     ``(prog, at, cur, st)`` after the last              the walk's result
=============  ==================================================  =========================

``prog`` is the program bundle ``(code, params, boxes, lips)``, ``at`` what the mode evaluates
(a point, a region, a batch), ``st`` its stacks, ``cur`` what the walk carries from instruction
to instruction (the point in the current frame, the region...).  :func:`walk` refuses a mode
that lacks a hook, and the engine (``dispatch.KIND``) having a kind of instruction the walk does
not know: no instruction falls through to a default.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from ..nodes.layout import ARG, OP, SKIP
from ..runtime.jit import kernel
from .dispatch import (
    K_BOX,
    K_OPERATOR,
    K_PAINT,
    K_POPPT,
    K_PRIMITIVE,
    K_PUSHPT,
    K_WARP,
    K_ZERO,
    KIND,
    kind_of,
)

#: The kinds of instruction :func:`walk` runs.
WALKED = {K_PRIMITIVE, K_OPERATOR, K_WARP, K_PAINT, K_BOX, K_PUSHPT, K_POPPT, K_ZERO}


@dataclass(frozen=True)
class Mode:
    """An evaluation mode: its name and its per-kind work (see the module doc)."""

    name: str
    start: object
    primitive: object
    operator: object
    misses: object
    zero: object
    enter: object
    warp: object
    leave: object
    paint: object
    finish: object


def walk(mode: Mode):
    """The program walk running ``mode``'s hooks: ``walk(prog, at, st)``, a plain Python function
    for ``jit.kernel`` or ``jit.linked`` to compile.  ValueError for a mode without every hook
    or an instruction kind the walk does not run."""
    missing = [f.name for f in fields(Mode) if getattr(mode, f.name) is None]
    if missing:
        raise ValueError(f"evaluation mode {mode.name!r} lacks the hooks {missing}")
    unknown = set(int(k) for k in KIND) - WALKED
    if unknown:
        raise ValueError(f"the program walk does not run instruction kinds {sorted(unknown)}")
    start, primitive, operator, misses, zero = (mode.start, mode.primitive, mode.operator,
                                                mode.misses, mode.zero)
    enter, warp, leave, paint, finish = mode.enter, mode.warp, mode.leave, mode.paint, mode.finish

    def run(prog, at, st):
        code = prog[0]
        n = code.shape[0]
        cur = start(prog, at, st)
        sp = 0
        pp = 0
        i = 0
        while i < n:
            kind = kind_of(code[i, OP])
            if kind == K_PRIMITIVE:
                primitive(prog, at, i, cur, pp, st, sp)
                sp += 1
            elif kind == K_OPERATOR:
                k = code[i, ARG]
                sp -= k
                operator(prog, at, i, cur, st, sp, k)
                sp += 1
            elif kind == K_POPPT:
                cur = leave(prog, at, i, cur, st, sp - 1, pp)
                pp -= 1
            elif kind == K_PAINT:
                paint(prog, at, i, cur, st, sp - 1)
            elif kind == K_ZERO:
                zero(at, st, sp)
                sp += 1
            else:  # K_BOX, K_PUSHPT, K_WARP: a subtree behind its box
                if misses(prog, at, i, cur, pp, st):
                    zero(at, st, sp)
                    sp += 1
                    i = code[i, SKIP]
                    continue
                if kind == K_PUSHPT:
                    pp += 1
                    cur = enter(prog, at, i, cur, st, pp)
                elif kind == K_WARP:
                    cur = warp(prog, at, i, cur, st, pp)
            i += 1
        return finish(prog, at, cur, st)

    run.__name__ = run.__qualname__ = f"walk_{mode.name}"
    return run


def hook(fn):
    """A mode's hook: compiled into its walk (numba inlines it)."""
    return kernel(fn, inline="always")
