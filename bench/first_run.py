"""A first run's wait: each command run twice as a new user would, from an empty numba cache,
for one or more commits, alternating between them round by round (the machine drifts).

    python bench/first_run.py [REV ...] [--rounds 1]

Each REV (default: the working tree) is checked out into a temporary worktree; in each round
each checkout gets a new empty ``NUMBA_CACHE_DIR`` and runs, as processes, ``blobtree render
murex --size 128x128``, ``render whorl126 --size 128x128`` and ``mesh whorl126 --resolution
64`` in that order, each twice.  Prints the wall seconds of each first and second run, the
first's extra seconds, and the three commands' extra together.  ``--record`` appends the last
REV's median extra seconds, with the first REV's as the peer, to the bench record.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import record  # noqa: E402
from ab import checkouts  # noqa: E402

#: The commands timed, in order, as a new user runs them.
COMMANDS = (["render", "murex", "--size", "128x128", "-o", "murex.png"],
            ["render", "whorl126", "--size", "128x128", "-o", "whorl126.png"],
            ["mesh", "whorl126", "--resolution", "64", "-o", "whorl126.ply"])


def timed_run(code: Path, cache: Path, work: Path, args: list[str]) -> float:
    """Wall seconds of ``blobtree ARGS`` from checkout ``code`` with numba cache ``cache``."""
    env = {**os.environ, "PYTHONPATH": str(code), "NUMBA_CACHE_DIR": str(cache)}
    start = time.perf_counter()
    run = subprocess.run([sys.executable, "-m", "blobtree.cli.main", *args], cwd=work,
                         env=env, capture_output=True, text=True)
    if run.returncode:
        sys.exit(f"blobtree {' '.join(args)} failed:\n{run.stderr[-2000:]}")
    return time.perf_counter() - start


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("revs", nargs="*", help="git revisions (default: the working tree)")
    ap.add_argument("--rounds", type=int, default=1)
    record.add_arguments(ap)
    args = ap.parse_args()
    path = record.target(args)
    m = record.machine()
    print(f"{m['cpu']} ({m['cores']} cores, {m['simd']}); wall seconds, first / second run, "
          "each round from an empty numba cache")
    revs = args.revs or [None]
    extra: list[list[list[float]]] = [[] for _ in revs]  # per rev, per round: per command
    with checkouts(revs, "blobtree-first-run-") as (dirs, tmp):
        for r in range(args.rounds):
            for k in (range(len(revs)) if r % 2 == 0 else reversed(range(len(revs)))):
                cache, work = tmp / f"cache-{k}-{r}", tmp / f"work-{k}-{r}"
                work.mkdir()
                extras, cells = [], []
                for command in COMMANDS:
                    first, second = (timed_run(dirs[k], cache, work, command) for _ in range(2))
                    extras.append(first - second)
                    cells.append(f"{' '.join(command[:2])} {first:.1f} / {second:.1f}")
                extra[k].append(extras)
                print(f"round {r + 1}, {revs[k] or 'working tree'}: {'; '.join(cells)}; "
                      f"extra: render murex {extras[0]:.1f} s, the three {sum(extras):.1f} s",
                      flush=True)
    if path is not None:
        record.append("first_run.py", _rows(revs, extra), path)


def _rows(revs: list[str | None], extra: list[list[list[float]]]) -> list[dict]:
    """The record's rows: the median extra seconds of the last rev, the first rev's as peer."""
    peer = f"commit {revs[0]}" if len(revs) > 1 and revs[0] else None
    note = f"empty numba cache; median of {len(extra[-1])} rounds alternating with the peer"
    rows = []
    for label, pick in ((" ".join(COMMANDS[0][:4]), lambda e: e[0]),
                        ("render murex, render whorl126, mesh whorl126", sum)):
        new, base = (statistics.median([pick(e) for e in runs]) for runs in (extra[-1], extra[0]))
        rows.append(record.row(f"first run beyond the second: {label}", new,
                               peer, base if peer else None, note))
    return rows


if __name__ == "__main__":
    main()
