"""The engine's view of the node registry: opcodes, their kinds and rules, and one compiled
dispatcher per kind of kernel, all derived from ``nodes.REGISTRY``.

Opcodes 0-3 are the program's own instructions (BOX, PUSHPT, POPPT, ZERO); every registered node
type with kernels gets the next number, in registration order (programs are never stored, so the
numbers need not be stable).  A dispatcher is a chain of small compiled functions, one per
opcode, ``if op == mine: my_kernel(...) else: next(...)``, built from closures over each type's
kernel (numba compiles the closures' captured functions in; ``jit.kernel``'s tag keeps them
apart in the cache).  The end of a chain returns NaN: the compiler refuses any node type without
kernels, so it is never reached, and never runs another node's maths.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..jit import kernel
from ..nodes import REGISTRY, kmath
from ..nodes.base import FALLOFF, LIPSCHITZ_RULES, RADIUS, ZERO_RULES, Node, freeze_registry

# ----- the program's own instructions -------------------------------------------------------
OP_BOX, OP_PUSHPT, OP_POPPT, OP_ZERO = 0, 1, 2, 3

#: Kinds of instructions (``KIND[op]``).
K_PRIMITIVE, K_OPERATOR, K_WARP, K_PAINT, K_BOX, K_PUSHPT, K_POPPT, K_ZERO = range(8)
_KIND_OF = {"primitive": K_PRIMITIVE, "operator": K_OPERATOR, "warp": K_WARP, "paint": K_PAINT}

freeze_registry("blobtree.engine.dispatch")

#: Node types with kernels, and their opcodes.
TYPES: list[type[Node]] = [cls for cls in REGISTRY.values() if cls.KIND in _KIND_OF]
OPCODE: dict[type[Node], int] = {cls: 4 + i for i, cls in enumerate(TYPES)}
NAMES = ["BOX", "PUSHPT", "POPPT", "ZERO"] + [cls.TYPE for cls in TYPES]

KIND = np.array([K_BOX, K_PUSHPT, K_POPPT, K_ZERO] + [_KIND_OF[c.KIND] for c in TYPES],
                dtype=np.int64)


DROP, KEEP, KILL = (ZERO_RULES.index(r) for r in ("drop", "keep", "kill"))
#: What a zero first / later child does to an operator (paints die with their child).
ZERO_FIRST = np.array([DROP] * 4 + [ZERO_RULES.index(
    getattr(c, "ZERO_FIRST", "kill")) for c in TYPES], dtype=np.int64)
ZERO_REST = np.array([DROP] * 4 + [ZERO_RULES.index(
    getattr(c, "ZERO_REST", "kill")) for c in TYPES], dtype=np.int64)
SUM, MAX = (LIPSCHITZ_RULES.index(r) for r in ("sum", "max"))
LIPSCHITZ = np.array([SUM] * 4 + [LIPSCHITZ_RULES.index(getattr(c, "LIPSCHITZ", "sum"))
                                  for c in TYPES], dtype=np.int64)
#: Value-stack rows an operator needs beyond its children.
STACK = np.array([0] * 4 + [getattr(c, "STACK", 0) for c in TYPES], dtype=np.int64)


def opcode(node: Node) -> int:
    """The opcode of a node's type; TypeError for a type the engine has no kernels for."""
    op = OPCODE.get(type(node))
    if op is None:
        raise TypeError(f"no kernels for node type {type(node).__name__} ({node.TYPE!r}); "
                        f"the engine knows {sorted(c.TYPE for c in TYPES)}")
    return op


# ----- dispatch chains ----------------------------------------------------------------------
def _name(f: Callable) -> str:
    py = getattr(f, "py_func", f)
    return f"{py.__module__}.{py.__qualname__}"


def _case(op: int, fn: Callable, rest: Callable, tag: str):
    @kernel(tag=tag)
    def case(code, *args):
        if code == op:
            return fn(*args)
        return rest(code, *args)

    return case


def _chain(name: str, cases: list[tuple[int, Callable]], miss: Callable):
    """A dispatcher f(op, *args) calling the kernel of ``op`` among ``cases``, else ``miss``."""
    d = miss
    for i in range(len(cases) - 1, -1, -1):
        tag = name + ":" + ",".join(f"{op}={_name(fn)}" for op, fn in cases[i:])
        d = _case(cases[i][0], cases[i][1], d, tag)
    return d


@kernel
def _miss4(code, *args):
    return math.nan, 0.0, 0.0, 0.0


@kernel
def _miss2(code, *args):
    return math.nan, math.nan


@kernel
def _miss1(code, *args):
    return math.nan


@kernel
def _miss3(code, *args):
    return math.nan, math.nan, math.nan


@kernel
def _miss12(code, *args):
    n = math.nan
    return n, n, n, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0


