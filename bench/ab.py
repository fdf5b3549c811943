"""A/B timing of two commits on a noisy machine: both render the same scene at the same time, each
pinned to its own core, so both meet the same machine (clock, neighbours); the cores swap every
round.  Timings of one process alone here drift by 10-20% between runs, more than most changes
worth measuring; paired runs agree within a few percent.

    python bench/ab.py BASE [NEW] [--model murex] [--size 256] [--rounds 3]
                       [--task render|mesh|live|studio]
                       [--threads 1|all] [--best 1]

BASE and NEW are git revisions (NEW defaults to the working tree); each is checked out into a
temporary worktree with its own numba cache, compiled once before timing.  Prints each round's
CPU seconds (one thread each) and NEW / BASE: for ``--task render`` (the default) a render
without and with shadows; for ``--task mesh`` ``polygonize`` at resolution ``--size`` and the
field at that mesh's vertices (one batch).

``--task live`` times ``bench/bench_live.py``'s changes of a spec (``--model``: a shipped spec)
as the explorer's first picture at ``--size`` pixels (``live.DRAFT`` where the checkout has
it, else without shadows): the tree, program and framing (the parts ``LiveShell.timings``
reports; wall seconds) and the whole picture, each summed over the changes; ``--task studio``
the explorer's sharp picture of the spec (the studio look) at ``--size`` pixels, without and
with shadows.

``--threads all`` measures what one thread cannot see (parallel overheads): the two checkouts
then run one after the other, alternating, each on all cores, and each round prints wall
seconds (the best of ``--best`` runs in one process) instead of CPU seconds.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: Run in each checkout: warm up (compile or load the kernels), then time the two measures.
PRELUDE = """
import os, sys, time
if int(sys.argv[1]) >= 0:
    os.sched_setaffinity(0, {int(sys.argv[1])})
clock = time.process_time if int(sys.argv[1]) >= 0 else time.perf_counter
best = int(sys.argv[4])
from blobtree.cli.scenes import resolve_scene
"""
#: Times ``picture(shadows)`` (defined by the workload before it) without and with shadows.
SHADOWS = """
out = []
for shadows in (False, True):
    times = []
    for _ in range(best):
        start = clock()
        picture(shadows)
        times.append(clock() - start)
    out.append(min(times))
print(*out)
"""
WORKLOADS = {"render": PRELUDE + """
from blobtree.render import render
from blobtree.render.camera import seen_camera
tree = resolve_scene(sys.argv[2])
prog = tree.program()
size = int(sys.argv[3])
cam = seen_camera(tree, prog, size, size)
render(prog, 32, 32, camera=cam)
picture = lambda shadows: render(prog, size, size, camera=cam, shadows=shadows)
""" + SHADOWS, "mesh": PRELUDE + """
import numpy as np
from blobtree.mesh.polygonizer import polygonize
prog = resolve_scene(sys.argv[2]).program()
size = int(sys.argv[3])
polygonize(prog, 32)
prog.evaluate(np.repeat([0.5 * (prog.bounds[0] + prog.bounds[1])], 30000, axis=0))
out = [[], []]
for _ in range(best):
    start = clock()
    mesh = polygonize(prog, size)
    out[0].append(clock() - start)
    start = clock()
    prog.field(mesh.vertices)
    out[1].append(clock() - start)
print(min(out[0]), min(out[1]))
""", "live": PRELUDE + """
from bench.bench_live import CHANGES
import blobtree.live
from blobtree.live import LiveShell, with_control
from blobtree.models.spec import load_spec
base = load_spec(sys.argv[2])
size = int(sys.argv[3])
live = LiveShell(base)
draft = getattr(blobtree.live, "DRAFT", {"shadows": False})
live.picture(size, size, **draft)
out = [0.0, 0.0]
for name, value in CHANGES:
    times = []
    for r in range(best):  # a new value each run: nothing kept from the run before
        live.set(with_control(base, name, value * (1.0 + 0.001 * r)))
        start = clock()
        live.picture(size, size, **draft)
        t = live.timings
        times.append((t["tree"] + t["program"] + t["framing"], clock() - start))
    out[0] += min(times)[0]
    out[1] += min(times, key=lambda x: x[1])[1]
