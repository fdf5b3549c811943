"""Benchmark: seconds per frame of a film of the Murex growing, locally and on a Dask cluster.

Renders the frames of ``blobtree grow murex`` (the camera and look of ``blobtree render
murex``) on the local engine (frame after frame, each on all cores) and on a local cluster of
single-threaded worker processes (a frame per task), checks the frames are byte-identical and
prints the seconds per frame and their ratio.

    python bench/bench_grow.py [--size 640] [--frames 12] [--workers 2] [--record]
                               [--record-file PATH]

Both engines are warmed up first (numba kernels loaded on every process) so the figures measure
the frames; the cluster's start-up is printed apart.  Each frame includes building the shell at
its age and compiling its program, as ``blobtree grow`` does.  With ``--record`` the two
figures are appended to bench/results.jsonl (see bench/record.py).
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path

import numpy as np
import record

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import blobtree as bt  # noqa: E402
from blobtree.cli.render_cmd import command_camera  # noqa: E402
from blobtree.film import Film, local_frames  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=640, help="frame side in pixels")
    ap.add_argument("--frames", type=int, default=12, help="frames of the film")
    ap.add_argument("--workers", type=int, default=2, help="worker processes")
    record.add_arguments(ap)
    args = ap.parse_args()
    record_file = record.target(args)
    from blobtree.distributed import connect, remote_frames

    n, spec = args.size, bt.models.SHELLS["murex"]
    tree = bt.models.murex()
    camera = command_camera("murex", tree, tree.program(), n, n)
    film = Film(spec, 0, args.frames, n, n, camera)
    warm = Film(spec, 0, 2, 32, 32, camera)
    dict(local_frames(warm, [0, 1]))  # kernels loaded
    local, t_local = record.timed(lambda: dict(local_frames(film, film.order())))
    print(f"local engine  {args.frames} frames {n}x{n}: {t_local / args.frames:8.2f} s/frame")

    with contextlib.ExitStack() as stack:
        client, t_start = record.timed(lambda: stack.enter_context(connect(workers=args.workers)))
        print(f"cluster start ({args.workers} workers): {t_start:8.2f} s")
        indices = list(range(warm.frames)) * args.workers
        _, t_cold = record.timed(lambda: list(remote_frames(client, warm, indices)))
        print(f"cold frames on the cluster (workers load kernels): {t_cold:.2f} s")
        remote, t_remote = record.timed(lambda: dict(remote_frames(client, film, film.order())))
    print(f"Dask cluster  {args.frames} frames {n}x{n}: {t_remote / args.frames:8.2f} s/frame")
    same = all(np.array_equal(local[i], remote[i]) for i in local)
    print(f"byte-identical: {same}")
    print(f"ratio cluster / local: {t_remote / t_local:.3f}")
    if record_file:
        workload = (f"murex growing, {args.frames} frames {n}x{n}, s per frame, Dask cluster "
                    f"of {args.workers} workers")
        record.append("bench_grow.py", [record.row(
            workload, t_remote / args.frames, "blobtree, local engine", t_local / args.frames,
            f"one run each; {'byte-identical' if same else 'frames differ'}")], record_file)
        print(f"recorded in {record_file}")


if __name__ == "__main__":
    main()