@kernel
def _miss_none(code, *args):
    return


@kernel
def _no_along(p, o, ox, oy, oz, dx, dy, dz, length):
    """No directional bound: the caller uses the box bound."""
    return -1.0


def _distance_lipschitz(s_fn: Callable, tag: str):
    """The default box bound of a primitive with a constant field radius: the distance-aware
    bound around the box centre (``kmath.distance_lipschitz``)."""

    @kernel(tag=tag)
    def lipschitz(p, o, lip, cx, cy, cz, hx, hy, hz):
        s = s_fn(p, o, cx, cy, cz)[0]
        radius = p[o + RADIUS]
        return kmath.distance_lipschitz(lip, int(p[o + FALLOFF]), radius, math.sqrt(s) * radius,
                                        math.sqrt(hx * hx + hy * hy + hz * hz))

    return lipschitz


def _prim_rows(s_fn: Callable, tag: str):
    """A primitive's field at the nb points of a batch (rows of ``engine.batch``): one loop with
    the primitive's maths compiled in, vectorisable."""

    @kernel(tag=tag)
    def rows(fid, p, o, pts, pp, vs, sp, nb):
        for k in range(nb):
            qx, qy, qz = kmath.map_point(p, o, pts[pp, 0, k], pts[pp, 1, k], pts[pp, 2, k])
            s = s_fn(p, o, qx, qy, qz)[0]
            f = kmath.fo(fid, min(s, 1.0))
            vs[sp, k] = f if s < 1.0 else 0.0

    return rows


def _rows_from_combine(combine: Callable, tag: str):
    """The default field-only batch kernel of an operator: its ``combine`` point by point."""

    @kernel(tag=tag)
    def rows(vs, b, k, p, o, nb, tmp):
        for m in range(nb):
            for j in range(k):
                tmp[j, 0] = vs[b + j, m]
            combine(tmp, 0, k, p, o, 0)
            vs[b, m] = tmp[0, 0]

    return rows


def _rows_adapter(rows_fn: Callable, tag: str):
    @kernel(tag=tag)
    def rows(vs, b, k, p, o, nb, tmp):
        rows_fn(vs, b, k, p, o, nb)

    return rows


def _of(kind: str) -> list[type[Node]]:
    return [c for c in TYPES if c.KIND == kind]


_PRIMS = _of("primitive")
_OPS = _of("operator")

#: s, ds/dq of a primitive: prim_s(op, p, o, qx, qy, qz)
prim_s = _chain("prim_s", [(OPCODE[c], c.KERNELS.s) for c in _PRIMS], _miss4)
#: (u, v) of a primitive: prim_uv(op, p, o, qx, qy, qz)
prim_uv = _chain("prim_uv", [(OPCODE[c], c.KERNELS.uv) for c in _PRIMS], _miss2)
#: bound on |grad f| over a local box: prim_lipschitz(op, p, o, lip, cx, cy, cz, hx, hy, hz)
prim_lipschitz = _chain("prim_lipschitz", [
    (OPCODE[c], c.KERNELS.lipschitz or _distance_lipschitz(c.KERNELS.s, f"lip:{c.TYPE}"))
    for c in _PRIMS], _miss1)
#: bound on |df/dt| along a frame segment, or -1: prim_along(op, p, o, ox.., dx.., length)
prim_along = _chain("prim_along", [(OPCODE[c], c.KERNELS.along or _no_along)
                                   for c in _PRIMS], _miss1)
#: field of a primitive over batch rows: prim_rows(op, fid, p, o, pts, pp, vs, sp, nb)
prim_rows = _chain("prim_rows", [(OPCODE[c], _prim_rows(c.KERNELS.s, f"prim_rows:{c.TYPE}"))
                                 for c in _PRIMS], _miss_none)
#: operator over the value stack: combine(op, vs, b, k, p, o, mode)
combine = _chain("combine", [(OPCODE[c], c.KERNELS.combine) for c in _OPS], _miss_none)
#: operator over batch rows: combine_rows(op, vs, b, k, p, o, nb, tmp)
combine_rows = _chain("combine_rows", [
    (OPCODE[c], _rows_adapter(c.KERNELS.rows, f"rows:{c.TYPE}") if c.KERNELS.rows
     else _rows_from_combine(c.KERNELS.combine, f"rows_from:{c.TYPE}")) for c in _OPS],
    _miss_none)
#: canonical warp map and Jacobian: warp_map(op, p, o, X, Y, Z)
warp_map = _chain("warp_map", [(OPCODE[c], c.KERNELS.map) for c in _of("warp")], _miss12)
#: colour of a paint node: paint(op, p, o, px, py, pz, gx, gy, gz)
paint = _chain("paint", [(OPCODE[c], c.KERNELS.paint) for c in _of("paint")], _miss3)
