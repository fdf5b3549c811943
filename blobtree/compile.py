"""Compile a BlobTree into a flat postfix program for the numba kernels.

Layout (one row per instruction):

* ``code`` int64 (n, 4): opcode, offset into ``params``, skip target, child count;
* ``params`` float64: per-instruction parameters (primitives: the 3x4 frame->local map with all
  enclosing affine transforms folded in, R, falloff id, then the skeleton);
* ``boxes`` float64 (n, 6): the instruction's box in the current frame (world, or the space of the
  nearest enclosing warp); a point outside skips the subtree, which then contributes 0;
* ``lips`` float64 (n,): Lipschitz constants in world units for primitives and warped subtrees.

Affine chains are folded into primitives, so only warps move the point at run time.  Large
blends, super-elliptic blends and unions are regrouped into a bounding-volume hierarchy (they are
associative), so a point meets O(log n) boxes instead of n.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import geometry as geo
from . import kernels as K
from . import nodes as N
from . import specialize as S
from .fields import FALLOFFS

#: Batches at least this large are sorted into cells that run specialised programs.
BINNED_MIN = 20_000
BIN_POINTS = 2_000
BIN_MAX = 32

#: Children per leaf group of the bounding-volume hierarchy built over associative operators.
GROUP = 4

_ASSOCIATIVE = {N.Blend: K.OP_BLEND, N.SuperBlend: K.OP_SUPER, N.Union: K.OP_UNION}
_OTHER_OPS = {N.Intersection: K.OP_INTER, N.Difference: K.OP_DIFF,
              N.ControlledBlend: K.OP_CBLEND}


@dataclass
class Program:
    """A compiled tree: the arrays the kernels run, and batched evaluation from numpy."""

    code: np.ndarray
    params: np.ndarray
    boxes: np.ndarray
    lips: np.ndarray
    depth: int
    bounds: geo.Box
    lipschitz_global: float

    @property
    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(code, params, boxes, lips) for use inside other numba kernels."""
        return self.code, self.params, self.boxes, self.lips

    def __len__(self) -> int:
        return len(self.code)

    def _run(self, P: np.ndarray, mode: int):
        P = np.ascontiguousarray(P, dtype=np.float64)
        n = len(P)
        f = np.empty(n)
        g = np.empty((n, 3)) if mode > 0 else np.empty((0, 3))
        c = np.empty((n, 3)) if mode > 1 else np.empty((0, 3))
        lo, hi = self.bounds
        if n >= BINNED_MIN and np.all(np.isfinite(lo)) and np.all(hi > lo):
            # about BIN_POINTS points per cell, at most BIN_MAX cells a side
            side = int(np.clip(round((n / BIN_POINTS) ** (1 / 3)), 1, BIN_MAX))
            dims = np.full(3, side, dtype=np.int64)
            S.eval_binned(self.code, self.params, self.boxes, self.lips, P, mode, self.depth,
                          lo, hi, dims, f, g, c)
        else:
            K.eval_batch(self.code, self.params, self.boxes, P, mode, self.depth, f, g, c)
        return f, g, c

    def field(self, P: np.ndarray) -> np.ndarray:
        """Field values (N,) at (N, 3) points."""
        return self._run(P, 0)[0]

    def gradient(self, P: np.ndarray) -> np.ndarray:
        """Analytic gradients (N, 3)."""
        return self._run(P, 1)[1]

    def albedo(self, P: np.ndarray) -> np.ndarray:
        """Colours (N, 3) in [0, 1]."""
        return self._run(P, 2)[2]

    def evaluate(self, P: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(field, gradient, colour) in one pass."""
        return self._run(P, 2)

    def lipschitz(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """Per box (M, 3) corners: a bound on |grad f| valid over the whole box."""
        lo = np.ascontiguousarray(lo, dtype=np.float64).reshape(-1, 3)
        hi = np.ascontiguousarray(hi, dtype=np.float64).reshape(-1, 3)
        out = np.empty(len(lo))
        K.lipschitz_batch(self.code, self.params, self.boxes, self.lips, lo, hi, self.depth, out)
        return out


class _Emitter:
    def __init__(self) -> None:
        self.code: list[list[int]] = []
        self.params: list[float] = []
        self.boxes: list[np.ndarray] = []
        self.lips: list[float] = []

    def add(self, op: int, params=(), box: geo.Box | None = None, count: int = 0,
            lip: float = 0.0) -> int:
        i = len(self.code)
        self.code.append([op, len(self.params), i + 1, count])
        self.params.extend(float(v) for v in params)
        self.boxes.append(_box6(box))
        self.lips.append(lip)
        return i

    def close(self, i: int, box: geo.Box) -> None:
        """Set instruction i's skip target to the next instruction, and its box."""
        self.code[i][2] = len(self.code)
        self.boxes[i] = _box6(box)

    # ---------------------------------------------------------------------------------------
    def emit(self, node: N.Node, M: np.ndarray) -> geo.Box:
        """Emit ``node`` whose coordinates map to the current frame by M; return its frame box."""
        if isinstance(node, N.Affine):
            return self.emit(node.child, geo.compose(M, node.matrix))
        if isinstance(node, N.Primitive):
            return self.primitive(node, M)
        if isinstance(node, N.Color):
            head = self.add(K.OP_BOX)
            box = self.emit(node.child, M)
            self.add(K.OP_COLOR, node.rgb)
            self.close(head, box)
            return box
        if isinstance(node, N.Warp):
            return self.warp(node, M)
        head = self.add(K.OP_BOX)
        if type(node) in _ASSOCIATIVE:
            box = self.group(_ASSOCIATIVE[type(node)], node, list(node.children), M)
        else:
            box = node.combine_boxes([self.emit(c, M) for c in node.children])
            self.add(_OTHER_OPS[type(node)], _op_params(node), count=len(node.children))
        self.close(head, box)
        return box

    def group(self, op: int, node: N.Node, children: list[N.Node], M: np.ndarray) -> geo.Box:
        """Children of an associative operator, as a hierarchy of boxed groups."""
        extra = _op_params(node)
        if len(children) <= GROUP:
            boxes = [self.emit(c, M) for c in children]
            self.add(op, extra, count=len(children))
            return geo.box_union(boxes)
        centres = np.array([0.5 * (b[0] + b[1]) for b in (c._box(M) for c in children)])
        centres = np.nan_to_num(centres, nan=0.0, posinf=0.0, neginf=0.0)
        axis = int(np.argmax(centres.max(axis=0) - centres.min(axis=0)))
        order = np.argsort(centres[:, axis], kind="stable")
        half = len(children) // 2
        boxes = []
        for part in (order[:half], order[half:]):
            head = self.add(K.OP_BOX)
            box = self.group(op, node, [children[i] for i in sorted(part)], M)
            self.close(head, box)
            boxes.append(box)
        self.add(op, extra, count=2)
        return geo.box_union(boxes)

    def primitive(self, node: N.Primitive, M: np.ndarray) -> geo.Box:
        inv = geo.invert(M)
        box = node._box(M)
        head = list(inv.reshape(-1)) + [node.radius, FALLOFFS[node.falloff]]
        if isinstance(node, N.Point):
            op, geom = K.OP_POINT, node.center
        elif isinstance(node, N.Cone):
            op, geom = K.OP_CONE, [*node.a, *node.b, node.radius_a, node.radius_b]
        elif isinstance(node, N.Torus | N.Disc):
            op = K.OP_TORUS if isinstance(node, N.Torus) else K.OP_DISC
            geom = [node.ring, *node.center]
        elif isinstance(node, N.Cylinder):
            op, geom = K.OP_CYLINDER, [*node.a, *node.b, node.cylinder_radius]
        else:
            raise TypeError(f"no kernel for primitive {type(node).__name__}")
        lip = node.lipschitz() * geo.spectral_norm(inv[:, :3])
        self.add(op, head + list(geom), box, lip=lip)
        return box

    def warp(self, node: N.Warp, M: np.ndarray) -> geo.Box:
        inv = geo.invert(M)
        box = node._box(M)
        push = self.add(K.OP_PUSHPT, inv.reshape(-1), box,
                        lip=node.lipschitz() * geo.spectral_norm(inv[:, :3]))
        if isinstance(node, N.Bend):
            op, canon = K.OP_BEND, [node.k, node.length]
        elif isinstance(node, N.Twist):
            op, canon = K.OP_TWIST, [node.k]
        else:
            op, canon = K.OP_TAPER, [node.rate, *node.t_range]
        w = self.add(op, list(_canonical_perm(node).reshape(-1)) + canon, node.own_box)
        self.emit(node.child, geo.IDENTITY)
        self.code[w][2] = len(self.code)  # a miss jumps to POPPT
        self.add(K.OP_POPPT)
        self.code[push][2] = len(self.code)
        return box

    def program(self, root: N.Node) -> Program:
        code = np.array(self.code, dtype=np.int64).reshape(-1, 4)
        depth = _stack_depth(code)
        return Program(
            code=code,
            params=np.array(self.params, dtype=np.float64),
            boxes=np.array(self.boxes, dtype=np.float64).reshape(-1, 6),
            lips=np.array(self.lips, dtype=np.float64),
            depth=depth,
            bounds=root.bounds(),
            lipschitz_global=root.lipschitz(),
        )


def _box6(box: geo.Box | None) -> np.ndarray:
    if box is None:
        return np.array([-np.inf] * 3 + [np.inf] * 3)
    return np.concatenate(box)


def _op_params(node: N.Node) -> list[float]:
    if isinstance(node, N.SuperBlend):
        return [node.n]
    if isinstance(node, N.ControlledBlend):
        flat = [v for pair in node.pairs for v in pair]
        return [len(node.pairs), *flat, len(node.singles), *node.singles]
    return []


def _canonical_perm(node: N.Warp) -> np.ndarray:
    """Signed permutation from frame axes to the kernel's canonical warp axes."""
    if isinstance(node, N.Bend):
        return node._perm
    a, i, j = node.index
    m = np.zeros((3, 3))
    m[0, i] = m[1, j] = m[2, a] = 1.0
    return m


def _stack_depth(code: np.ndarray) -> int:
    """Deepest value or point stack a run can reach (+1 spare row)."""
    sp = pp = deepest = 0
    for op, _, _, count in code:
        if op <= K.OP_CYLINDER:
            sp += 1
        elif op == K.OP_PUSHPT:
            pp += 1
        elif op == K.OP_POPPT:
            pp -= 1
        elif op in (K.OP_BLEND, K.OP_SUPER, K.OP_UNION, K.OP_INTER, K.OP_DIFF, K.OP_CBLEND):
            sp -= count - 1
        deepest = max(deepest, sp, pp)
    return deepest + 2


def compile_tree(tree: N.Node) -> Program:
    """Flatten ``tree`` into a :class:`Program`."""
    if not isinstance(tree, N.Node):
        raise ValueError(f"tree must be a BlobTree node, got {type(tree).__name__}")
    em = _Emitter()
    em.emit(tree, geo.IDENTITY)
    return em.program(tree)
