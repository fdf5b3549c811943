"""The engine's view of the node registry: opcodes, their kinds and rules, and one compiled
dispatcher per kind of kernel, all derived from ``nodes.REGISTRY``.

Every registered node type with kernels gets an opcode, primitives first, then operators, warps
and paint nodes (so each kind is a range of opcodes), then come the program's own instructions
(BOX, PUSHPT, POPPT, ZERO).  Programs are never stored, so the numbers need not be stable.

Each dispatcher is one compiled function generated from the registry,
``if op == 3: return k3_s(...)  if op == 4: ...`` (:data:`SOURCE` holds the generated text).  Its
last line returns NaN: the compiler refuses any node type without kernels, so it is never
reached, and never runs another node's maths.
"""

from __future__ import annotations

import math

import numpy as np

from ..nodes import REGISTRY, kernel_math
from ..nodes.kernels import LIPSCHITZ_RULES, ZERO_RULES
from ..nodes.layout import FALLOFF, RADIUS
from ..nodes.node import Node, freeze_registry
from ..runtime.jit import kernel

#: Kinds of instructions, in opcode order.
K_PRIMITIVE, K_OPERATOR, K_WARP, K_PAINT, K_BOX, K_PUSHPT, K_POPPT, K_ZERO = range(8)
_KIND_OF = {"primitive": K_PRIMITIVE, "operator": K_OPERATOR, "warp": K_WARP, "paint": K_PAINT}

freeze_registry("blobtree.engine.dispatch")

#: Node types with kernels, grouped by kind (so a kind is a range of opcodes), and their opcodes.
TYPES: list[type[Node]] = sorted((c for c in REGISTRY.values() if c.KIND in _KIND_OF),
                                 key=lambda c: _KIND_OF[c.KIND])
OPCODE: dict[type[Node], int] = {cls: i for i, cls in enumerate(TYPES)}
_ENDS = [sum(1 for c in TYPES if _KIND_OF[c.KIND] <= k) for k in range(4)]
#: Ends of the opcode ranges of primitives, operators, warps and paint nodes.
PRIMITIVE_END, OPERATOR_END, WARP_END, PAINT_END = _ENDS
# ----- the program's own instructions, after the node types' --------------------------------
OP_BOX, OP_PUSHPT, OP_POPPT, OP_ZERO = range(PAINT_END, PAINT_END + 4)

#: The kind of each opcode (for Python; kernels call :func:`kind_of`).
KIND = np.array([_KIND_OF[c.KIND] for c in TYPES] + [K_BOX, K_PUSHPT, K_POPPT, K_ZERO],
                dtype=np.int64)


@kernel
def kind_of(op):
    """The kind of an opcode: comparisons against the ranges, which the compiler folds into the
    branches on the kind."""
    if op < PRIMITIVE_END:
        return K_PRIMITIVE
    if op < OPERATOR_END:
        return K_OPERATOR
    if op < WARP_END:
        return K_WARP
    if op < PAINT_END:
        return K_PAINT
    return K_BOX + op - PAINT_END


def _table(attr: str, rules: tuple[str, ...], default: str, structural: str) -> np.ndarray:
    """Per opcode, the index in ``rules`` of a type's declared rule (``structural`` for the
    program's own instructions)."""
    return np.array([rules.index(getattr(c, attr, default)) for c in TYPES]
                    + [rules.index(structural)] * 4, dtype=np.int64)


DROP, KEEP, KILL = (ZERO_RULES.index(r) for r in ("drop", "keep", "kill"))
#: What a zero first / later child does to an operator (paints die with their child).
ZERO_FIRST = _table("ZERO_FIRST", ZERO_RULES, "kill", "drop")
ZERO_REST = _table("ZERO_REST", ZERO_RULES, "kill", "drop")
SUM, MAX, SCALED, NORM = (LIPSCHITZ_RULES.index(r) for r in ("sum", "max", "scaled", "norm"))
LIPSCHITZ = _table("LIPSCHITZ", LIPSCHITZ_RULES, "sum", "sum")
#: Whether an opcode's type has a value-aware ``bound`` kernel (a CSG operator's).
VALUE_BOUND = np.array([c.KIND == "operator" and c.KERNELS.bound is not None for c in TYPES]
                       + [False] * 4)
