"""The C allocator's thresholds for large blocks: freed arrays kept for reuse, not unmapped.

glibc's ``malloc`` serves a block above ``M_MMAP_THRESHOLD`` (128 KiB at start) with fresh pages
from ``mmap`` when its heap has no free block that large, and unmaps them on ``free``; it raises
the threshold (at most to 32 MiB) only as such blocks are freed, and returns the free top of its
heap to the system beyond ``M_TRIM_THRESHOLD`` (twice the mmap threshold).  Numpy takes its
arrays from ``malloc``, and the mesher and the engine make many short-lived arrays of a few to a
few hundred MiB, so with glibc's defaults most of them are fresh pages, each page a fault and a
zeroing on first touch.  With the mmap threshold pinned at glibc's own maximum (32 MiB) and the
heap's free top kept up to ``TRIM_THRESHOLD`` (256 MiB, or 1/32 of the machine's memory if
less), repeated meshing reuses its memory: ``polygonize(whorl126, 256)`` takes about 260 page
faults where the defaults take 13,000 (tests/test_allocator.py checks the reuse,
bench/bench_mesh.py times meshing); rendering and the engine are unaffected.  The cost: a
process keeps up to ``TRIM_THRESHOLD`` of freed memory for reuse instead of returning it.

:func:`pin_thresholds` runs when blobtree is imported.  It does nothing where the C library is
not glibc, where the user has set glibc's own variables (``MALLOC_MMAP_THRESHOLD_``,
``MALLOC_TRIM_THRESHOLD_``, ``GLIBC_TUNABLES``), or with ``BLOBTREE_MALLOC=system``.
"""

from __future__ import annotations

import ctypes
import os
from collections.abc import Mapping

#: blocks up to this size come from the heap and are reused (glibc's maximum for its heuristic)
MMAP_THRESHOLD = 32 << 20
#: free memory at the heap's top kept for reuse, at most (and at most 1/32 of the machine's):
#: at 64 MiB whorl126's mesh at 256 is trimmed and mapped afresh on every call, at 128 MiB its
#: mesh at 512; 512 MiB gains nothing more
TRIM_THRESHOLD = 256 << 20
#: mallopt's parameter numbers (malloc.h)
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
#: environment variables through which a user sets the allocator; any of them leaves it alone
USER_SETTINGS = ("MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_", "GLIBC_TUNABLES")


def pin_thresholds(environ: Mapping[str, str] = os.environ) -> bool:
    """Set glibc's mmap and trim thresholds (see the module's docstring); whether it did."""
    choice = environ.get("BLOBTREE_MALLOC", "pinned")
    if choice not in ("pinned", "system"):
        raise ValueError(f"BLOBTREE_MALLOC must be 'pinned' or 'system', got {choice!r}")
    if choice == "system" or any(name in environ for name in USER_SETTINGS):
        return False
    try:
        libc = ctypes.CDLL(None)
        libc.gnu_get_libc_version  # noqa: B018  (only glibc has it)
    except (OSError, AttributeError):
        return False
    memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    return bool(libc.mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)
                and libc.mallopt(M_TRIM_THRESHOLD, min(TRIM_THRESHOLD, memory // 32)))
