"""Polygonize a BlobTree: marching cubes on the part of the lattice the surface can cross.

1. **Cull** (:func:`_cull`).  An octree of boxes down to ``FINE`` cells; a box is dropped when
   the engine's Lipschitz bound L over it (or over its ancestor of ``BOUND_MIN`` cells) proves
   the 0.5 iso-surface cannot cross it, ``|f(centre) - 0.5| > L * half_diagonal`` (L is 0
   where the box misses every node box; the field values at the centre let CSG operators leave
   out a child that cannot win there, and prove more: a min stays below 0.5 as far as any of
   its terms does).
2. **Sample** (:func:`_sample`).  The kept boxes at their corners and centres, then whole boxes
   from those showing both sides of 0.5 outwards across crossed faces.  Work therefore grows
   with the surface (about 4x per doubling of the resolution), not with the volume.
3. **Contour** the wholly sampled boxes with the face-consistent marching cubes of
   :mod:`blobtree.mesh._kernels`; vertices are keyed on lattice edges and welded (only those
   on the faces of blocks can repeat).
4. **Place** every vertex on the iso-surface: regula falsi steps on the real field along its
   lattice edge, batched over all vertices, then a Newton step from the one evaluation that
   also gives the normals (from the gradient) and colours (from the albedo).

Limits: a feature thinner than about two cells (a spine tip, a thin bridge between blobs) can
fall between samples and be lost or broken into islands; see docs/meshing.md.
"""

from __future__ import annotations

import math
import os

import numpy as np

from ..checks import Integer, Vec3, positive, short_repr
from ..engine import batch
from ..engine.batch import lanes_walk
from ..engine.program import Program, program_of
from ..nodes.node import ISO
from ..runtime import partner
from ..runtime.threads import parallel_for
from . import _kernels
from ._kernels import block_triangles, compile_triangles
from ._lattice import (
    box_geometry,
    gather,
    keep_boxes,
    new_store,
    seeds,
    split,
    spread,
    store,
)
from ._place import (
    bracket_step,
    edge_starts,
    final_roots,
    newton_step,
    outward_normals,
    secant_points,
)
from .export import Mesh

#: what the arguments may be
RESOLUTION, CELL_SIZE, VEC3 = Integer(2, 2**20), positive(), Vec3()
#: cells per side of the blocks of lattice storage
LATTICE_BLOCK = 16
#: cells per side of the smallest boxes culled
FINE = 2
#: cells per side of the smallest boxes given a Lipschitz bound of their own; smaller boxes
#: reuse their ancestor's (at 4 cells a bound costs more than the samples it saves: without it
#: the Murex at 512 meshes 6% faster, whorl126 at 256 about as fast, with the same mesh;
#: ``python bench/ab.py BASE --task mesh --size 512``)
BOUND_MIN = 8
#: lattice points gathered and sampled at a time, at most (about 40 bytes each while sampled)
SAMPLE_CHUNK = 1 << 20
#: regula falsi steps per vertex at most (a Newton step on the shading evaluation follows); a
#: vertex stops early once the secant puts its root within VERTEX_TOL of the edge's length
REFINE_STEPS, VERTEX_TOL = 2, 1e-2
#: peak memory per output triangle and per finest culled box (fitted to the whorl and the Murex
#: at 512 and 1024 cells: 156 and 83 bytes)
BYTES_PER_TRIANGLE, BYTES_PER_BOX = 160, 90
#: triangles per cell of face area of the boxes kept above the finest level: 0.4 to 3 times the
#: final count (the Murex at 512 and 2560 cells), so those levels refuse a job only when even a
#: quarter of their estimate would not fit (the finest level's sampled estimate is within 3%)
TRIANGLES_PER_CELL, COARSE_SLACK = 1.0, 4.0
#: finest boxes sampled to estimate the triangles (the Lipschitz bound keeps 1 to 4 times more
#: boxes than the surface crosses, so their count alone is a poor estimate)
ESTIMATE_SAMPLE = 4096
#: triangles per lattice cell the surface crosses; most a finest box (8 cells) can hold
TRIANGLES_PER_CROSSED_CELL, MAX_TRIANGLES_PER_BOX = 2.0, 40


