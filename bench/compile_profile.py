"""Where a first run's compiling goes: compile seconds per numba function for one command.

    NUMBA_CACHE_DIR=$(mktemp -d) python bench/compile_profile.py render murex --size 128x128

Runs ``blobtree ARGS...`` in this process with a listener on numba's compile events and prints
each compiled function's own seconds (its compile less the compiles it started), largest first.
With an empty ``NUMBA_CACHE_DIR`` that is the first run's compiling; with a warm cache, nothing.
"""

from __future__ import annotations

import collections
import sys
import time
from pathlib import Path

from numba.core import event

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from blobtree.cli.main import main  # noqa: E402


class _Profile(event.Listener):
    """Exclusive compile seconds and signature counts per function."""

    def __init__(self) -> None:
        self.stack: list[list] = []
        self.seconds: collections.Counter[str] = collections.Counter()
        self.count: collections.Counter[str] = collections.Counter()

    def on_start(self, ev) -> None:
        fn = ev.data["dispatcher"].py_func
        self.stack.append([f"{fn.__module__}.{fn.__qualname__}", time.perf_counter(), 0.0])

    def on_end(self, ev) -> None:
        name, start, inner = self.stack.pop()
        spent = time.perf_counter() - start
        self.seconds[name] += spent - inner
        self.count[name] += 1
        if self.stack:
            self.stack[-1][2] += spent


def run(args: list[str], top: int = 40) -> None:
    """Profile ``blobtree args`` and print the ``top`` functions."""
    profile = _Profile()
    event.register("numba:compile", profile)
    start = time.perf_counter()
    main(args, standalone_mode=False)
    total = time.perf_counter() - start
    print(f"blobtree {' '.join(args)}: {total:.1f} s, {sum(profile.count.values())} signatures "
          f"of {len(profile.count)} functions compiled")
    for name, seconds in profile.seconds.most_common(top):
        print(f"{seconds:7.2f} s  x{profile.count[name]}  {name}")


if __name__ == "__main__":
    run(sys.argv[1:])
