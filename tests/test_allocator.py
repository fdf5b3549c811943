"""The allocator's thresholds (blobtree/runtime/allocator.py): when they are pinned, and what
it buys."""

import os
import subprocess
import sys

import pytest

from blobtree.runtime.allocator import MMAP_THRESHOLD, pin_thresholds

#: arrays of 1 to 3.5 MiB, each larger than the last and freed before the next: glibc's own
#: heuristic serves every one with fresh pages (each above the threshold the last free set);
#: pinned, the heap's freed block is reused and only grows
PROBE = """
import resource, numpy as np
import blobtree
faults = 0
for n in range(2, 8):
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    a = np.ones((n << 19) // 8)
    del a
    faults += resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before
print(faults)
"""


def _faults(**env: str) -> int:
    clean = {k: v for k, v in os.environ.items()
             if k not in ("BLOBTREE_MALLOC", "MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_",
                          "GLIBC_TUNABLES")}
    out = subprocess.run([sys.executable, "-c", PROBE], env={**clean, **env}, check=True,
                         capture_output=True, text=True)
    return int(out.stdout)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's allocator only")
def test_pinned_thresholds_reuse_freed_arrays():
    pages = sum(n << 19 for n in range(2, 8)) // 4096  # every array on fresh pages
    system, pinned = _faults(BLOBTREE_MALLOC="system"), _faults()
    assert system > 0.8 * pages
    assert pinned < 0.4 * pages  # about the largest array's pages: the heap grew to it once


def test_the_users_own_settings_win():
    assert not pin_thresholds({"BLOBTREE_MALLOC": "system"})
    assert not pin_thresholds({"MALLOC_MMAP_THRESHOLD_": str(MMAP_THRESHOLD)})
    assert not pin_thresholds({"GLIBC_TUNABLES": "glibc.malloc.trim_threshold=0"})


def test_a_bad_setting_is_refused():
    with pytest.raises(ValueError, match="BLOBTREE_MALLOC must be 'pinned' or 'system', got 'x'"):
        pin_thresholds({"BLOBTREE_MALLOC": "x"})
