"""Scale-out on Dask ``distributed`` (the optional extra ``blobtree[dask]``).

A render is cut into tiles (:func:`blobtree.render.tiles`), each rendered by
:func:`blobtree.render.render_tile` on some worker: tiles are byte-identical however the image is
cut, so the assembled image equals the local one.  A mesh sends its batched field evaluations
(culling bounds, lattice sampling, vertex placement) to the workers in chunks large enough to take
the same evaluation path as locally, so it equals the local mesh.  The tree travels as its scene
file text; each worker process compiles a scene once and keeps the program, keyed by the text's
hash.  A worker lost mid-job only delays it: Dask reruns its tasks elsewhere.  A film
(:mod:`blobtree.film`) sends each frame as one task: the worker builds the shell at the frame's
age and renders it whole, with the same bytes as locally.

This module sits above the renderer and the mesher and plugs into them: :func:`render` gives
``blobtree.render.render`` a source of remote tiles, :func:`polygonize` gives
``blobtree.mesh.polygonize`` an evaluator whose batches run on the cluster.  ``distributed`` is
imported only when a cluster is used: the core never needs it.
"""

from __future__ import annotations

import contextlib
import hashlib
import threading
from collections import OrderedDict
from collections.abc import Iterator, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from . import mesh
from . import render as raytrace
from .engine import GRID_MIN_POINTS, Program
from .film import Film
from .io import dumps, loads
from .nodes import Node
from .render import Camera, Light, RenderSettings, render_tile

if TYPE_CHECKING:
    from distributed import Client

Rect = tuple[int, int, int, int]

#: Seconds to wait for a scheduler before giving up.
CONNECT_TIMEOUT = 10.0
#: Compiled programs kept per worker process (most recently used scenes).
CACHE_SCENES = 4
#: Evaluation chunks per worker for a mesh (more than one balances uneven chunks).
CHUNKS_PER_WORKER = 4

_PROGRAMS: OrderedDict[str, Program] = OrderedDict()
_PROGRAMS_LOCK = threading.Lock()


def _distributed():
    """The ``distributed`` module, or ImportError saying how to install it."""
    try:
        import distributed
    except ImportError as exc:
        raise ImportError("a Dask cluster needs the optional extra: pip install 'blobtree[dask]'"
                          ) from exc
    return distributed


def scene_text(tree: Node) -> str:
    """The scene-file text a tree travels as; ValueError for anything but a tree."""
    if not isinstance(tree, Node):
        raise ValueError(f"a Dask job needs a BlobTree node (its scene file is sent to the "
                         f"workers), got {type(tree).__name__}")
    return dumps(tree)


def _scene(text: str) -> str:
    """Worker task holding the scene text: unlike scattered data, Dask recomputes it if every
    worker holding it is lost."""
    return text


def send_scene(client: Client, tree: Node) -> Any:
    """A future of the tree's scene text on the cluster, for tasks to take as an argument."""
    return client.submit(_scene, scene_text(tree), pure=False)


def worker_program(text: str) -> Program:
    """The compiled program of a scene text, compiled once per process (LRU of scenes)."""
    key = hashlib.sha256(text.encode()).hexdigest()
    with _PROGRAMS_LOCK:  # a worker may run tasks on several threads
        prog = _PROGRAMS.pop(key, None)
        if prog is None:
            prog = loads(text).program()
        _PROGRAMS[key] = prog
        while len(_PROGRAMS) > CACHE_SCENES:
            _PROGRAMS.popitem(last=False)
    return prog


@contextlib.contextmanager
def connect(scheduler: str | Client | None = None, workers: int | None = None,
            timeout: float | None = None) -> Iterator[Client | None]:
    """A Dask client: ``scheduler`` (an address "tcp://HOST:PORT", or a Client used as is), or
    a new local cluster of ``workers`` single-threaded processes, or None (the local engine)
    when neither is given.  Closes what it opened.  ``timeout``: seconds to wait for the
    scheduler (default ``CONNECT_TIMEOUT``)."""
    timeout = CONNECT_TIMEOUT if timeout is None else timeout
    if scheduler is not None and workers is not None:
        raise ValueError(f"give either scheduler or workers, not both (got scheduler="
                         f"{scheduler!r}, workers={workers!r})")
    if scheduler is None and workers is None:
        yield None
        return
    dd = _distributed()
    if isinstance(scheduler, dd.Client):
        yield scheduler
        return
    if workers is not None:
        if isinstance(workers, bool) or not (isinstance(workers, int) and workers >= 1):
            raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
        # one core per process: numba's own threads would compete with the other workers
        with dd.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                             dashboard_address=":0", env={"NUMBA_NUM_THREADS": "1"}
                             ) as cluster, dd.Client(cluster) as client:
            yield client
        return
    if not (isinstance(scheduler, str) and scheduler):
        raise ValueError(f"scheduler must be an address such as 'tcp://HOST:8786' or a "
                         f"distributed.Client, got {scheduler!r}")
    try:
        client = dd.Client(scheduler, timeout=timeout)
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        raise ValueError(f"scheduler {scheduler!r}: cannot connect within {timeout:g} s "
                         f"({type(exc).__name__}: {exc})") from None
    with client:
        yield client


