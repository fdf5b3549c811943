"""Where a render's time goes, tile by tile: renders a built-in model on one thread, one 64-pixel
tile at a time, and prints each tile's seconds as a grid (the image's layout), the total and the
share of the slowest tiles.  Uneven grids point at the rays that creep.  ``--rect X0 Y0 X1 Y1``
times that rectangle of pixels alone instead, the best of ``--repeat`` renders (CPU seconds):
two checkouts compared on a slow part of the picture, each pinned to a core (``taskset``).

Usage: python bench/profile_tiles.py [--model murex] [--size 512] [--no-shadows] [--tile 64]
                                     [--rect X0 Y0 X1 Y1 [--repeat 8]]
"""

from __future__ import annotations

import argparse
import time

import numba
import numpy as np

from blobtree.cli.scenes import resolve_scene
from blobtree.render import LOOKS, RenderSettings, trace_rect
from blobtree.render.camera import seen_camera
from blobtree.render.shade import default_lights, pack_lights


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default="murex")
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--tile", type=int, default=64)
    ap.add_argument("--no-shadows", action="store_true")
    ap.add_argument("--rect", type=int, nargs=4, metavar=("X0", "Y0", "X1", "Y1"))
    ap.add_argument("--repeat", type=int, default=8)
    args = ap.parse_args()
    if args.rect and not (0 <= args.rect[0] < args.rect[2] <= args.size
                          and 0 <= args.rect[1] < args.rect[3] <= args.size):
        ap.error(f"--rect must be X0 Y0 X1 Y1 with 0 <= X0 < X1 <= --size ({args.size}) and "
                 f"the same for Y, got {args.rect}")
    if args.repeat < 1:
        ap.error(f"--repeat must be at least 1, got {args.repeat}")
    if args.size < args.tile or args.tile < 1:
        ap.error(f"--size ({args.size}) must be at least --tile ({args.tile}), both positive")
    numba.set_num_threads(1)
    tree = resolve_scene(args.model)
    prog = tree.program()
    w = args.size
    cam = seen_camera(tree, prog, w, w)
    lights = pack_lights(default_lights(cam))
    settings = RenderSettings(width=w, height=w, samples=1, shadows=not args.no_shadows,
                              **LOOKS["studio"])
    packed = cam.packed(w, w)
    trace_rect(prog, packed, lights, settings, 0, 0, 1, 1)  # compile or load the kernels first
    if args.rect:
        times = []
        for _ in range(args.repeat):
            start = time.process_time()
            trace_rect(prog, packed, lights, settings, *args.rect)
            times.append(time.process_time() - start)
        print(f"{args.model} {w}x{w}, pixels {args.rect}, shadows "
              f"{'off' if args.no_shadows else 'on'}, one thread: best of {args.repeat} "
              f"{min(times):.3f} CPU s")
        return
    n = -(-w // args.tile)
    seconds = np.zeros((n, n))
    for j in range(n):
        for i in range(n):
            x0, y0 = i * args.tile, j * args.tile
            start = time.perf_counter()
            trace_rect(prog, packed, lights, settings, x0, y0, min(x0 + args.tile, w),
                       min(y0 + args.tile, w))
            seconds[j, i] = time.perf_counter() - start
    np.set_printoptions(linewidth=200, precision=2, suppress=True)
    print(f"{args.model} {w}x{w}, shadows {'off' if args.no_shadows else 'on'}, one thread: "
          f"{seconds.sum():.2f} s; seconds per {args.tile}-pixel tile:")
    print(seconds)
    top = np.sort(seconds.ravel())[::-1]
    print(f"slowest 5 tiles: {top[:5].sum() / seconds.sum():.0%} of the time")


if __name__ == "__main__":
    main()
