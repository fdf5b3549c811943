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
from collections.abc import Callable

import numba
import numpy as np

from blobtree.cli.scenes import resolve_scene
from blobtree.render import LOOKS, RenderSettings, trace_rect
from blobtree.render.camera import seen_camera
from blobtree.render.shade import default_lights, pack_lights


def rect_renderer(model: str, size: int, shadows: bool) -> Callable[..., None]:
    """``draw(x0, y0, x1, y1)``: renders that rectangle of ``model``'s size x size studio
    picture (one sample a pixel), its kernels compiled or loaded first."""
    tree = resolve_scene(model)
    prog = tree.program()
    cam = seen_camera(tree, prog, size, size)
    lights = pack_lights(default_lights(cam))
    settings = RenderSettings(width=size, height=size, samples=1, shadows=shadows,
                              **LOOKS["studio"])
    packed = cam.packed(size, size)

    def draw(x0: int, y0: int, x1: int, y1: int) -> None:
        trace_rect(prog, packed, lights, settings, x0, y0, x1, y1)

    draw(0, 0, 1, 1)
    return draw


def check_rect(ap: argparse.ArgumentParser, rect: list[int] | None, size: int) -> None:
    """Refuse a ``--rect`` outside the picture."""
    if rect and not (0 <= rect[0] < rect[2] <= size and 0 <= rect[1] < rect[3] <= size):
        ap.error(f"--rect must be X0 Y0 X1 Y1 with 0 <= X0 < X1 <= --size ({size}) and the "
                 f"same for Y, got {rect}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default="murex")
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--tile", type=int, default=64)
    ap.add_argument("--no-shadows", action="store_true")
    ap.add_argument("--rect", type=int, nargs=4, metavar=("X0", "Y0", "X1", "Y1"))
    ap.add_argument("--repeat", type=int, default=8)
    args = ap.parse_args()
    check_rect(ap, args.rect, args.size)
    if args.repeat < 1:
        ap.error(f"--repeat must be at least 1, got {args.repeat}")
    if args.size < args.tile or args.tile < 1:
        ap.error(f"--size ({args.size}) must be at least --tile ({args.tile}), both positive")
    numba.set_num_threads(1)
    w = args.size
    draw = rect_renderer(args.model, w, not args.no_shadows)
    if args.rect:
        times = []
        for _ in range(args.repeat):
            start = time.process_time()
            draw(*args.rect)
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
            draw(x0, y0, min(x0 + args.tile, w), min(y0 + args.tile, w))
            seconds[j, i] = time.perf_counter() - start
    np.set_printoptions(linewidth=200, precision=2, suppress=True)
    print(f"{args.model} {w}x{w}, shadows {'off' if args.no_shadows else 'on'}, one thread: "
          f"{seconds.sum():.2f} s; seconds per {args.tile}-pixel tile:")
    print(seconds)
    top = np.sort(seconds.ravel())[::-1]
    print(f"slowest 5 tiles: {top[:5].sum() / seconds.sum():.0%} of the time")


if __name__ == "__main__":
    main()