#: How an operator's field moves with its first / each later child (``Operator.MONOTONE``).
MONOTONE_FIRST, MONOTONE_REST = (
    np.array([getattr(c, "MONOTONE", (0, 0))[j] for c in TYPES] + [0] * 4, dtype=np.int64)
    for j in (0, 1))
#: Value-stack rows an operator needs beyond its children.
STACK = np.array([getattr(c, "STACK", 0) for c in TYPES] + [0] * 4, dtype=np.int64)


def opcode(node: Node) -> int:
    """The opcode of a node's type; TypeError for a type the engine has no kernels for."""
    op = OPCODE.get(type(node))
    if op is None:
        raise TypeError(f"no kernels for node type {type(node).__name__} ({node.TYPE!r}); "
                        f"the engine knows {sorted(c.TYPE for c in TYPES)}")
    return op


# ----- generated dispatchers ----------------------------------------------------------------
def _of(kind: str) -> list[type[Node]]:
    return [c for c in TYPES if c.KIND == kind]


def _dispatcher(name: str, args: str, kind: str, case: str, miss: str) -> str:
    """Source of ``name(op, args)``: per type of ``kind``, ``if op == OP: <case>``, where the
    case text names the type's kernels ``K.<kernel>`` (or None: its line is ``miss``)."""
    lines = [f"def {name}(op, {args}):"]
    for cls in _of(kind):
        k = f"k{OPCODE[cls]}_"
        text = case(cls) if callable(case) else case
        body = text.replace("K.", k) if text is not None else miss
        lines.append(f"    if op == {OPCODE[cls]}:")
        lines.extend("        " + line for line in body.splitlines())
    lines.append(f"    {miss}")
    return "\n".join(lines) + "\n"


#: Kernels compiled into their dispatcher (the rest are called): a primitive's field (the batch
#: loops drop the gradient they do not use; one copy serves them and the point walk), the bounds
#: the ray tracer asks for at every step, and the operators, whose work is small next to a call.
INLINE_KERNELS = ("s", "along", "lipschitz", "rise", "span", "combine", "rows", "bound", "map",
                  "frame", "apply", "stretch")
#: Dispatchers compiled into their one caller (``warp_map``'s, ``point.apply_warp``, is itself
#: compiled into its callers).
INLINE_DISPATCHERS = ("prim_s", "prim_along", "prim_lipschitz", "prim_rise", "prim_span",
                      "combine", "combine_rows", "op_bound", "warp_map")


def _inlined(fn):
    """``fn`` compiled on its own, once, and inlined by LLVM into each caller (numba's own
    inlining would type its body again at every call site)."""
    return kernel(fn, forceinline=True, tag="inline")


def _kernels() -> dict[str, object]:
    """Every type's kernels by their name in the generated source, k<opcode>_<kernel>."""
    out: dict[str, object] = {}
    for cls in TYPES:
        for field, fn in vars(cls.KERNELS).items():
            if fn is not None:
                out[f"k{OPCODE[cls]}_{field}"] = (_inlined(fn.py_func)
                                                  if field in INLINE_KERNELS else fn)
    return out


_PRIM = "p, o, qx, qy, qz"
_DEFAULT_LIPSCHITZ = ("s = K.s(p, o, cx, cy, cz)[0]\n"
                      "return distance_bound(p, o, lip, s, hx, hy, hz, r)")
_DEFAULT_SPAN = ("s = K.s(p, o, cx, cy, cz)[0]\n"
                 "return distance_span(p, o, s, hx, hy, hz, r)")
_ROWS = """a = affine(p, o)
for k in range(nb):
    qx, qy, qz = map_with(a, pts[pp, 0, k], pts[pp, 1, k], pts[pp, 2, k])
    s = K.s(p, o, qx, qy, qz)[0]
    vs[sp, k] = fo(fid, min(s, 1.0)) if s < 1.0 else 0.0
return"""
_WARP_ROWS = """for m in range(nb):
    X, Y, Z = to_canonical(p, o, pts[pp, 0, m], pts[pp, 1, m], pts[pp, 2, m])
    q = K.map(p, o, X, Y, Z)
    pts[pp, 0, m], pts[pp, 1, m], pts[pp, 2, m] = from_canonical(p, o, q[0], q[1], q[2])
return"""
_WARP_ROWS_FRAMED = """w = K.frame(p, o)
pm = permutation(p, o)
for m in range(nb):
    X, Y, Z = to_canonical_with(pm, pts[pp, 0, m], pts[pp, 1, m], pts[pp, 2, m])
    q = K.apply(w, X, Y, Z)
    pts[pp, 0, m], pts[pp, 1, m], pts[pp, 2, m] = from_canonical_with(pm, q[0], q[1], q[2])
return"""
_ROWS_FROM_COMBINE = """for m in range(nb):
    for j in range(k):
        tmp[j, 0] = vs[b + j, m]
    K.combine(tmp, 0, k, p, o, 0)
    vs[b, m] = tmp[0, 0]
return"""

