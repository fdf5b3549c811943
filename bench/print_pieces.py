"""Count the solids and sealed bubbles of every shipped shell's mesh at every 32 cells from 128
to 512 (printability: a shell you can print is one solid at any resolution), with the time each
mesh took.  Exits 1 if some mesh is not one solid.  The tests check two resolutions.

Usage: python bench/print_pieces.py [--shells murex oliva] [--step 32] [--sharp]
  --sharp: carve with the paper's sharp differences (lip_smooth = cut_smooth = 0), to compare
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace

import blobtree as bt
from blobtree.models import SHELLS


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shells", nargs="+", default=list(SHELLS), choices=list(SHELLS))
    ap.add_argument("--step", type=int, default=32)
    ap.add_argument("--sharp", action="store_true")
    args = ap.parse_args()
    if args.step < 1:
        ap.error(f"--step must be a positive number of cells, got {args.step}")
    failed = False
    for name in args.shells:
        spec = SHELLS[name]
        if args.sharp:
            spec = replace(spec, lip_smooth=0.0, cut_smooth=0.0)
        tree = bt.models.shell(spec, textured=False)
        cells = []
        for resolution in range(128, 513, args.step):
            start = time.perf_counter()
            mesh = bt.polygonize(tree, resolution=resolution)
            seconds = time.perf_counter() - start
            solids, bubbles = mesh.solids_and_bubbles()
            failed |= solids != 1 or not mesh.is_watertight
            cells.append(f"{resolution}: {solids}" + (f"+{bubbles}b" if bubbles else "")
                         + f" ({seconds:.1f} s)")
        print(f"{name}: " + ", ".join(cells), flush=True)
    print("solids per mesh (+ bubbles sealed inside)" + ("" if not failed else
                                                         "; SOME MESH IS NOT ONE SOLID"))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
