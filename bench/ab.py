"""A/B timing of two commits on a noisy machine: both render the same scene at the same time, each
pinned to its own core, so both meet the same machine (clock, neighbours); the cores swap every
round.  Timings of one process alone here drift by 10-20% between runs, more than most changes
worth measuring; paired runs agree within a few percent.

    python bench/ab.py BASE [NEW] [--model murex] [--size 256] [--rounds 3] [--task mesh]

BASE and NEW are git revisions (NEW defaults to the working tree); each is checked out into a
temporary worktree with its own numba cache, compiled once before timing.  Prints each round's
CPU seconds (one thread each) and NEW / BASE: for ``--task render`` (the default) a render
without and with shadows; for ``--task mesh`` ``polygonize`` at resolution ``--size`` and the
field at that mesh's vertices (one batch).
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: Run in each checkout: warm up (compile or load the kernels), then time the two measures.
PRELUDE = """
import os, sys, time
os.sched_setaffinity(0, {int(sys.argv[1])})
from blobtree.cli.scenes import resolve_scene
"""
WORKLOADS = {"render": PRELUDE + """
from blobtree.render import render
from blobtree.render.camera import seen_camera
tree = resolve_scene(sys.argv[2])
prog = tree.program()
size = int(sys.argv[3])
cam = seen_camera(tree, prog, size, size)
render(prog, 32, 32, camera=cam)
out = []
for shadows in (False, True):
    start = time.process_time()
    render(prog, size, size, camera=cam, shadows=shadows)
    out.append(time.process_time() - start)
print(*out)
""", "mesh": PRELUDE + """
import numpy as np
from blobtree.mesh.polygonizer import polygonize
prog = resolve_scene(sys.argv[2]).program()
size = int(sys.argv[3])
polygonize(prog, 32)
prog.evaluate(np.repeat([0.5 * (prog.bounds[0] + prog.bounds[1])], 30000, axis=0))
start = time.process_time()
mesh = polygonize(prog, size)
out = [time.process_time() - start]
start = time.process_time()
prog.field(mesh.vertices)
print(out[0], time.process_time() - start)
"""}
#: What each task's two numbers are.
MEASURES = {"render": ("no shadows", "shadows"), "mesh": ("polygonize", "field at vertices")}


def checkout(rev: str, into: Path) -> Path:
    """A worktree of ``rev`` under ``into``, or the working tree itself for ``rev`` None."""
    if rev is None:
        return ROOT
    path = into / rev.replace("/", "_")
    subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "-q", str(path), rev],
                   check=True)
    return path


def run(dirs: list[Path], caches: list[Path], tmp: Path, task: str, model: str,
        core_shift: int, size: int) -> list[list[float]]:
    """Both checkouts' CPU seconds (the task's two measures), run at the same time, checkout k
    pinned to core (k + core_shift) % 2."""
    procs = [subprocess.Popen(
        [sys.executable, "-c", WORKLOADS[task], str((k + core_shift) % 2), model, str(size)],
        cwd=tmp, stdout=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONPATH": str(d), "NUMBA_CACHE_DIR": str(c),
             "NUMBA_NUM_THREADS": "1"})
        for k, (d, c) in enumerate(zip(dirs, caches, strict=True))]
    times = []
    for p in procs:
        out, _ = p.communicate()
        if p.returncode:
            sys.exit(f"a {task} run failed (exit {p.returncode})")
        times.append([float(v) for v in out.split()])
    return times


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("base")
    ap.add_argument("new", nargs="?", default=None)
    ap.add_argument("--model", default="murex")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--task", choices=sorted(WORKLOADS), default="render")
    args = ap.parse_args()
    if args.size < 32 or args.rounds < 1:
        ap.error(f"--size must be at least 32 (got {args.size}), --rounds at least 1 "
                 f"(got {args.rounds})")
    if len(os.sched_getaffinity(0)) < 2:
        sys.exit("ab.py needs two cores")
    tmp = Path(tempfile.mkdtemp(prefix="blobtree-ab-"))
    dirs = []
    try:
        dirs = [checkout(args.base, tmp), checkout(args.new, tmp)]
        caches = [tmp / f"cache{k}" for k in range(2)]
        run(dirs, caches, tmp, args.task, args.model, 0, 32)  # compile both, untimed
        ratios = []
        names = MEASURES[args.task]
        print(f"{args.task} {args.model} at {args.size}, one thread each, CPU seconds "
              f"({names[0]}, {names[1]})")
        for r in range(args.rounds):
            (a0, a1), (b0, b1) = run(dirs, caches, tmp, args.task, args.model, r, args.size)
            ratios.append((b0 / a0, b1 / a1))
            print(f"round {r + 1}: base {a0:.2f} {a1:.2f}   new {b0:.2f} {b1:.2f}   "
                  f"new/base {b0 / a0:.3f} {b1 / a1:.3f}")
        for k, name in enumerate(names):
            values = sorted(v[k] for v in ratios)
            print(f"median new/base, {name}: {values[len(values) // 2]:.3f}")
    finally:
        for d in dirs:
            if d != ROOT:
                subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(d)],
                               check=False)
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