SOURCE = "".join([
    _dispatcher("prim_s", _PRIM, "primitive", f"return K.s({_PRIM})",
                "return NAN, 0.0, 0.0, 0.0"),
    _dispatcher("prim_uv", _PRIM, "primitive", f"return K.uv({_PRIM})", "return NAN, NAN"),
    _dispatcher("prim_lipschitz", "p, o, lip, cx, cy, cz, hx, hy, hz, r", "primitive",
                lambda c: ("return K.lipschitz(p, o, lip, cx, cy, cz, hx, hy, hz, r)"
                           if c.KERNELS.lipschitz else _DEFAULT_LIPSCHITZ), "return NAN"),
    _dispatcher("prim_along", "p, o, ox, oy, oz, dx, dy, dz, length", "primitive",
                lambda c: ("return K.along(p, o, ox, oy, oz, dx, dy, dz, length)"
                           if c.KERNELS.along else "return -1.0"), "return NAN"),
    _dispatcher("prim_rise", "p, o, box, cone", "primitive",
                lambda c: ("return K.rise(p, o, box[0], box[1], box[2], box[3], box[4], "
                           "box[5], cone[0], cone[1], cone[2], cone[3])" if c.KERNELS.rise
                           else "return -1.0"), "return NAN"),
    _dispatcher("prim_span", "p, o, cx, cy, cz, hx, hy, hz, r", "primitive",
                lambda c: ("return K.span(p, o, cx, cy, cz, hx, hy, hz, r)" if c.KERNELS.span
                           else "return 0.0, INF" if c.KERNELS.lipschitz else _DEFAULT_SPAN),
                "return NAN, NAN"),
    _dispatcher("prim_rows", "fid, p, o, pts, pp, vs, sp, nb", "primitive", _ROWS, "return"),
    _dispatcher("combine", "vs, b, k, p, o, mode", "operator",
                "K.combine(vs, b, k, p, o, mode)\nreturn", "return"),
    _dispatcher("op_bound", "vs, b, k, p, o, reach", "operator",
                lambda c: ("return K.bound(vs, b, k, p, o, reach)" if c.KERNELS.bound
                           else "return -1.0, 0.0, 0.0"), "return -1.0, 0.0, 0.0"),
    _dispatcher("combine_rows", "vs, b, k, p, o, nb, tmp", "operator",
                lambda c: ("K.rows(vs, b, k, p, o, nb)\nreturn" if c.KERNELS.rows
                           else _ROWS_FROM_COMBINE), "return"),
    _dispatcher("warp_map", "p, o, X, Y, Z", "warp", "return K.map(p, o, X, Y, Z)",
                "return NAN, NAN, NAN, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0"),
    _dispatcher("warp_stretch", "p, o, lox, loy, loz, hix, hiy, hiz", "warp",
                lambda c: ("return K.stretch(p, o, lox, loy, loz, hix, hiy, hiz)"
                           if c.KERNELS.stretch else "return INF"), "return INF"),
    _dispatcher("warp_rows", "p, o, pts, pp, nb", "warp",
                lambda c: _WARP_ROWS_FRAMED if c.KERNELS.apply else _WARP_ROWS, "return"),
    _dispatcher("paint", "p, o, px, py, pz, gx, gy, gz", "paint",
                "return K.paint(p, o, px, py, pz, gx, gy, gz)", "return NAN, NAN, NAN"),
])


@kernel(inline="always")
def distance_span(p, o, s, hx, hy, hz, r):
    """The default span of a primitive with a constant field radius R: least and most of r / R
    over a region around a centre with s = d^2 / R^2 (the distance to the skeleton moves by at
    most the region's radius), within the box of half extents h and the ball of radius r."""
    d = math.sqrt(s)
    rho = min(math.sqrt(hx * hx + hy * hy + hz * hz), r) / p[o + RADIUS]
    return max(d - rho, 0.0), d + rho


