"""Benchmark: a render on a local Dask cluster against the local engine.

Renders the whole Murex shell with the same settings on the local engine (numba threads, one per
core) and on a local cluster of single-threaded worker processes, checks the images are
byte-identical and prints the times and their ratio (bar: <= 1.3 on 2 cores, 1024x1024).

    python bench/bench_distributed.py [--size 1024] [--workers 2] [--samples 1] [--tile 64]
                                      [--record] [--record-file PATH]

Both engines are warmed up first (numba kernels loaded, the scene compiled on every worker) so
the ratio measures the distribution overhead; the cluster's start-up and its first, cold render
are printed too.  With ``--record`` the two warm renders' times are appended to
bench/results.jsonl (see bench/record.py).
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=1024, help="image side in pixels")
    ap.add_argument("--workers", type=int, default=2, help="worker processes")
    ap.add_argument("--samples", type=int, default=1, help="rays per pixel")
    ap.add_argument("--tile", type=int, default=64, help="tile side in pixels")
    record.add_arguments(ap)
    args = ap.parse_args()
    record_file = record.target(args)
    from blobtree.distributed import connect

    tree = bt.models.murex()
    opts = dict(samples=args.samples, tile=args.tile)
    n = args.size
    bt.render(tree, 32, 32, **opts)  # warm-up: kernels loaded, program compiled
    local, t_local = record.timed(lambda: bt.render(tree, n, n, **opts))
    print(f"local engine      {n}x{n}: {t_local:8.2f} s")

    with contextlib.ExitStack() as stack:
        client, t_start = record.timed(lambda: stack.enter_context(connect(workers=args.workers)))
        print(f"cluster start ({args.workers} workers): {t_start:8.2f} s")
        _, t_cold = record.timed(lambda: bt.render(tree, 32, 32, **opts, scheduler=client))
        print(f"cold 32x32 on the cluster (workers load kernels, compile): {t_cold:.2f} s")
        remote, t_remote = record.timed(lambda: bt.render(tree, n, n, **opts, scheduler=client))
    print(f"Dask cluster      {n}x{n}: {t_remote:8.2f} s")
    print(f"byte-identical: {np.array_equal(local, remote)}")
    print(f"ratio cluster / local: {t_remote / t_local:.3f} (bar: <= 1.3)")
    print(f"ratio with start-up and warm-up: {(t_start + t_cold + t_remote) / t_local:.3f}")
    if record_file:
        same = "byte-identical" if np.array_equal(local, remote) else "images differ"
        workload = (f"murex render {n}x{n}, Dask cluster of {args.workers} workers, "
                    f"{args.samples} samples per pixel, tile {args.tile}")
        record.append("bench_distributed.py", [record.row(
            workload, t_remote, "blobtree, local engine", t_local, f"one run each; {same}")],
            record_file)
        print(f"recorded in {record_file}")


if __name__ == "__main__":
    main()