print(*out)
""", "studio": PRELUDE + """
from blobtree.live import LiveShell
from blobtree.models.spec import load_spec
live = LiveShell(load_spec(sys.argv[2]))
size = int(sys.argv[3])
live.picture(32, 32)
picture = lambda shadows: live.picture(size, size, shadows=shadows)
""" + SHADOWS}
#: What each task's two numbers are.
MEASURES = {"render": ("no shadows", "shadows"), "mesh": ("polygonize", "field at vertices"),
            "live": ("tree, program and framing", "first picture"),
            "studio": ("no shadows", "shadows")}


@contextlib.contextmanager
def checkouts(revs: list[str | None], prefix: str) -> Iterator[tuple[list[Path], Path]]:
    """Worktrees of ``revs`` (the working tree itself for None) and a scratch directory, all
    under a temporary directory named ``prefix``...; removed at the end."""
    tmp = Path(tempfile.mkdtemp(prefix=prefix))
    dirs: list[Path] = []
    try:
        for rev in revs:
            if rev is None:
                dirs.append(ROOT)
                continue
            dirs.append(tmp / rev.replace("/", "_"))
            subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "-q",
                            str(dirs[-1]), rev], check=True)
        yield dirs, tmp
    finally:
        for d in dirs:
            if d != ROOT:
                subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(d)],
                               check=False)
        shutil.rmtree(tmp, ignore_errors=True)


def run(dirs: list[Path], caches: list[Path], tmp: Path, task: str, model: str,
        core_shift: int, size: int, alone: bool, best: int) -> list[list[float]]:
    """Both checkouts' seconds (the task's two measures): CPU seconds of runs at the same time,
    checkout k pinned to core (k + core_shift) % 2; with ``alone``, wall seconds of runs one
    after the other on all cores, checkout core_shift % 2 first."""
    def start(k: int) -> subprocess.Popen:
        d, c = dirs[k], caches[k]
        env = {**os.environ, "PYTHONPATH": str(d), "NUMBA_CACHE_DIR": str(c)}
        if not alone:
            env["NUMBA_NUM_THREADS"] = "1"
        core = -1 if alone else (k + core_shift) % 2
        return subprocess.Popen(
            [sys.executable, "-c", WORKLOADS[task], str(core), model, str(size), str(best)],
            cwd=tmp, stdout=subprocess.PIPE, text=True, env=env)

    def result(p: subprocess.Popen) -> list[float]:
        out, _ = p.communicate()
        if p.returncode:
            sys.exit(f"a {task} run failed (exit {p.returncode})")
        return [float(v) for v in out.split()]

    if not alone:
        procs = [start(k) for k in range(2)]
        return [result(p) for p in procs]
    times: list[list[float]] = [[], []]
    for k in ((0, 1) if core_shift % 2 == 0 else (1, 0)):
        times[k] = result(start(k))
    return times


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("base")
    ap.add_argument("new", nargs="?", default=None)
    ap.add_argument("--model", default="murex")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--task", choices=sorted(WORKLOADS), default="render")
    ap.add_argument("--threads", choices=("1", "all"), default="1",
                    help="1: both at once, one core each (CPU seconds); all: one after the "
                         "other on all cores (wall seconds)")
    ap.add_argument("--best", type=int, default=1, help="runs per round, the best one counted")
    args = ap.parse_args()
    if args.size < 32 or args.rounds < 1 or args.best < 1:
        ap.error(f"--size must be at least 32 (got {args.size}), --rounds and --best at least "
                 f"1 (got {args.rounds}, {args.best})")
    alone = args.threads == "all"
    if len(os.sched_getaffinity(0)) < 2:
        sys.exit("ab.py needs two cores")
    with checkouts([args.base, args.new], "blobtree-ab-") as (dirs, tmp):
        caches = [tmp / f"cache{k}" for k in range(2)]
        run(dirs, caches, tmp, args.task, args.model, 0, 32, alone, 1)  # compile, untimed
        ratios = []
        names = MEASURES[args.task]
        how = ("all threads, one after the other, wall seconds" if alone
               else "one thread each, CPU seconds")
        print(f"{args.task} {args.model} at {args.size}, {how}, best of {args.best} "
              f"({names[0]}, {names[1]})")
        for r in range(args.rounds):
            (a0, a1), (b0, b1) = run(dirs, caches, tmp, args.task, args.model, r, args.size,
                                     alone, args.best)
            ratios.append((b0 / a0, b1 / a1))
            print(f"round {r + 1}: base {a0:.2f} {a1:.2f}   new {b0:.2f} {b1:.2f}   "
                  f"new/base {b0 / a0:.3f} {b1 / a1:.3f}")
        for k, name in enumerate(names):
            values = sorted(v[k] for v in ratios)
            print(f"median new/base, {name}: {values[len(values) // 2]:.3f}")


if __name__ == "__main__":
    main()
