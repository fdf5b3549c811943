"""Compile a BlobTree into a flat postfix program for the numba kernels.

Layout (one row per instruction; docs/engine.md has the details):

* ``code`` int64 (n, 4): opcode (``dispatch``), offset into ``params``, skip target, child count
  (for a primitive: the params offset of the texture that paints it, or -1);
* ``params`` float64: per-instruction parameters (primitives: the 3x4 frame->local map with all
  enclosing affine transforms folded in, R, falloff id, the map's norm, then the type's own
  ``LAYOUT``; PUSHPT the 3x4 map into the warp's frame and its norm; operators
  their ``op_params``; warps a signed permutation and their ``LAYOUT``; paints their ``pack``);
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
from functools import cached_property, partial

import numpy as np

from .. import geometry as geo
from ..fields import FALLOFFS
from ..nodes.kinds import Operator, Paint, Primitive
from ..nodes.layout import (
    ARG,
    FALLOFF,
    FRAME_NORM,
    GRADIENT,
    MAP_NORM,
    OFFSET,
    OP,
    RADIUS,
    SHADE,
    SKIP,
    VALUE,
)
from ..nodes.node import ISO, REGISTRY, Node, frames_kept
from ..nodes.warp import Warp
from ..runtime.threads import parallel_for
from . import batch as B
from . import bounds as K
from . import point
from . import specialize as S
from .dispatch import (
    K_OPERATOR,
    K_POPPT,
    K_PRIMITIVE,
    K_PUSHPT,
    K_ZERO,
    KIND,
    OP_BOX,
    OP_POPPT,
    OP_PUSHPT,
    STACK,
    opcode,
)
from .specialize import Grid, Regions

#: Batches at least this large run through the grid of specialised programs.
GRID_MIN_POINTS = 20_000
GRID_CELLS_PER_PRIMITIVE = 64
GRID_MIN_CELLS = 4_096
GRID_MAX_CELLS = 64**3
GRID_MAX_INSTRUCTIONS = 4_000_000

#: Children per leaf group of the bounding-volume hierarchy built over associative operators.
GROUP = 4

#: Largest program a tree may expand to (a shared subtree is repeated at each of its places).
MAX_INSTRUCTIONS = 4_000_000


@dataclass
class Program:
    """A compiled tree: the arrays the kernels run, and batched evaluation from numpy."""

    code: np.ndarray
    params: np.ndarray
    boxes: np.ndarray
    lips: np.ndarray
    depth: int
    bounds: geo.Box

    @property
    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(code, params, boxes, lips) for use inside other numba kernels."""
        return self.code, self.params, self.boxes, self.lips

    def __len__(self) -> int:
        return len(self.code)

    @cached_property
    def lipschitz_global(self) -> float:
        """A bound on ``|grad f|`` valid everywhere: the box bound over the tree's bounds (outside
        them the field is 0); computed on first use.  0 for an empty tree."""
        lo, hi = (np.asarray(b, dtype=np.float64) for b in self.bounds)
        if np.any(lo > hi):
            return 0.0
        return float(self.lipschitz(lo[None], hi[None])[0])

    def _run(self, P: np.ndarray, mode: int):
        P = np.ascontiguousarray(P, dtype=np.float64)
        args = self.range_args(P, mode)
        f, g, c = args[-1]
        grid = self.grid if len(P) >= GRID_MIN_POINTS else None
        if grid is not None and mode == VALUE:
            B.eval_sorted(grid, self.params, self.depth, P, f)
        elif grid is not None:
            B.eval_sorted(grid, self.params, self.depth, P, f, g, c)
        else:
            parallel_for(point.eval_range, len(P), *args)
        return f, g, c

    def range_args(self, P: np.ndarray, mode: int) -> tuple:
        """The arguments of ``point.eval_range`` after (start, stop) for the (N, 3) float64
        points P in ``mode``, its outputs (f, g, c) last (a partner process compiles it for
        these types without running it)."""
        n = len(P)
        f = np.empty(n)
        g = np.empty((n, 3)) if mode >= GRADIENT else np.empty((0, 3))
        c = np.empty((n, 3)) if mode >= GRADIENT else np.empty((0, 3))  # (colours cost nothing)
        return self.arrays, P, mode, self.depth, (f, g, c)

    @cached_property
    def grid(self) -> Grid | None:
        """The program specialised to each cell of a grid over the bounds (built on first use),
        or None for an empty or unbounded tree."""
        lo, hi = self.bounds
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi > lo)):
            return None
        nprim = int(np.sum(KIND[self.code[:, OP]] == K_PRIMITIVE))
        cells = int(np.clip(GRID_CELLS_PER_PRIMITIVE * nprim, GRID_MIN_CELLS, GRID_MAX_CELLS))
        while True:
            ext = hi - lo
            dims = np.maximum(1, np.round(ext * (cells / np.prod(ext)) ** (1 / 3))).astype(
                np.int64)
            size = ext / dims
            pad = 1e-9 * float(ext.max())
            rlo, rhi = S.cell_boxes(lo, size, dims, pad)
            start = S.region_starts(self.arrays, rlo, rhi)
            if start[-1] <= GRID_MAX_INSTRUCTIONS or cells <= GRID_MIN_CELLS:
                cells = S.specialize_regions(self.arrays, rlo, rhi, start)
                return Grid(*cells.arrays, lo.copy(), size, dims)
            cells //= 4

    def regions(self, lo: np.ndarray, hi: np.ndarray) -> Regions:
        """The program specialised to each box (lo[r], hi[r]) ((R, 3) each; infinite corners
        for a region holding anything), for :meth:`field_grouped`.  The boxes are grown by a
        little more than the rounding of points computed on their faces."""
        lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
        corners = np.abs(np.concatenate([lo.ravel(), hi.ravel()]))
        pad = 1e-9 * float(np.max(corners[np.isfinite(corners)], initial=1.0))
        return S.specialize_regions(self.arrays, lo - pad, hi + pad)

    def field_grouped(self, regions: Regions, P: np.ndarray, first: np.ndarray) -> np.ndarray:
        """Field values (N,) of (N, 3) points grouped by region: P[first[r]:first[r + 1]] all
        lie in region r of ``regions`` (from :meth:`regions`; ``first`` has R + 1 entries).
        Each group runs its region's program, with no sorting."""
        return self._run_grouped(regions, P, first, 1)[:, 0]

    def evaluate_grouped(self, regions: Regions, P: np.ndarray, first: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(field, gradient, colour) of points grouped by region, as :meth:`field_grouped`."""
        vals = self._run_grouped(regions, P, first, 7)
        f, g, c = np.empty(len(P)), np.empty((len(P), 3)), np.empty((len(P), 3))
        parallel_for(B.put_back, len(P), vals, np.arange(len(P), dtype=np.int32), f, g, c)
        return f, g, c

    def _run_grouped(self, regions: Regions, P: np.ndarray, first: np.ndarray, width: int
                     ) -> np.ndarray:
        vals = np.empty((len(P), width))  # the field, or with the gradient and colour
        B.eval_grouped(regions, self.params, self.depth, np.ascontiguousarray(P, np.float64),
                       np.asarray(first, dtype=np.int64), vals)
        return vals

    def field(self, P: np.ndarray) -> np.ndarray:
        """Field values (N,) at (N, 3) points."""
        return self._run(P, VALUE)[0]

    def gradient(self, P: np.ndarray) -> np.ndarray:
        """Analytic gradients (N, 3)."""
        return self._run(P, GRADIENT)[1]

    def albedo(self, P: np.ndarray) -> np.ndarray:
        """Colours (N, 3) in [0, 1]."""
        return self._run(P, SHADE)[2]

    def evaluate(self, P: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(field, gradient, colour) in one pass."""
        return self._run(P, SHADE)

    def lipschitz(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """Per box (M, 3) corners: a bound on ``|grad f|`` valid over the whole box."""
        lo = np.ascontiguousarray(lo, dtype=np.float64).reshape(-1, 3)
        hi = np.ascontiguousarray(hi, dtype=np.float64).reshape(-1, 3)
        out = np.empty(len(lo))
        parallel_for(K.lipschitz_range, len(lo), self.arrays, lo, hi, self.depth, out)
        return out

    def bound_at(self, lo: np.ndarray, hi: np.ndarray, at: np.ndarray) -> np.ndarray:
        """Per box (M, 3) corners and a point ``at`` (M, 3) of each, a row (M, 4): the field at
        the point, a bound on ``|grad f|`` over the box, and how far from the point the field
        surely stays below and above 0.5 within the box.  The field values let CSG operators
        tighten both (a child that cannot set the result anywhere in the box adds nothing to
        the bound; a min stays below 0.5 as far as any of its terms does)."""
        lo, hi, at = (np.ascontiguousarray(a, dtype=np.float64).reshape(-1, 3)
                      for a in (lo, hi, at))
        if not len(lo) == len(hi) == len(at):
            raise ValueError(f"lo, hi and at must hold as many points, got {len(lo)}, "
                             f"{len(hi)} and {len(at)}")
        if not K.bounds_use_values(self.code):  # no CSG root: the plain bound and batch field
            f, lip = self.field(at), self.lipschitz(lo, hi)
            gap = np.divide(np.abs(f - ISO), lip, out=np.full(len(f), np.inf), where=lip > 0)
            return np.stack([f, lip, np.where(f < ISO, gap, 0.0), np.where(f > ISO, gap, 0.0)],
                            axis=1)
        out = np.empty((len(lo), 4))
        parallel_for(K.bound_range, len(lo), self.arrays, lo, hi, at, self.depth, out)
        return out


#: A node's boxes are handed to the next compile while it has them in at most this many
#: frames: a subtree left alone keeps its frames, one moved each time (a spiral changed) would
#: gather a frame a compile; past this it starts afresh, so the boxes kept stay bounded.
HANDED_BOXES = 2

#: (node key, frame, look) -> (code start, code end, params start, params end, box): where a
#: compile put each subtree
Spans = dict[tuple[str, bytes, int], tuple[int, int, int, int, geo.Box]]
#: (children's keys, frame) -> where a compile met them (an instruction inside their
#: operator's run), and the two groups :func:`_split` made of them
Splits = dict[tuple[tuple[str, ...], bytes], tuple[int, tuple[np.ndarray, np.ndarray]]]


class Reuse:
    """The instructions of a tree compiled before, by subtree, for :func:`compile_tree` to copy
    into the next program wherever the same subtree (by structural key) meets the same frame and
    texture: a spec changed in one part compiles only that part again."""

    def __init__(self) -> None:
        self.program: Program | None = None
        self.images: dict[str, int] = {}
        self.spans: Spans = {}
        #: node key -> its boxes by frame (``Node.box``'s memo), handed to equal nodes
        self.boxes: dict[str, dict[bytes, geo.Box]] = {}
        self.splits: Splits = {}
        #: the spans' and the splits' keys in code order, and where they start (:meth:`inside`)
        self._ordered: list[tuple[str, bytes, int]] = []
        self._starts = np.zeros(0, dtype=np.int64)
        self._split_order: list[tuple[tuple[str, ...], bytes]] = []
        self._split_starts = np.zeros(0, dtype=np.int64)

    def hold(self, program: Program, images: dict[str, int],
             spans: Spans, boxes: dict[str, dict[bytes, geo.Box]], splits: Splits) -> None:
        """Hold a compiled program, its images' places, its subtrees' spans, its nodes' boxes
        and its groups (see the attributes)."""
        self.program, self.images, self.spans = program, images, spans
        self.boxes, self.splits = boxes, splits
        self._ordered = sorted(spans, key=lambda key: spans[key][0])
        self._starts = np.array([spans[key][0] for key in self._ordered], dtype=np.int64)
        self._split_order = sorted(splits, key=lambda key: splits[key][0])
        self._split_starts = np.array([splits[key][0] for key in self._split_order],
                                      dtype=np.int64)

    def inside(self, c0: int, c1: int, dc: int, dp: int) -> tuple[Spans, Splits]:
        """The spans of the subtrees and the splits of the groups within instructions c0:c1 (a
        subtree's instructions are one run, inside any run that holds its first), moved by dc
        instructions and dp parameters: where they lie once :meth:`_Emitter.copy` has copied
        that run, so that a subtree copied whole in one compile still has its parts to copy,
        and its groups' splits, in the next."""
        i, j = np.searchsorted(self._starts, (c0, c1))
        moved = {}
        for key in self._ordered[i:j]:
            a, b, q0, q1, box = self.spans[key]
            moved[key] = (a + dc, b + dc, q0 + dp, q1 + dp, box)
        i, j = np.searchsorted(self._split_starts, (c0, c1))
        splits = {key: (self.splits[key][0] + dc, self.splits[key][1])
                  for key in self._split_order[i:j]}
        return moved, splits


class _Emitter:
    """Emits a tree's instructions in postfix order (see the module docstring for the layout)."""

    def __init__(self) -> None:
        self.reuse: Reuse | None = None
        #: this compile's subtrees by key (see :class:`Reuse`), when there is a Reuse to keep
        self.spans: Spans = {}
        #: this compile's groups (see :class:`Reuse`)
        self.splits: Splits = {}
        self.code: list[list[int]] = []
        #: the instructions' parameters; the images come before them in ``params``
        self.params: list[float] = []
        #: the instructions' boxes, their low and high corners
        self.lo: list[np.ndarray] = []
        self.hi: list[np.ndarray] = []
        self.lips: list[float] = []
        #: image key -> params offset, the image blocks, and how many parameters they take
        self.images: dict[str, int] = {}
        self.image_blocks: list[np.ndarray] = []
        self.base = 0
        #: (node id, frame, look) -> (code start, code end, params start, params end, box) of
        #: its first emission: a shared subtree is emitted once and copied after
        self.emitted: dict[tuple[int, bytes, int], tuple[int, int, int, int, geo.Box]] = {}
        #: instruction -> (its frame, a factor, where its header's norm goes): the primitives,
        #: PUSHPTs and POPPTs whose frame->local maps, their norms and the lips (factor times
        #: norm) :meth:`frame_maps` computes for all at once (a POPPT takes only its lip: 0)
        self.framed: dict[int, tuple[np.ndarray, float, int]] = {}

    def add(self, op: int, params=(), box: geo.Box | None = None, count: int = 0,
            lip: float = 0.0) -> int:
        i = len(self.code)
        self.code.append([op, self.base + len(self.params), i + 1, count])
        self.params.extend(map(float, params))
        lo, hi = _NO_BOX if box is None else box
        self.lo.append(lo)
        self.hi.append(hi)
        self.lips.append(lip)
        return i

    def close(self, i: int, box: geo.Box) -> None:
        """Set instruction i's skip target to the next instruction, and its box."""
        self.code[i][SKIP] = len(self.code)
        self.lo[i], self.hi[i] = box

    def image_offset(self, node: Node) -> int:
        """Where a texture's image block lies in params (each distinct image once, all before
        the first instruction: see :func:`compile_tree`)."""
        key = node.image_key
        if key not in self.images:
            assert not self.code, "images are placed before any instruction"
            block = node.image_block()
            self.images[key] = self.base
            self.image_blocks.append(block)
            self.base += len(block)
        return self.images[key]

    # ---------------------------------------------------------------------------------------
    def emit(self, node: Node, M: np.ndarray, look: int = -1) -> geo.Box:
        """Emit ``node`` whose coordinates map to the current frame by M; return its frame box.
        ``look``: params offset of the field-interpolated texture painting primitives, or -1.
        A subtree met again in the same frame is a copy of its first instructions, so shared
        subtrees cost their size once, then a copy per use."""
        key = (id(node), M.tobytes(), look)
        first = self.emitted.get(key)
        if first is not None:
            return self.repeat(*first)
        c0, p0 = len(self.code), len(self.params)
        if self.reuse is None:
            box = self.emit_new(node, M, look)
        else:
            skey = (node.key, key[1], look)
            before = self.reuse.spans.get(skey)
            box = self.emit_new(node, M, look) if before is None else self.copy(*before)
            self.spans[skey] = (c0, len(self.code), self.base + p0,
                                self.base + len(self.params), box)
        self.emitted[key] = (c0, len(self.code), p0, len(self.params), box)
        return box

    def copy(self, c0: int, c1: int, p0: int, p1: int, box: geo.Box) -> geo.Box:
        """Copy instructions c0:c1 and parameters p0:p1 (absolute) of the reused program to
        the end, moved as :meth:`repeat` moves them (the images lie where they lay)."""
        prog = self.reuse.program
        dc, dp = len(self.code) - c0, self.base + len(self.params) - p0
        spans, splits = self.reuse.inside(c0, c1, dc, dp)
        self.spans.update(spans)
        self.splits.update(splits)
        rows = prog.code[c0:c1].copy()
        rows[:, OFFSET] += dp
        rows[:, SKIP] += dc
        self.code.extend(rows.tolist())
        self.params.extend(prog.params[p0:p1].tolist())
        self.lo.extend(prog.boxes[c0:c1, :3])
        self.hi.extend(prog.boxes[c0:c1, 3:])
        self.lips.extend(prog.lips[c0:c1].tolist())
        return box

    def repeat(self, c0: int, c1: int, p0: int, p1: int, box: geo.Box) -> geo.Box:
        """Copy instructions c0:c1 and their parameters p0:p1 to the end, their parameter
        offsets and jump targets moved with them (image offsets stay: images are placed before
        any instruction, see :func:`compile_tree`)."""
        dc, dp = len(self.code) - c0, len(self.params) - p0
        self.framed.update({i + dc: self.framed[i] for i in range(c0, c1) if i in self.framed})
        self.code.extend([op, at + dp, to + dc, n] for op, at, to, n in self.code[c0:c1])
        self.params.extend(self.params[p0:p1])
        self.lo.extend(self.lo[c0:c1])
        self.hi.extend(self.hi[c0:c1])
        self.lips.extend(self.lips[c0:c1])
        return box

    def emit_new(self, node: Node, M: np.ndarray, look: int) -> geo.Box:
        """Emit ``node`` met for the first time in this frame (see :meth:`emit`)."""
        kind = node.KIND
        if kind == "affine":  # (a chain of them at once: only what lies below it is emitted)
            return self.emit(*node.below(M), look)
        if kind == "primitive":
            return self.primitive(node, M, look)
        if kind == "paint":
            return self.paint(node, M, look)
        if kind == "warp":
            return self.warp(node, M, look)
        return self.operator(node, M, look)

    def operator(self, node: Operator, M: np.ndarray, look: int) -> geo.Box:
        op = opcode(node)
        children = node.program_children()
        head = self.add(OP_BOX)
        if node.ASSOCIATIVE:
            box = self.group(op, node, children, M, look)
        else:
            box = node.combine_boxes([self.emit(c, M, look) for c in children])
            self.add(op, node.op_params(), count=len(children))
        self.close(head, box)
        return box

    def paint(self, node: Paint, M: np.ndarray, look: int) -> geo.Box:
        """Colour nodes and textures (see texture/mapping.py for the two methods)."""
        if node.sets_look:
            return self.emit(node.child, M, self.image_offset(node))
        head = self.add(OP_BOX)
        box = self.emit(node.child, M, look)
        self.add(opcode(node), node.pack(M, self.image_offset))
        self.close(head, box)
        return box

    def group(self, op: int, node: Operator, children: list[Node], M: np.ndarray,
              look: int) -> geo.Box:
        """Children of an associative operator, as a hierarchy of boxed groups."""
        extra = node.op_params()
        if len(children) <= GROUP:
            boxes = [self.emit(c, M, look) for c in children]
            self.add(op, extra, count=len(children))
            return geo.box_union(boxes)
        boxes = []
        for part in self.split(children, M):
            head = self.add(OP_BOX)
            box = self.group(op, node, [children[i] for i in sorted(part)], M, look)
            self.close(head, box)
            boxes.append(box)
        self.add(op, extra, count=2)
        return geo.box_union(boxes)

    def split(self, children: list[Node], M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:func:`_split` of the children's boxes, as the reused compile split them if the
        same children met the same frame there."""
        if self.reuse is None:
            return _split([c.box(M) for c in children])
        key = (tuple(c.key for c in children), M.tobytes())
        known = self.splits.get(key) or self.reuse.splits.get(key)
        parts = _split([c.box(M) for c in children]) if known is None else known[1]
        self.splits[key] = (len(self.code), parts)
        return parts

    def primitive(self, node: Primitive, M: np.ndarray, look: int) -> geo.Box:
        """A primitive: its header (the frame->local map, R, falloff id, the map's norm; the
        map and norm filled in by :meth:`frame_maps`), then its own parameters."""
        box = node.box(M)
        i = self.add(opcode(node), _own_params(node), box, count=look)
        self.framed[i] = (M, node.lipschitz(), MAP_NORM)
        return box

    def warp(self, node: Warp, M: np.ndarray, look: int) -> geo.Box:
        box = node.box(M)
        push = self.add(OP_PUSHPT, [0.0] * (FRAME_NORM + 1), box)  # (map, norm: frame_maps)
        self.framed[push] = (M, node.lipschitz(), FRAME_NORM)
        w = self.add(opcode(node), _warp_params(node), node.own_box, lip=node.stretch)
        self.emit(node.child, geo.IDENTITY, look)
        self.code[w][SKIP] = len(self.code)  # a miss jumps to POPPT
        # POPPT's lip: the factor from the warp's child frame to the outer frame
        self.framed[self.add(OP_POPPT)] = (M, node.stretch, 0)
        self.code[push][SKIP] = len(self.code)
        return box

    def frame_maps(self, code: np.ndarray, params: np.ndarray, lips: np.ndarray) -> None:
        """Fill in the frame->local maps of the primitives and PUSHPTs, their norms and the
        lips that scale with them, all in one pass (numpy's batched inverse and singular
        values give each matrix the bits they give it alone)."""
        if not self.framed:
            return
        rows = np.fromiter(self.framed, dtype=np.int64, count=len(self.framed))
        frames = np.array([f for f, _, _ in self.framed.values()]).reshape(-1, 3, 4)
        factor = np.array([k for _, k, _ in self.framed.values()])
        place = np.array([h for _, _, h in self.framed.values()])
        a = np.linalg.inv(frames[:, :, :3])
        inv = np.concatenate([a, -(a @ frames[:, :, 3:])], axis=2)
        norm = np.linalg.svd(a, compute_uv=False)[:, 0]
        lips[rows] = factor * norm
        mapped = place > 0
        at = code[rows[mapped], OFFSET]
        params[at[:, None] + np.arange(12)] = inv[mapped].reshape(-1, 12)
        params[at + place[mapped]] = norm[mapped]

    def program(self, root: Node) -> Program:
        code = np.array(self.code, dtype=np.int64).reshape(-1, 4)
        params = np.concatenate([*self.image_blocks, np.array(self.params, dtype=np.float64)])
        lips = np.array(self.lips, dtype=np.float64)
        self.frame_maps(code, params, lips)
        return Program(
            code=code,
            params=params,
            boxes=np.concatenate([np.array(self.lo, dtype=np.float64).reshape(-1, 3),
                                  np.array(self.hi, dtype=np.float64).reshape(-1, 3)], axis=1),
            lips=lips,
            depth=_stack_depth(code),
            bounds=root.bounds(),
        )


def _own_params(node: Primitive) -> list[float]:
    """A primitive's parameters in the program, its header's frame map and norm left 0 (they
    depend on the frame: :meth:`_Emitter.frame_maps`); kept on the node, which is a value (a
    change of the spiral places the same pieces again)."""
    def make() -> list[float]:
        header = [0.0] * MAP_NORM + [0.0]
        header[RADIUS], header[FALLOFF] = node.field_radius, FALLOFFS[node.falloff]
        return [float(v) for v in header + node.pack()]

    return node.memo("_own_params", make)


def _warp_params(node: Warp) -> list[float]:
    """A warp's parameters in the program: its signed permutation, then its own ``LAYOUT``;
    kept on the node, as :func:`_own_params`."""
    return node.memo("_warp_params",
                     lambda: [float(v) for v in (*node.canonical.reshape(-1), *node.pack())])


#: The box of an instruction that has none: everything.
_NO_BOX = (np.full(3, -np.inf), np.full(3, np.inf))


def _stack_depth(code: np.ndarray) -> int:
    """Deepest value or point stack a run can reach (+1 spare row)."""
    if len(code) == 0:
        return 2
    op, count = code[:, OP], code[:, ARG]
    kinds = KIND[op]
    operator = kinds == K_OPERATOR
    push = (kinds == K_PRIMITIVE) | (kinds == K_ZERO)
    dsp = np.where(push, 1, np.where(operator, 1 - count, 0))
    sp = np.cumsum(dsp)  # value stack after each instruction
    pp = np.cumsum((kinds == K_PUSHPT).astype(np.int64) - (kinds == K_POPPT))
    working = np.where(operator, sp - dsp + STACK[op], 0)  # an operator's rows beyond its
    return int(max(0, sp.max(), pp.max(), working.max())) + 2  # children while it runs


def expanded_size(tree: Node, nodes: list[Node] | None = None) -> int:
    """About how many instructions ``tree`` compiles to, counted over its distinct nodes
    (``nodes``: ``tree.unique()`` if already listed; a shared subtree counts at each of its
    places, as the program repeats it).  Each node keeps its count (a value of its subtree), so
    a tree changed in one part counts only the nodes the change made."""
    def size_of(node: Node) -> int:  # a program child may be a child moved by new affine nodes
        while (size := node.memo("_expanded")) is None and node.KIND == "affine":
            node = node.child
        return size

    def make(node: Node) -> int:  # (its children's counts are kept: they come before it)
        kids = node.program_children() if node.KIND == "operator" else node.children
        own = {"affine": 0, "primitive": 1, "paint": 2, "warp": 3}.get(node.KIND, 2)
        if node.KIND == "operator" and getattr(node, "ASSOCIATIVE", False):
            own += 2 * max(len(kids) // GROUP, 1)
        return own + sum(size_of(c) for c in kids)

    for node in tree.unique() if nodes is None else nodes:
        if node.memo("_expanded") is None:
            node.memo("_expanded", partial(make, node))
    return size_of(tree)


def _split(boxes: list[geo.Box]) -> tuple[np.ndarray, np.ndarray]:
    """Two groups of the boxes (index arrays) for the box hierarchy of an associative operator:
    of the cuts of the boxes sorted by centre along each axis, the one that leaves the fewest
    boxes expected to hold a point (the volume heuristic of bounding-volume hierarchies: a
    group's box holds a point in proportion to its volume, and then all its boxes are tested),
    the boxes grown by a little so that flat ones still count; of equally good cuts, the most
    even (boxes all alike give a balanced tree).  Empty boxes count as points at the origin."""
    b = np.array(boxes, dtype=np.float64)
    if not np.isfinite(b).all():
        b = np.nan_to_num(b, nan=0.0, posinf=0.0, neginf=0.0)
    lo = b[:, 0]
    hi = np.maximum(b[:, 1], lo)
    n = len(b)
    grow = 0.01 * float((hi.max(axis=0) - lo.min(axis=0)).max())
    # the three axes at once: [axis, place in that axis' order, coordinate]
    order = np.argsort(lo + hi, axis=0, kind="stable").T
    # each cut's two groups' boxes: the running greatest of hi and of -lo, from the front and
    # from the back, in one pass ([side, axis, place, coordinate])
    ends = np.concatenate([hi, -lo], axis=1)[order]
    run = np.maximum.accumulate(np.stack([ends, ends[:, ::-1]]), axis=2)[:, :, :-1]
    volume = np.prod(run[..., :3] + run[..., 3:] + grow, axis=3)
    k = np.arange(1, n)
    cost = volume[0] * k + volume[1, :, ::-1] * (n - k)
    # on each axis, of the cuts within a hair of its cheapest, the most even (the first such);
    # then the cheapest axis (the first of equals)
    near = cost <= cost.min(axis=1, keepdims=True) * (1.0 + 1e-9)
    cut = np.argmin(np.where(near, np.abs(2 * k - n), n + 1), axis=1)
    axis = int(np.argmin(cost[np.arange(3), cut]))
    i = int(cut[axis])
    return order[axis, :i + 1], order[axis, i + 1:]


def program_of(tree: Node | Program, name: str = "tree") -> Program:
    """The compiled program of a tree, or a program (or any evaluator with ``program``-like
    methods, as ``blobtree.distributed`` passes) as is; ValueError naming ``name`` otherwise."""
    if hasattr(tree, "program"):
        return tree.program()
    if isinstance(tree, Program) or all(hasattr(tree, a) for a in ("bounds", "field", "evaluate")):
        return tree
    raise ValueError(f"{name} must be a BlobTree node or a Program, got {type(tree).__name__[:60]}")


def compile_tree(tree: Node, reuse: Reuse | None = None) -> Program:
    """Flatten ``tree`` into a :class:`Program`; TypeError for a node type without kernels,
    ValueError for a tree that expands past ``MAX_INSTRUCTIONS``.  ``reuse``: copy the
    instructions of the subtrees it holds from the tree compiled with it before (the same
    program as compiled afresh), then hold this tree's."""
    if not isinstance(tree, Node):
        raise ValueError(f"tree must be a BlobTree node, got {type(tree).__name__[:60]}")
    nodes = tree.unique()
    n = expanded_size(tree, nodes)
    if n > MAX_INSTRUCTIONS:
        raise ValueError(
            f"tree expands to about {n:,} instructions, more than {MAX_INSTRUCTIONS:,}: a "
            "subtree shared in many places is repeated at each (e.g. blends of blends of one "
            "node); build it with fewer repetitions")
    em = _Emitter()
    for node in nodes:  # images first, so no subtree's instructions hold one
        if hasattr(node, "image_key"):
            em.image_offset(node)
    if reuse is not None:  # copies need the images where they were
        em.reuse = reuse if reuse.program is not None and reuse.images == em.images else Reuse()
        for node in nodes:  # a subtree left alone is not walked again for its boxes
            node.box_memo(reuse.boxes.get(node.key))
    em.emit(_value_root(tree, nodes), geo.IDENTITY)
    prog = em.program(tree)
    if reuse is not None:
        boxes = {node.key: memo for node in nodes
                 if frames_kept(memo := node.box_memo()) <= HANDED_BOXES}
        reuse.hold(prog, dict(em.images), em.spans, boxes, em.splits)
    return prog


def _value_root(tree: Node, nodes: list[Node]) -> Node:
    """The tree to emit: under a one-child union (the same field) where it holds an operator
    that ``WANTS_VALUES`` below a root whose bound takes no values, so that the tracer and the
    mesher take the value-aware bound pass (``bounds.bounds_use_values`` reads the root).
    ``nodes``: the tree's distinct nodes."""
    root_takes_values = tree.KIND == "operator" and tree.KERNELS.bound is not None
    if root_takes_values or not any(getattr(n, "WANTS_VALUES", False) for n in nodes):
        return tree
    return REGISTRY["union"](tree)
