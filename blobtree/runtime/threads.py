"""Running a compiled kernel over parts of a range on all cores.

The batch kernels release the GIL (``nogil=True``) and take the part of the work they do as
``(start, stop)``; :func:`parallel_for` hands the parts to a pool of threads.  This replaces
numba's ``parallel=True`` loops, whose compilation costs seconds per kernel on a first run,
with the same speed for work cut into a few large parts.  The number of threads is numba's
(``NUMBA_NUM_THREADS``), so a process told to use one core uses one.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numba
from numba.np.ufunc import parallel as numba_threading

#: Parts per thread: a little more than one, so uneven parts even out.
PARTS_PER_THREAD = 4

_pool: ThreadPoolExecutor | None = None
_pool_size = 0
_lock = threading.Lock()


def threads() -> int:
    """How many threads kernels run on: numba's count, ``NUMBA_NUM_THREADS`` unless
    ``numba.set_num_threads`` changed it, read without starting numba's own pool of threads
    (17-28 ms of every command, and the kernels never use that pool): until the pool starts,
    no ``set_num_threads`` has run (it starts the pool), so the count is numba's setting."""
    if getattr(numba_threading, "_is_initialized", True):
        return numba.get_num_threads()
    return numba.config.NUMBA_NUM_THREADS


def _executor(n: int) -> ThreadPoolExecutor:
    global _pool, _pool_size
    with _lock:
        if _pool is None or _pool_size != n:
            if _pool is not None:
                _pool.shutdown(wait=False)
            _pool, _pool_size = ThreadPoolExecutor(max_workers=n,
                                                   thread_name_prefix="blobtree"), n
        return _pool


#: Fewest items worth handing to another thread.
MIN_PART = 64


def parallel_for(kernel: Callable[..., Any], n: int, *args: Any, parts: int | None = None,
                 grain: int = MIN_PART) -> None:
    """``kernel(start, stop, *args)`` for consecutive parts covering ``range(n)``, on all cores.

    The kernel must release the GIL to run in parallel; it writes its results into arrays among
    ``args``.  ``parts`` sets how finely the range is cut (default: a few parts per thread, none
    smaller than ``grain`` items: 1 where an item is itself a large piece of work).
    """
    parallel_map(kernel, n, *args, parts=parts, grain=grain)


def parallel_map(kernel: Callable[..., Any], n: int, *args: Any, parts: int | None = None,
                 grain: int = MIN_PART) -> list[Any]:
    """:func:`parallel_for`, returning what the kernel returned for each part, in order (none
    for n <= 0)."""
    k = threads()
    if parts is None:
        parts = min(PARTS_PER_THREAD * k, -(-n // grain))
    parts = max(1, min(n, parts))
    if n <= 0:
        return []
    if k == 1 or parts == 1:
        return [kernel(0, n, *args)]
    cuts = [n * i // parts for i in range(parts + 1)]
    futures = [_executor(k).submit(kernel, a, b, *args)
               for a, b in zip(cuts[:-1], cuts[1:], strict=True) if b > a]
    return [f.result() for f in futures]
