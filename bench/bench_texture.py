"""What texturing costs: the Murex shell rendered textured and plain.

With ``--record`` the figures are appended to bench/results.jsonl (see bench/record.py).

Run: python bench/bench_texture.py [--size 512] [--repeat 2] [--record] [--record-file PATH]
"""

from __future__ import annotations

import argparse
import time

import record

import blobtree as bt
from blobtree.models.figures import FIGURES
from blobtree.render.camera import framed_camera


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--repeat", type=int, default=2)
    record.add_arguments(ap)
    args = ap.parse_args()
    record_file = record.target(args)
    times = {}
    for textured in (False, True):
        shell = bt.models.murex(textured=textured)
        fig = FIGURES["14"]
        camera = framed_camera(shell.program(), args.size, args.size, view=fig.view, up=fig.up,
                               fov=fig.fov)
        bt.render(shell, 64, 64, camera=camera, progress=False)  # warm up
        best = float("inf")
        for _ in range(args.repeat):
            start = time.perf_counter()
            bt.render(shell, args.size, args.size, camera=camera, progress=False)
            best = min(best, time.perf_counter() - start)
        times[textured] = best
        print(f"{'textured' if textured else 'plain   '}: {best:.2f} s")
    print(f"texturing adds {100 * (times[True] / times[False] - 1):+.0f}% (bar: at most +50%)")
    if record_file:
        n = args.size
        record.append("bench_texture.py", [record.row(
            f"murex render {n}x{n}, figure 14 framing, in-process, textured", times[True],
            "blobtree, untextured", times[False], f"best of {args.repeat}")], record_file)
        print(f"recorded in {record_file}")


if __name__ == "__main__":
    main()