@kernel
def distance_bound(p, o, lip, s, hx, hy, hz, r):
    """The default box bound of a primitive with a constant field radius R: the distance-aware
    bound (segment tracing's, Galin et al. 2020), the falloff's steepest slope over the
    region's distances (:func:`distance_span`), scaled from the global bound ``lip``."""
    rmin, rmax = distance_span(p, o, s, hx, hy, hz, r)
    return lip * kernel_math.slope_at(int(p[o + FALLOFF]), rmin, rmax)


def _build() -> dict[str, object]:
    """Compile :data:`SOURCE` as if written in this file: numba caches compiled functions by
    their source file, so the generated dispatchers are cached like any other kernel (and
    ``jit.engine_key`` recompiles them whenever a node type's module changes)."""
    namespace = {"__name__": __name__, "NAN": math.nan, "distance_bound": distance_bound,
                 "distance_span": distance_span, "INF": math.inf,
                 "fo": kernel_math.fo, "affine": kernel_math.affine,
                 "map_with": kernel_math.map_with, "to_canonical": kernel_math.to_canonical,
                 "from_canonical": kernel_math.from_canonical,
                 "permutation": kernel_math.permutation,
                 "to_canonical_with": kernel_math.to_canonical_with,
                 "from_canonical_with": kernel_math.from_canonical_with,
                 **_kernels()}
    exec(compile(SOURCE, __file__, "exec"), namespace)  # noqa: S102 (our own generated code)
    names = ("prim_s", "prim_uv", "prim_lipschitz", "prim_along", "prim_rise", "prim_span",
             "prim_rows", "combine", "op_bound", "combine_rows", "warp_map", "warp_stretch",
             "warp_rows", "paint")
    return {name: (_inlined(namespace[name]) if name in INLINE_DISPATCHERS
                   else kernel(namespace[name]))
            for name in names}


_D = _build()
#: s, ds/dq of a primitive: prim_s(op, p, o, qx, qy, qz)
prim_s = _D["prim_s"]
#: (u, v) of a primitive: prim_uv(op, p, o, qx, qy, qz)
prim_uv = _D["prim_uv"]
#: bound on ``|grad f|`` over a local region (a box and a ball about its centre):
#: prim_lipschitz(op, p, o, lip, cx, cy, cz, hx, hy, hz, r)
prim_lipschitz = _D["prim_lipschitz"]
#: least and most of r / R over a local region (as prim_lipschitz takes it), whose falloffs
#: are the most and least the field can be there: prim_span(op, p, o, cx, cy, cz, hx, hy, hz, r)
prim_span = _D["prim_span"]
#: bound on |df/dt| along a frame segment, or -1: prim_along(op, p, o, ox.., dx.., length)
prim_along = _D["prim_along"]
#: bound on how fast a primitive's field rises in a frame box along a cone of directions, or -1:
#: prim_rise(op, p, o, (lox, loy, loz, hix, hiy, hiz), (dx, dy, dz, spread))
prim_rise = _D["prim_rise"]
#: a warp's query map over the batch's points in place: warp_rows(op, p, o, pts, pp, nb)
warp_rows = _D["warp_rows"]
#: field of a primitive over batch rows: prim_rows(op, fid, p, o, pts, pp, vs, sp, nb)
prim_rows = _D["prim_rows"]
#: operator over the value stack: combine(op, vs, b, k, p, o, mode)
combine = _D["combine"]
#: an operator's value-aware (bound, below, above) over a region, or a bound of -1 where it has
#: none (apply its rule): op_bound(op, vs, b, k, p, o, reach)
op_bound = _D["op_bound"]
#: operator over batch rows: combine_rows(op, vs, b, k, p, o, nb, tmp)
combine_rows = _D["combine_rows"]
#: canonical warp map and Jacobian: warp_map(op, p, o, X, Y, Z)
warp_map = _D["warp_map"]
#: a bound on a warp's query map's Jacobian norm over a canonical box, or inf where the warp has
#: no ``stretch`` kernel: warp_stretch(op, p, o, lox, loy, loz, hix, hiy, hiz)
warp_stretch = _D["warp_stretch"]
#: colour of a paint node: paint(op, p, o, px, py, pz, gx, gy, gz)
paint = _D["paint"]