def describe(client: Client) -> str:
    """The cluster a client uses: scheduler address and number of workers."""
    nthreads = client.nthreads()
    return (f"cluster: {client.scheduler.address}, {len(nthreads)} workers, "
            f"{sum(nthreads.values())} threads")


# ----- rendering ----------------------------------------------------------------------------
def _render_tile(text: str, camera: Camera, lights: list[Light], settings: RenderSettings,
                 rect: Rect) -> np.ndarray:
    """Worker task: one tile of the image."""
    return render_tile(worker_program(text), camera, lights, settings, *rect)


def remote_tiles(scheduler: str | Client, tree: Node, camera: Camera, lights: Sequence[Light],
                 settings: RenderSettings, rects: Sequence[Rect]
                 ) -> Iterator[tuple[Rect, np.ndarray]]:
    """Render ``rects`` on the cluster, yielding (rect, pixels) as tiles finish.

    Closing the iterator early (an error, Ctrl-C) cancels the tiles not yet done.
    """
    scene_text(tree)  # checked before connecting
    dd = _distributed()
    with connect(scheduler) as client:
        scene = send_scene(client, tree)
        futures = {client.submit(_render_tile, scene, camera, list(lights), settings, rect,
                                 pure=False): rect for rect in rects}
        try:
            for future in dd.as_completed(list(futures)):
                yield futures.pop(future), future.result()
        finally:
            client.cancel(list(futures))


# ----- films --------------------------------------------------------------------------------
def _film_frame(film: Film, i: int) -> np.ndarray:
    """Worker task: one frame of a film (its shell built and compiled on the worker)."""
    return film.frame(i)


def remote_frames(scheduler: str | Client, film: Film, indices: Sequence[int]
                  ) -> Iterator[tuple[int, np.ndarray]]:
    """Render a film's frames ``indices`` on the cluster, one task each, yielding (index,
    pixels) as they finish (``blobtree.film.make_film``'s source).  A worker lost mid-frame
    costs that frame: Dask runs it again elsewhere.  Closing the iterator early (an error,
    Ctrl-C) cancels the frames not yet done."""
    dd = _distributed()
    with connect(scheduler) as client:
        futures = {client.submit(_film_frame, film, i, pure=False): i for i in indices}
        try:
            for future in dd.as_completed(list(futures)):
                yield futures.pop(future), future.result()
        finally:
            client.cancel(list(futures))


# ----- meshing ------------------------------------------------------------------------------
def _evaluate(text: str, method: str, *arrays: np.ndarray) -> Any:
    """Worker task: ``Program.<method>(*arrays)`` for the scene."""
    return getattr(worker_program(text), method)(*arrays)


class RemoteProgram:
    """A program whose batched evaluations (``field``, ``evaluate``, ``bound_at``) run on the
    cluster, giving the same values as the local program: chunks of at least
    ``GRID_MIN_POINTS`` rows (or the whole batch when smaller) take the same evaluation path as
    the whole batch would."""

    def __init__(self, client: Client, tree: Node):
        self.client = client
        self.bounds = tree.program().bounds
        self.scene = send_scene(client, tree)
        self.parts = CHUNKS_PER_WORKER * max(1, len(client.nthreads()))

    def _map(self, method: str, *arrays: np.ndarray) -> list[Any]:
        n = len(arrays[0])
        k = min(self.parts, max(1, n // GRID_MIN_POINTS))
        bounds = np.linspace(0, n, k + 1).astype(np.int64)
        futures = [self.client.submit(_evaluate, self.scene, method,
                                      *(a[i:j] for a in arrays), pure=False)
                   for i, j in zip(bounds[:-1], bounds[1:], strict=True)]
        try:
            return self.client.gather(futures)
        finally:
            self.client.cancel(futures)

    def field(self, points: np.ndarray) -> np.ndarray:
        """Field values (N,) at (N, 3) points."""
        return np.concatenate(self._map("field", points))

    def evaluate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(field, gradient, colour) at (N, 3) points."""
        parts = self._map("evaluate", points)
        return tuple(np.concatenate([p[i] for p in parts]) for i in range(3))

    def bound_at(self, lo: np.ndarray, hi: np.ndarray, at: np.ndarray) -> np.ndarray:
        """``Program.bound_at``: per box [lo, hi] (M, 3) holding its point ``at``, the field
        there, a bound on ``|grad f|`` over the box and how far the field stays below and above
        0.5 (M, 4)."""
        return np.concatenate(self._map("bound_at", lo, hi, at))


def polygonize(scheduler: str | Client, tree: Node, **options: Any) -> mesh.Mesh:
    """:func:`blobtree.mesh.polygonize` with its field evaluations on a Dask cluster."""
    scene_text(tree)  # checked before connecting
    with connect(scheduler) as client:
        return mesh.polygonize(RemoteProgram(client, tree), **options)


def render(scheduler: str | Client, tree: Node, *args: Any, **options: Any) -> np.ndarray:
    """:func:`blobtree.render.render` with its tiles rendered on a Dask cluster."""
    scene_text(tree)  # checked before connecting

    def tiles(prog, camera, lights, settings, rects):
        return remote_tiles(scheduler, tree, camera, lights, settings, rects)

    return raytrace.render(tree, *args, source=tiles, **options)
