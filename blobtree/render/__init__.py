"""The direct ray tracer: images straight from the field, by segment tracing.

``render`` cuts the image into tiles and renders them with :func:`render_tile`, each tile in
parallel on all cores; the same tiles can be rendered anywhere (see ``blobtree.distributed``) and
assembled into the same bytes.
"""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor, as_completed
from typing import Any

import numpy as np
from numba.core.compiler_lock import global_compiler_lock

from ..checks import Choice
from ..engine import bounds
from ..engine import specialize as specialize_module
from ..engine.batch import rows_walk
from ..engine.bounds import bounded_walk, lipschitz_walk
from ..engine.point import eval_range, point_walk
from ..engine.program import program_of
from ..nodes import Point
from ..nodes.layout import VALUE
from ..runtime import partner
from ..runtime.threads import parallel_for
from ..runtime.threads import threads as parallel_threads
from . import shade as shade_module
from . import tiles as tiles_module
from . import trace as trace_module
from .camera import Camera, seen_camera
from .checkpoint import Checkpoint, job_key
from .image import save_image
from .shade import Light, default_lights, pack_lights
from .tiles import LOOKS, RenderSettings, compile_tracer, render_tile, stop_flag, trace_rect
from .trace import intersect_rays

__all__ = ["LOOKS", "Camera", "Light", "RenderSettings", "Stopped", "intersect", "render",
           "render_tile", "save_image", "stop_flag", "tile_side", "tiles", "warm_kernels",
           "warming"]

Rect = tuple[int, int, int, int]
#: Renders rectangles somewhere: (prog, camera, lights, settings, rects) -> (rect, pixels)...
TileSource = Callable[[Any, Camera, list[Light], RenderSettings, list[Rect]],
                      Iterator[tuple[Rect, np.ndarray]]]

#: Tile sides a render picks from by default (``tile=None``): the largest that still gives every
#: thread ``TILES_PER_THREAD`` tiles.  Each tile costs some 60-80 us of handing out, setting up
#: and collecting (see bench/profile_tiles.py), so large images take 128-pixel tiles; enough
#: tiles keep the cores busy to the end.
TILE_SIDES = (128, 64)
TILES_PER_THREAD = 48
#: A small picture, with fewer than ``FEW_TILES`` tiles of the smallest side per thread, takes
#: tiles halved down to ``SMALL_TILE`` until it has them: a 128x128 picture's four 64-pixel
#: tiles left one of two cores idle for a third of the render (0.176 s, against 0.153 s in
#: sixteen 32-pixel tiles, the Murex's explorer preview; 32 was slower at 512x512).
FEW_TILES, SMALL_TILE = 8, 32