def polygonize(
    tree,
    resolution: int | None = None,
    *,
    cell_size: float | None = None,
    bounds=None,
    progress: bool = False,
    max_memory: int | None = None,
) -> Mesh:
    """Triangulate the 0.5 iso-surface of ``tree`` into a closed, welded, oriented mesh.

    ``resolution``: cells across the longest side of the bounds (default 128 when neither it nor
    ``cell_size`` is given); ``cell_size``: the cell edge length instead.  ``bounds``: ``(lo, hi)``
    region to mesh (default: the tree's bounds); the solid is capped where the bounds cut it.
    ``progress`` shows a tqdm bar.  ``max_memory`` (bytes, default: available memory) is the
    budget: a job whose estimated output exceeds it is refused with ValueError before sampling.
    Features thinner than about two cells may be lost (see docs/meshing.md).
    ``tree`` may also be any evaluator with ``bounds``, ``field``, ``evaluate`` and
    ``bound_at`` as ``Program`` has them (``blobtree.distributed`` passes one whose batches run on
    a Dask cluster; the mesh is the same).
    """
    from tqdm.auto import tqdm

    prog = program_of(tree)
    if isinstance(prog, Program):  # (kernels run here, not on a cluster)
        _share_first_compile()
    if bounds is None and not np.all(np.asarray(prog.bounds[1]) > np.asarray(prog.bounds[0])):
        return Mesh.empty()  # the tree's support is empty or flat: no solid
    lo, hi = _check_bounds(prog.bounds if bounds is None else bounds)
    h = _cell_size(lo, hi, resolution, cell_size)
    budget = (_available_memory() if max_memory is None
              else Integer(0).check("max_memory", max_memory))
    grid = _Grid(lo, hi, h, clip=bounds is not None)
    # the steps are uneven (and the first run compiles in the first): no rate, no estimate
    with tqdm(total=4, desc="mesh", disable=not progress, leave=False,
              bar_format="{desc}: {n_fmt}/{total_fmt} steps |{bar}| {elapsed}") as bar:
        culled = _cull(prog, grid, budget)
        bar.update()
        values, block_origins, box_start, boxes, regions = _sample(prog, grid, culled)
        bar.update()
        keys, f0, f1, centres, tris, vertex_start = block_triangles(
            values, block_origins, box_start, boxes, FINE, grid.dims, ISO
        )
        del values
        bar.update()
        verts, grad, colors = _place(prog, grid, regions, keys, f0, f1, centres, vertex_start)
        bar.update()
    return Mesh(verts, tris, _normals(grad, verts, tris), np.clip(colors, 0.0, 1.0))


def _share_first_compile() -> None:
    """On a first run (the lanes walk missing from the cache), a partner process compiles the
    lanes walk, then the contouring's kernels, while this one compiles the culling's, the
    sampling's and the vertices' (``runtime.partner``).  The lanes walk comes first: the
    sampling's batches (``batch._eval_runs``) call it by symbol, so this process waits for it
    when it reaches them (after 3-4 s; with the contouring first, it idled 9 s there)."""
    if not lanes_walk.ensure(compile=False):
        partner.start({lanes_walk.symbol: f"{batch.__name__}:lanes_walk",
                       partner.kernel_key(_kernels._fill_part.py_func):
                       f"{__name__}:_triangles_unit"})


def _triangles_unit() -> None:
    """Compile the contouring's kernels (the partner's unit)."""
    compile_triangles(LATTICE_BLOCK, FINE, ISO)


def _place(prog, grid: _Grid, regions, keys, f0, f1, centres, vertex_start):
    """Vertices on the surface (edge vertices, block by block as ``vertex_start`` says, then
    loop-centre vertices), with the field's gradient and colour there."""
    p0, axis = grid.edge_points(keys)
    t, t_lo, t_hi, verts = _refine(prog, grid, regions, p0, axis, f0, f1, vertex_start)
    if grid.clip:  # the cap lies on the bounds; bracketing converges slowly onto the jump
        np.clip(verts, grid.lo, grid.hi, out=verts)
    n = len(verts)
    verts = np.concatenate([verts, _project(prog, grid, grid.origin + centres * grid.h)])
    if regions is None:
        f, grad, colors = prog.evaluate(verts)
    else:  # the centres, which may have left their blocks, in the last region: anywhere
        f, grad, colors = prog.evaluate_grouped(regions, verts, np.r_[vertex_start, len(verts)])
    # a last Newton step along each edge from the values just taken, kept inside the bracket
    # (and off the cap of a cut solid, where the real field is not the one meshed)
    movable = (np.all((p0 >= grid.lo) & (p0 + grid.h <= grid.hi), axis=1) if grid.clip
               else np.ones(n, dtype=bool))
    parallel_for(newton_step, n, f, grad, ISO, axis, grid.h, t, t_lo, t_hi, movable, verts)
    return verts, grad, colors


