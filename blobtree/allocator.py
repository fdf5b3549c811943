"""The C allocator's thresholds for large blocks, pinned where glibc's own heuristic ends up.

glibc's ``malloc`` serves a block above ``M_MMAP_THRESHOLD`` (128 KiB at start) with fresh pages
from ``mmap`` and unmaps them on ``free``; it raises the threshold (at most to 32 MiB) only as
such blocks are freed, and returns the free top of its heap to the system beyond
``M_TRIM_THRESHOLD``.  Numpy takes its arrays from ``malloc``, and the mesher and the engine make
many short-lived arrays of a few MiB, so most of them were fresh pages, each page a fault on
first touch: ``polygonize(whorl126, 256)`` took 13,000 minor faults and 185 ms, and with the
thresholds pinned at glibc's own maxima (32 MiB, and twice that for trimming) 300 faults and
152 ms (the Murex at 512: 4.85 s -> 4.72 s; rendering and the engine's 10^7 points unchanged).
The cost: a process keeps up to 64 MiB of freed memory for reuse instead of returning it.

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
#: free memory at the heap's top kept for reuse (glibc's heuristic: twice the mmap threshold)
TRIM_THRESHOLD = 2 * MMAP_THRESHOLD
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
    return bool(libc.mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)
                and libc.mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD))
