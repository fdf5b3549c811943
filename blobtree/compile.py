"""Compile a BlobTree into a flat postfix program for the numba kernels.

Layout (one row per instruction):

* ``code`` int64 (n, 4): opcode, offset into ``params``, skip target, child count (for a
  primitive: the params offset of the texture that paints it, or -1);
* ``params`` float64: per-instruction parameters (primitives: the 3x4 frame->local map with all
  enclosing affine transforms folded in, R, falloff id, then the skeleton);
* ``boxes`` float64 (n, 6): the instruction's box in the current frame (world, or the space of the
  nearest enclosing warp); a point outside skips the subtree, which then contributes 0;
* ``lips`` float64 (n,): Lipschitz constants in the current frame for primitives and warped
  subtrees (PUSHPT); for a warp its stretch (a bound on its Jacobian's norm); for POPPT the
  factor from the warp's child frame to the outer frame.

Affine chains are folded into primitives, so only warps move the point at run time.  Large
blends, super-elliptic blends and unions are regrouped into a bounding-volume hierarchy (they are
associative), so a point meets O(log n) boxes instead of n.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numba
import numpy as np

from . import batch as B
from . import geometry as geo
from . import kernels as K
from . import nodes as N
from . import specialize as S
from . import texture as tex
from .fields import FALLOFFS

#: Batches at least this large run through the grid of specialised programs.
GRID_MIN_POINTS = 20_000
GRID_CELLS_PER_PRIMITIVE = 64
GRID_MIN_CELLS = 4_096
GRID_MAX_CELLS = 64**3
GRID_MAX_INSTRUCTIONS = 4_000_000

#: Children per leaf group of the bounding-volume hierarchy built over associative operators.
GROUP = 4

_ASSOCIATIVE = {N.Blend: K.OP_BLEND, N.SuperBlend: K.OP_SUPER, N.Union: K.OP_UNION}
_OTHER_OPS = {N.Intersection: K.OP_INTER, N.Difference: K.OP_DIFF,
              N.ControlledBlend: K.OP_CBLEND}


@dataclass
class Grid:
    """Per-cell specialised programs (see specialize.py): cell c runs rows start[c]:start[c+1]."""

    start: np.ndarray
    code: np.ndarray
    boxes: np.ndarray
    lips: np.ndarray
    lo: np.ndarray
    size: np.ndarray
    dims: np.ndarray

    @property
    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(start, code, boxes) for ``specialize.eval_point_grid``."""
        return self.start, self.code, self.boxes

    @property
    def frame(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(lo, size, dims) of the grid."""
        return self.lo, self.size, self.dims


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
        grid = self.grid if n >= GRID_MIN_POINTS else None
        if grid is not None and mode == 0:
            B.field_sorted(grid, self.params, self.depth, P, f, numba.get_num_threads())
        elif grid is not None:
            S.eval_grid_batch(*grid.arrays, self.params, *grid.frame, P, mode, self.depth,
                              f, g, c)
        else:
            K.eval_batch(self.code, self.params, self.boxes, P, mode, self.depth, f, g, c)
        return f, g, c

    @cached_property
    def grid(self) -> Grid | None:
        """The program specialised to each cell of a grid over the bounds (built on first use),
        or None for an empty or unbounded tree."""
        lo, hi = self.bounds
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi > lo)):
            return None
        nprim = int(np.sum(self.code[:, 0] <= K.OP_CYLINDER))
        cells = int(np.clip(GRID_CELLS_PER_PRIMITIVE * nprim, GRID_MIN_CELLS, GRID_MAX_CELLS))
        while True:
            ext = hi - lo
            dims = np.maximum(1, np.round(ext * (cells / np.prod(ext)) ** (1 / 3))).astype(
                np.int64)
            size = ext / dims
            start, gc, gb, gl = S.build_grid(self.code, self.boxes, self.lips, lo, size, dims,
                                             1e-9 * float(ext.max()))
            if len(gc) <= GRID_MAX_INSTRUCTIONS or cells <= GRID_MIN_CELLS:
                return Grid(start, gc, gb, gl, lo.copy(), size, dims)
            cells //= 4

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
        self.textures: dict[tuple[str, str], int] = {}

    def data(self, values) -> int:
        """Append raw parameter data (no instruction); return its offset."""
        offset = len(self.params)
        self.params.extend(float(v) for v in values)
        return offset

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
    def emit(self, node: N.Node, M: np.ndarray, look: int = -1) -> geo.Box:
        """Emit ``node`` whose coordinates map to the current frame by M; return its frame box.
        ``look``: params offset of the field-interpolated texture painting primitives, or -1."""
        if isinstance(node, N.Affine):
            return self.emit(node.child, geo.compose(M, node.matrix), look)
        if isinstance(node, N.Primitive):
            return self.primitive(node, M, look)
        if isinstance(node, N.Color | N.Texture):
            return self.paint(node, M, look)
        if isinstance(node, N.Warp):
            return self.warp(node, M, look)
        head = self.add(K.OP_BOX)
        if type(node) in _ASSOCIATIVE:
            box = self.group(_ASSOCIATIVE[type(node)], node, list(node.children), M, look)
        else:
            box = node.combine_boxes([self.emit(c, M, look) for c in node.children])
            self.add(_OTHER_OPS[type(node)], _op_params(node), count=len(node.children))
        self.close(head, box)
        return box

    def paint(self, node: N.Color | N.Texture, M: np.ndarray, look: int) -> geo.Box:
        """Colour nodes and textures (see texture.py for the two methods)."""
        if isinstance(node, N.Texture) and node.mapping == "primitive":
            return self.emit(node.child, M, self.texture_block(node))
        head = self.add(K.OP_BOX)
        box = self.emit(node.child, M, look)
        if isinstance(node, N.Color):
            self.add(K.OP_COLOR, node.rgb)
        else:
            ms = node.mapping
            sp = ms.spiral
            inv = geo.invert(M)
            self.add(K.OP_TEXBOUND, [
                *inv.reshape(-1), *M[:, :3].T.reshape(-1),
                sp.r0, sp.rho, 1.0 / np.tan(np.radians(sp.beta)), sp.d_over_r, ms.theta_max,
                ms.u_period, ms.radius_factor, ms.gradient_weight, ms.step, ms.max_steps,
                self.texture_block(node)])
        self.close(head, box)
        return box

    def texture_block(self, node: N.Texture) -> int:
        """The texture image in params as [w, h, wrap, rgb rows in [0, 1]] (once per image)."""
        key = (node.digest, node.wrap)
        if key not in self.textures:
            h, w = node.image.shape[:2]
            self.textures[key] = self.data(
                [w, h, tex.WRAPS[node.wrap], *(node.image.reshape(-1) / 255.0)])
        return self.textures[key]

    def group(self, op: int, node: N.Node, children: list[N.Node], M: np.ndarray,
              look: int) -> geo.Box:
        """Children of an associative operator, as a hierarchy of boxed groups."""
        extra = _op_params(node)
        if len(children) <= GROUP:
            boxes = [self.emit(c, M, look) for c in children]
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
            box = self.group(op, node, [children[i] for i in sorted(part)], M, look)
            self.close(head, box)
            boxes.append(box)
        self.add(op, extra, count=2)
        return geo.box_union(boxes)

    def primitive(self, node: N.Primitive, M: np.ndarray, look: int) -> geo.Box:
        inv = geo.invert(M)
        box = node._box(M)
        head = list(inv.reshape(-1)) + [node.radius, FALLOFFS[node.falloff]]
        if isinstance(node, N.Point):
            op, geom = K.OP_POINT, node.center
        elif isinstance(node, N.Cone):
            op, geom = K.OP_CONE, [*node.a, *node.b, node.radius_a, node.radius_b,
                                   *np.concatenate(tex.perpendicular_frame(node.b - node.a))]
        elif isinstance(node, N.Torus | N.Disc):
            op = K.OP_TORUS if isinstance(node, N.Torus) else K.OP_DISC
            geom = [node.ring, *node.center]
        elif isinstance(node, N.Cylinder):
            op, geom = K.OP_CYLINDER, [*node.a, *node.b, node.cylinder_radius,
                                       *np.concatenate(tex.perpendicular_frame(node.b - node.a))]
        else:
            raise TypeError(f"no kernel for primitive {type(node).__name__}")
        lip = node.lipschitz() * geo.spectral_norm(inv[:, :3])
        self.add(op, head + list(geom), box, count=look, lip=lip)
        return box

    def warp(self, node: N.Warp, M: np.ndarray, look: int) -> geo.Box:
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
        w = self.add(op, list(_canonical_perm(node).reshape(-1)) + canon, node.own_box,
                     lip=node.stretch)
        self.emit(node.child, geo.IDENTITY, look)
        self.code[w][2] = len(self.code)  # a miss jumps to POPPT
        # POPPT's lip: the factor from the warp's child frame to the outer frame
        self.add(K.OP_POPPT, lip=node.stretch * geo.spectral_norm(inv[:, :3]))
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