def _check_bounds(bounds) -> tuple[np.ndarray, np.ndarray]:
    """``bounds`` as two float arrays (lo, hi), or ValueError."""
    if isinstance(bounds, str | bytes) or not hasattr(bounds, "__len__") or len(bounds) != 2:
        raise ValueError(f"bounds must be a pair (lo, hi) of 3-vectors, got {short_repr(bounds)}")
    lo, hi = (np.array(VEC3.check(f"bounds[{i}]", b)) for i, b in enumerate(bounds))
    if not np.all(hi > lo):
        raise ValueError(f"bounds must have hi > lo on every axis, got {short_repr(bounds)}")
    return lo, hi


def _cell_size(lo, hi, resolution, cell_size) -> float:
    """The cell edge from ``resolution`` or ``cell_size`` (default: 128 cells across)."""
    if resolution is not None and cell_size is not None:
        raise ValueError("give either resolution or cell_size, not both")
    if cell_size is not None:
        return CELL_SIZE.check("cell_size", cell_size)
    resolution = 128 if resolution is None else RESOLUTION.check("resolution", resolution)
    return float(np.max(hi - lo)) / resolution


def _available_memory() -> int:
    """MemAvailable from /proc/meminfo, else total physical memory."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


class _Grid:
    """The lattice: one cell of padding around the bounds, whose points read as outside, so the
    surface closes even where ``bounds`` cut the solid."""

    def __init__(self, lo: np.ndarray, hi: np.ndarray, h: float, clip: bool):
        self.lo, self.hi, self.h, self.clip = lo, hi, h, clip
        self.origin = lo - h
        cells = np.ceil((hi - lo) / h).astype(np.int64) + 2
        # lattice points per axis, rounded up to whole blocks
        self.blocks = -(-cells // LATTICE_BLOCK)
        self.dims = self.blocks * LATTICE_BLOCK + 1
        if float(np.prod(self.dims.astype(np.float64))) * 3 >= 2.0**62:
            raise ValueError(f"cell size {h!r} gives a lattice too large to index")

    def field(self, prog, points: np.ndarray) -> np.ndarray:
        """The field, 0 outside the bounds (this caps the solid where the bounds cut it)."""
        return self.clip_values(points, prog.field(points))

    def clip_values(self, points: np.ndarray, f: np.ndarray) -> np.ndarray:
        """Field values ``f`` at ``points``, set to 0 outside the bounds."""
        if not self.clip:  # the padding lies outside the tree's bounds: the field is 0 there
            return f
        out = np.any((points < self.lo) | (points > self.hi), axis=1)
        return np.where(out, 0.0, f)

    def block_code(self, block: np.ndarray) -> np.ndarray:
        """The row-major numbers of blocks given by their indices (K, 3)."""
        nb = self.blocks
        return (block[:, 0] * nb[1] + block[:, 1]) * nb[2] + block[:, 2]

    def edge_points(self, keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Lower lattice point (V, 3) and axis (V,) of each lattice-edge key."""
        p0, axis = np.empty((len(keys), 3)), np.empty(len(keys), dtype=np.int64)
        parallel_for(edge_starts, len(keys), keys, self.dims, self.origin, self.h, p0, axis)
        return p0, axis