def tile_side(width: int, height: int, threads: int) -> int:
    """The default tile side for a width x height image on ``threads`` cores (see
    :data:`TILE_SIDES` and :data:`FEW_TILES`)."""

    def count(side: int) -> int:
        return -(-width // side) * -(-height // side)

    for side in TILE_SIDES:
        if count(side) >= TILES_PER_THREAD * threads:
            return side
    side = TILE_SIDES[-1]
    while side > SMALL_TILE and count(side) < FEW_TILES * threads:
        side //= 2
    return side


def warm_kernels() -> threading.Thread:
    """Start loading the ray tracer's kernels from numba's cache (compiling them on a first
    run) on another thread, by rendering one pixel of a lone point, and return the thread: the
    loading (0.07-0.1 s, mostly in LLVM, without the GIL) then overlaps whatever the caller
    does next in Python, such as building its scene; a render that starts sooner waits for it
    (numba's compiler lock).  The pixel's errors are not reported: the real render reports its
    own.

    On a first run (the Lipschitz pass missing from the cache) a partner process compiles the
    framing's range entry (:func:`range_unit`), the Lipschitz pass and the tracer
    (:func:`tracer_unit`) while this one compiles the point, bounded and rows walks they call
    (``runtime.partner``): two halves on two cores.  Whether it is a first run is decided
    before this returns (loading the Lipschitz pass, or starting the partner)."""

    # The partner starts here, not on the thread: the caller may reach a kernel the partner
    # compiles within a few tenths of a second (framing a shell runs the range entry), and
    # waits for the partner's copy only once the partner is started.
    first_run = False
    with contextlib.suppress(Exception):
        if not lipschitz_walk.ensure(compile=False):
            first_run = True
            partner.start({RANGE: f"{__name__}:range_unit",
                           lipschitz_walk.symbol: f"{bounds.__name__}:lipschitz_walk",
                           **{getattr(m, name).symbol: f"{m.__name__}:{name}"
                              for m, name in _TRACER_LINKED},
                           TRACER: f"{__name__}:tracer_unit"})

    def run() -> None:
        with contextlib.suppress(Exception):
            if first_run:
                with global_compiler_lock:  # (a render starting meanwhile waits for them)
                    point_walk.ensure()
                    bounded_walk.ensure()
                    rows_walk.ensure()
            trace_rect(*_pixel())

    thread = threading.Thread(target=run, name="blobtree-warm-kernels", daemon=True)
    thread.start()
    return thread


@contextlib.contextmanager
def warming(enabled: bool = True) -> Iterator[None]:
    """:func:`warm_kernels` during the block (if ``enabled``), joined at its end: not left
    loading (or compiling) as the interpreter exits."""
    thread = warm_kernels() if enabled else None
    try:
        yield
    finally:
        if thread is not None:
            thread.join()


def _pixel() -> tuple:
    """trace_rect's arguments for one pixel of a lone point."""
    cam = Camera(eye=(0.0, 0.0, 3.0), target=(0.0, 0.0, 0.0))
    return (Point().program(), cam.packed(1, 1), pack_lights(default_lights(cam)),
            RenderSettings(width=1, height=1), 0, 0, 1, 1)


#: The tracer's kernels compiled on their own (``runtime.linked``), as modules and names: a
#: partner process compiles them before the tracer's kernel (:data:`TRACER`).
_TRACER_LINKED = ((specialize_module, "region_specialize"), (trace_module, "packet_trace"),
                  (shade_module, "packet_shade"), (tiles_module, "cone_packet"))
#: The tracer's kernel, as the partner process's unit is named (``runtime.partner``).
TRACER = partner.kernel_key(tiles_module._render_blocks.py_func)


def tracer_unit() -> None:
    """Compile the tracer's kernels without running them (a partner process's unit)."""
    compile_tracer(*_pixel()[:4])


#: The point walk's range entry, which framing a shell runs (``camera.surface_points``), as the
#: partner process's unit is named: the partner compiles it first, while this process compiles
#: the walks it calls.
RANGE = partner.kernel_key(eval_range.py_func)


def range_unit() -> None:
    """Compile :func:`~blobtree.engine.point.eval_range` for the arguments ``Program.field``
    passes, without running it (a partner process's unit)."""
    args = (0, 0, *Point().program().range_args(np.empty((0, 3)), VALUE))
    eval_range.compile(tuple(eval_range.typeof_pyval(a) for a in args))


def tiles(width: int, height: int, size: int = TILE_SIDES[-1]
          ) -> Iterator[tuple[int, int, int, int]]:
    """The (x0, y0, x1, y1) tiles covering a width x height image, row by row."""
    if not (isinstance(size, int) and size >= 1):
        raise ValueError(f"size must be an integer >= 1, got {size!r}")
    for y0 in range(0, height, size):
        for x0 in range(0, width, size):
            yield x0, y0, min(x0 + size, width), min(y0 + size, height)


def render(tree, width: int, height: int, camera: Camera | None = None,
           lights: Sequence[Light] | None = None, samples: int = 1, shadows: bool = True,
           background: tuple[float, float, float] | None = None, *, look: str = "studio",
           progress: bool = False, tile: int | None = None, threads: int | None = None,
           source: TileSource | None = None, checkpoint: str | os.PathLike | None = None,
           resume: bool = False, **shading) -> np.ndarray:
    """Ray-trace ``tree`` into an (height, width, 3) uint8 sRGB image.

    ``camera`` defaults to a three-quarter view framing the whole surface; ``lights`` to one key
    light; ``samples`` rays per pixel (jittered strata, reproducible); ``look`` one of
    ``LOOKS`` (``"studio"``: soft backdrop, soft shadows, ambient occlusion; ``"glossy"``:
    the same, polished; ``"paper"``: the plain style of the paper's figures); ``background``, an
    RGB triple in [0, 1], replaces the look's backdrop by that plain colour; ``progress`` shows a
    bar over tiles of side ``tile`` (default ``tile_side``'s; the rays of each 8x8-pixel
    cone are traced together, so a tile side that is not a multiple of 8 traces the cones on its
    edges again for each tile that touches them; the pixels are the same); ``threads`` (default:
    numba's thread count) render tiles side by side;
    ``shading`` overrides any field of :class:`~blobtree.RenderSettings` the look sets (``ambient``,
    ``specular``, ``shininess``, ``occlusion``, ``light_radius``, ``sky``...) and the jitter
    ``seed``.

    ``source(prog, camera, lights, settings, rects)``, if given, renders the rectangles elsewhere
    and yields (rect, pixels) as they finish (``blobtree.distributed`` plugs in a Dask cluster
    here; the bytes are the same).  ``checkpoint`` (a directory) keeps each finished tile there;
    ``resume=True`` reuses the tiles a previous, interrupted run of the same job left there (see
    ``blobtree.render.checkpoint.Checkpoint``).
    """
    values = dict(LOOKS[Choice(tuple(LOOKS)).check("look", look)])
    if background is not None:
        values.update(background=background, background_bottom=None)
    values.update(shading)
    settings = RenderSettings(width=width, height=height, samples=samples, shadows=bool(shadows),
                              **values)
    if threads is None:
        threads = parallel_threads()
    if not (isinstance(threads, int) and threads >= 1):
        raise ValueError(f"threads must be an integer >= 1, got {threads!r}")
    prog = program_of(tree)
    if camera is None:
        camera = seen_camera(tree, prog, width, height)
    elif not isinstance(camera, Camera):
        raise ValueError(f"camera must be a blobtree Camera or None, got {camera!r}")
    lights = default_lights(camera) if lights is None else list(lights)
    img = np.empty((height, width, 3), dtype=np.uint8)
    store = None
    if checkpoint is not None:
        store = Checkpoint(checkpoint, job_key(prog, camera, lights, settings), resume=resume)
        tile = store.held_tile if tile is None else tile
    elif resume:
        raise ValueError("resume=True needs a checkpoint directory (checkpoint=None given)")
    if tile is None:
        tile = tile_side(width, height, threads)
    rects = list(tiles(width, height, tile))
    if store is not None:
        store.tile = tile
        rects = store.restore(img, rects)
    if source is None:
        done = local_tiles(prog, camera, lights, settings, rects, threads)
    else:
        done = source(prog, camera, lights, settings, rects)
    bar = None
    try:
        with contextlib.closing(done):
            for (x0, y0, x1, y1), pixels in done:
                img[y0:y1, x0:x1] = pixels
                if store is not None:
                    store.save((x0, y0, x1, y1), pixels)
                if progress and bar is None:  # from the first tile: no estimate from compiling
                    from tqdm.auto import tqdm  # lazily: it imports asyncio (~20 ms a command)

                    bar = tqdm(total=len(rects), initial=1, unit="tile", desc="render",
                               leave=False)
                elif bar is not None:
                    bar.update()
    finally:
        if bar is not None:
            bar.close()
    return img


class Stopped(Exception):
    """A render given up: the ``stop`` flag of :func:`local_tiles` was set."""


def local_tiles(prog, camera: Camera, lights: list[Light], settings: RenderSettings,
                 rects: list[tuple[int, int, int, int]], threads: int,
                 stop: np.ndarray | None = None
                 ) -> Iterator[tuple[tuple[int, int, int, int], np.ndarray]]:
    """Render ``rects`` on ``threads`` cores of this machine, yielding (rect, pixels) as tiles
    finish.  ``stop`` (:func:`stop_flag`), once another thread sets it, gives the render up:
    the running tiles end at their next packet of 8x8 pixels, and this raises
    :class:`Stopped` instead of yielding another tile.  Closing the iterator drops the tiles
    not started and stops the running ones so (a render interrupted ends in a few
    milliseconds, not once its running tiles are done)."""
    cam = camera.packed(settings.width, settings.height)
    packed = pack_lights(lights)
    if stop is None:
        stop = stop_flag()
    # Each tile runs on one core without the GIL; a pool hands tiles out as cores free up.
    pool = ThreadPoolExecutor(max_workers=threads)
    try:
        futures = {pool.submit(trace_rect, prog, cam, packed, settings, *r, stop): r
                   for r in rects}
        for done in as_completed(futures):
            pixels = done.result()
            if stop[0] != 0:  # (the tile may be unfinished)
                raise Stopped("the render was stopped")
            yield futures[done], pixels
    finally:
        stop[0] = 1
        pool.shutdown(wait=True, cancel_futures=True)


def intersect(tree, origins: np.ndarray, directions: np.ndarray,
              tmax: float | np.ndarray = np.inf) -> np.ndarray:
    """Distance t (in units of |direction|) to the first surface hit of each ray, NaN on a miss.

    ``origins`` and ``directions`` are (N, 3); ``tmax`` caps t (a scalar or (N,)).
    """
    prog = program_of(tree)
    o = np.ascontiguousarray(origins, dtype=np.float64)
    d = np.ascontiguousarray(directions, dtype=np.float64)
    if o.ndim != 2 or o.shape[1] != 3 or not np.all(np.isfinite(o)):
        raise ValueError(f"origins must be a finite (N, 3) array, got shape {o.shape}")
    if d.shape != o.shape or not np.all(np.isfinite(d)) or np.any(np.all(d == 0.0, axis=1)):
        raise ValueError(f"directions must be finite non-zero vectors of shape {o.shape}, "
                         f"got shape {d.shape}")
    tm = np.broadcast_to(np.asarray(tmax, dtype=np.float64), (len(o),)).copy()
    if np.any(np.isnan(tm)) or np.any(tm < 0.0):
        raise ValueError(f"tmax must be >= 0, got {tmax!r}")
    lo, hi = (np.asarray(b, dtype=np.float64) for b in prog.bounds)
    eps = 1e-6 * float(np.linalg.norm(hi - lo))
    out = np.empty(len(o))
    parallel_for(intersect_rays, len(o), prog.arrays, prog.depth, (o, d), (lo, hi), tm, eps, out)
    return out