def _cull(prog, grid: _Grid, budget: int):
    """Octree descent from blocks of ``LATTICE_BLOCK << levels`` cells down to ``FINE`` cells.

    Returns the lattice origins (K, 3) of the finest boxes the surface may cross and the field
    at their centres (K,) (lattice points).
    """
    levels = max(0, math.ceil(math.log2(max(1, int(grid.blocks.max())) / 4)))
    size = LATTICE_BLOCK << levels  # cells per side of the top-level blocks
    top = -(-grid.blocks * LATTICE_BLOCK // size)
    origins = np.stack(np.meshgrid(*(np.arange(n) * size for n in top), indexing="ij"), -1)
    origins = origins.reshape(-1, 3)
    limit = grid.dims - 1
    parent_lip = None
    while True:
        lo, hi, centre, half_diag = box_geometry(origins, size, grid.origin, grid.h, limit)
        # the smallest boxes reuse their ancestor's bound: it holds over them too.  (The field
        # at the centre is unclipped, as L bounds it.)
        if size == FINE:
            lip, fc = parent_lip, _field_by_runs(prog, grid, origins, centre)
            below = above = np.zeros(len(fc))
        else:
            fc, lip, below, above = prog.bound_at(lo, hi, centre).T
        # (taking rows by index: 5x faster than numpy's boolean indexing here)
        keep = np.flatnonzero(keep_boxes(lip, fc, below, above, half_diag, lo, hi, grid.lo,
                                         grid.hi, grid.clip, ISO))
        origins = origins.take(keep, axis=0)
        if size > FINE:
            triangles = len(origins) * size * size * TRIANGLES_PER_CELL
            _check_budget(triangles, 0, grid.h, budget, slack=COARSE_SLACK)
        elif len(origins) * (BYTES_PER_BOX + MAX_TRIANGLES_PER_BOX * BYTES_PER_TRIANGLE) > budget:
            # (sampled only when the most the boxes can give might not fit)
            _check_budget(_estimate_triangles(prog, grid, origins), len(origins), grid.h, budget)
        if size == FINE:  # (the centres' values are the lattice samples there)
            fc = fc.take(keep)
            return origins, grid.clip_values(centre.take(keep, axis=0), fc) if grid.clip else fc
        # boxes below BOUND_MIN get no bound of their own: straight on to the finest
        step = 2 if size > BOUND_MIN else size // FINE
        size //= step
        origins, parent = split(origins, size, step, limit)
        parent_lip = lip.take(keep[parent])


def _estimate_triangles(prog, grid: _Grid, origins: np.ndarray) -> float:
    """Triangles the finest boxes at ``origins`` will give, from the lattice cells the surface
    crosses in a fixed random sample of them."""
    if len(origins) == 0:
        return 0.0
    pick = np.random.default_rng(0).choice(len(origins), min(len(origins), ESTIMATE_SAMPLE),
                                           replace=False)
    steps = np.arange(FINE + 1)
    offsets = np.stack(np.meshgrid(steps, steps, steps, indexing="ij"), -1).reshape(-1, 3)
    points = grid.origin + (origins[pick, None, :] + offsets[None]) * grid.h
    points = points.reshape(-1, 3)
    n = FINE + 1
    inside = (grid.field(prog, points) >= ISO).reshape(len(pick), n, n, n)
    corners = [inside[:, i:i + FINE, j:j + FINE, k:k + FINE]
               for i in (0, 1) for j in (0, 1) for k in (0, 1)]
    crossed = np.any(corners, axis=0) & ~np.all(corners, axis=0)
    return crossed.sum() / len(pick) * len(origins) * TRIANGLES_PER_CROSSED_CELL


def _check_budget(triangles: float, boxes: int, h: float, budget: int,
                  slack: float = 1.0) -> None:
    """ValueError if the estimated peak memory exceeds ``slack`` times ``budget`` bytes."""
    estimate = triangles * BYTES_PER_TRIANGLE + boxes * BYTES_PER_BOX
    if estimate > budget * slack:
        raise ValueError(
            f"resolution too large: the mesh would need about {estimate / 2**30:.1f} GiB "
            f"(about {triangles / 1e6:.0f} M triangles at cell size {h:.4g}), more than the "
            f"{budget / 2**30:.1f} GiB available; use a smaller resolution or larger cell_size")


def _sample(prog, grid: _Grid, culled):
    """From the culled boxes (the finest kept boxes' lattice origins and centre values, as
    :func:`_cull` returns them): lattice values (B, LATTICE_BLOCK+1, LATTICE_BLOCK+1,
    LATTICE_BLOCK+1) of the blocks holding kept boxes, the blocks' origins (B, 3), and the
    boxes whose cells to contour: local coordinates (A, 3), those of block q at
    ``box_start[q]:box_start[q + 1]``, and the program specialised to each block, then to
    everywhere (:func:`_block_regions`; returned as ``values, origins, box_start, boxes,
    regions``).

    1. Every kept box is sampled at its corners and centre (a body-centred lattice of spacing
       ``FINE``: any part of the solid or of its complement that holds a ball of diameter
       1.12 * FINE cells contains one of these samples).
    2. Boxes whose nine samples are not all on one side, and then every kept box across a face
       on which a lattice edge crosses the surface, are sampled whole, until no crossed face
       leads to a box not yet sampled.  Crossings are followed, not searched for.
    3. Only the cells of boxes sampled whole are contoured: every crossed lattice edge lies
       between such boxes (a crossed face leads to another one; culled boxes hold no surface),
       so the contour closes.  A piece of surface inside one box that misses all nine samples
       is lost (see docs/meshing.md).
    """
    kept, kept_value = culled
    nb = grid.blocks
    block, kept_loc = np.divmod(kept, LATTICE_BLOCK)  # each box's block and its place in it
    code = grid.block_code(block)
    order = _by_block(code)  # the kept boxes grouped by block (see gather)
    kept_loc, kept_value, code = kept_loc.take(order, axis=0), kept_value[order], code[order]
    present = np.zeros(int(np.prod(nb)), dtype=bool)
    present[code] = True
    codes = np.flatnonzero(present)  # the blocks holding kept boxes, in order
    block_origins = np.stack(np.unravel_index(codes, tuple(nb)), axis=1) * LATTICE_BLOCK
    block_of = np.full(tuple(nb), -1, dtype=np.int64)
    block_of.reshape(-1)[codes] = np.arange(len(codes))
    kept_slot = block_of.reshape(-1)[code]
    values, sampled, boxmap = new_store(len(codes), LATTICE_BLOCK, FINE, kept_slot, kept_loc,
                                        kept_value)

    regions = _block_regions(prog, grid, block_origins)

    def sample(box_ids, offsets):
        step = max(1, SAMPLE_CHUNK // len(offsets))  # boxes at a time: bounded scratch memory
        for start in range(0, len(box_ids), step):
            flat, points, first = gather(sampled, box_ids[start:start + step], kept_slot,
                                         kept_loc, offsets, block_origins, grid.origin, grid.h)
            f = _field(prog, grid, regions, points, first)
            parallel_for(store, len(flat), flat, f, values.reshape(-1))

    corners = np.stack(np.meshgrid(*([[0, FINE]] * 3), indexing="ij"), -1).reshape(-1, 3)
    whole = np.stack(np.meshgrid(*([np.arange(FINE + 1)] * 3), indexing="ij"), -1)
    whole = whole.reshape(-1, 3)
    sample(np.arange(len(kept)), corners)
    active = seeds(values, kept_slot, kept_loc, FINE, ISO)
    frontier = np.flatnonzero(active)
    while len(frontier):
        sample(frontier, whole)
        frontier = spread(
            values,
            frontier,
            active,
            kept_slot,
            kept_loc,
            boxmap,
            block_of,
            block_origins,
            LATTICE_BLOCK,
            FINE,
            ISO,
        )
    # the boxes sampled whole, by block: no other cell can cross the surface
    boxes_by_block = np.flatnonzero(active)
    box_start = np.searchsorted(kept_slot[boxes_by_block], np.arange(len(codes) + 1))
    return values, block_origins, box_start, kept_loc.take(boxes_by_block, axis=0), regions


def _block_regions(prog, grid: _Grid, block_origins: np.ndarray, anywhere: bool = True):
    """The program specialised to each block at ``block_origins`` (and then to everywhere, for
    points that may have left their block), if the evaluator can run points grouped by
    region (``blobtree.distributed``'s cannot: None)."""
    if not hasattr(prog, "field_grouped"):
        return None
    lo = grid.origin + block_origins * grid.h
    hi = lo + LATTICE_BLOCK * grid.h
    if anywhere:
        lo = np.concatenate([lo, np.full((1, 3), -np.inf)])
        hi = np.concatenate([hi, np.full((1, 3), np.inf)])
    return prog.regions(lo, hi)


def _field_by_runs(prog, grid: _Grid, boxes: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The field at one point inside each box at lattice origins ``boxes``: each run of boxes
    in one block (the octree visits a block's boxes together) through that block's program."""
    if not hasattr(prog, "field_grouped"):
        return prog.field(points)
    block = boxes // LATTICE_BLOCK
    code = grid.block_code(block)
    starts = np.flatnonzero(np.diff(code, prepend=code[:1] - 1))
    regions = _block_regions(prog, grid, block.take(starts, axis=0) * LATTICE_BLOCK, anywhere=False)
    return prog.field_grouped(regions, points, np.r_[starts, len(code)])


def _field(prog, grid: _Grid, regions, points: np.ndarray, first: np.ndarray) -> np.ndarray:
    """The field (clipped as the lattice is) at points grouped by block (block q's at
    first[q]:first[q + 1]), through the blocks' programs where the evaluator has them."""
    f = prog.field(points) if regions is None else prog.field_grouped(regions, points, first)
    return grid.clip_values(points, f)


def _by_block(code: np.ndarray) -> np.ndarray:
    """The order that groups boxes by their block's ``code``, blocks ascending, each block's
    boxes in their order.  The culling leaves each block's boxes together (its octree visits a
    block's boxes one after the other), so this sorts those runs, not the boxes."""
    starts = np.flatnonzero(np.diff(code, prepend=code[:1] - 1))
    lengths = np.diff(np.r_[starts, len(code)])
    runs = np.argsort(code[starts], kind="stable")
    placed = np.cumsum(lengths[runs]) - lengths[runs]  # each run's start once sorted
    return np.arange(len(code)) + np.repeat(starts[runs] - placed, lengths[runs])


def _refine(prog, grid: _Grid, regions, p0, axis, f0, f1, vertex_start):
    """Regula falsi along each vertex's lattice edge (:mod:`._place`): up to ``REFINE_STEPS``
    steps, a vertex leaving once its secant puts the root within ``VERTEX_TOL`` of the edge
    (the vertices come by block, as ``vertex_start`` says).
    Returns the root's parameter t in (0, 1), the final bracket (t_lo, t_hi) (kept 1e-4 from
    the ends) and the points (V, 3) at t."""
    n = len(p0)
    ta, tb = np.zeros(n), np.ones(n)
    ga, gb = f0 - ISO, f1 - ISO
    last = np.zeros(n, dtype=np.int8)
    t, pts = np.empty(n), np.empty((n, 3))
    rows = np.arange(n)
    for _ in range(REFINE_STEPS):
        if len(rows) == 0:
            break
        m = len(rows)
        parallel_for(secant_points, m, rows, p0, axis, grid.h, ta, tb, ga, gb, t, pts)
        g = _field(prog, grid, regions, pts[:m], np.searchsorted(rows, vertex_start)) - ISO
        done = np.empty(m, dtype=bool)
        parallel_for(bracket_step, m, rows, g, t, ta, tb, ga, gb, last, VERTEX_TOL, done)
        rows = rows.compress(~done)
    t_lo, t_hi = np.empty(n), np.empty(n)
    parallel_for(final_roots, n, (ta, tb, ga, gb), t, t_lo, t_hi, (p0, axis, grid.h), pts)
    return t, t_lo, t_hi, pts


def _project(prog, grid: _Grid, p: np.ndarray) -> np.ndarray:
    """Two Newton steps along the gradient towards the iso-surface, each at most half a cell."""
    for _ in range(2):
        if len(p) == 0:
            break
        f, g, _ = prog.evaluate(p)
        g2 = np.einsum("ij,ij->i", g, g)
        step = -np.divide(f - ISO, g2, out=np.zeros_like(g2), where=g2 > 0)[:, None] * g
        norm = np.linalg.norm(step, axis=1)
        p = p + step * np.minimum(1.0, 0.5 * grid.h / np.maximum(norm, 1e-300))[:, None]
    return p


def _normals(grad: np.ndarray, verts: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Unit outward normals -grad f / ``|grad f|``; face normals where the gradient vanishes."""
    normals, flat = np.empty_like(grad), np.empty(len(grad), dtype=bool)
    parallel_for(outward_normals, len(grad), grad, normals, flat)
    if np.any(flat):
        tri = verts[tris]
        fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        acc = np.zeros_like(verts)
        for c in range(3):
            np.add.at(acc, tris[:, c], fn)
        length = np.linalg.norm(acc[flat], axis=1)
        normals[flat] = acc[flat] / np.where(length > 0, length, 1.0)[:, None]
    return normals
