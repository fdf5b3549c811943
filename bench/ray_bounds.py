"""What bounds one camera ray's steps: along the ray through a pixel of a model's picture, the
field, the bound over a segment and the distances the value-aware bound pass proves (below and
above 0.5), for the whole tree and for each operator down to ``--depth`` levels (paint nodes
passed through), each compiled on its own in the same frame.  Where a subtree's bound is large
while its field stays far from 0.5, its slope is what makes the ray creep.

Usage: python bench/ray_bounds.py [--model murex] [--size 512] [--pixel 328 232]
                                  [--segment 0.1] [--depth 3] [--samples 12]
"""

from __future__ import annotations

import argparse

import numpy as np

from blobtree.cli.scenes import resolve_scene
from blobtree.engine.bounds import bounds_use_values, lipschitz_segment
from blobtree.engine.point import scratch
from blobtree.nodes.kinds import Operator
from blobtree.render.camera import seen_camera
from blobtree.render.tiles import _ray
from blobtree.render.trace import clip_box


def operators(node, depth: int, path: str = "root"):
    """(path, node) for ``node`` and the operators under it, ``depth`` levels down."""
    yield path, node
    if depth == 0:
        return
    for i, child in enumerate(node.children):
        while not isinstance(child, Operator) and len(child.children) == 1:
            child = child.children[0]  # a paint or affine node: look through it
        if isinstance(child, Operator):
            yield from operators(child, depth - 1, f"{path}.{i}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default="murex")
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--pixel", type=float, nargs=2, default=(328.0, 232.0))
    ap.add_argument("--segment", type=float, default=0.1)
    ap.add_argument("--depth", type=int, default=3)
    ap.add_argument("--samples", type=int, default=12)
    args = ap.parse_args()
    if not (0.0 <= min(args.pixel) and max(args.pixel) < args.size):
        ap.error(f"--pixel must lie in [0, {args.size}), got {args.pixel}")
    tree = resolve_scene(args.model)
    prog = tree.program()
    w = args.size
    cam = seen_camera(tree, prog, w, w).packed(w, w)
    d = np.array(_ray(cam, w, w, args.pixel[0] + 0.5, args.pixel[1] + 0.5))
    o = cam[:3].copy()
    lo, hi = (np.asarray(b, float) for b in prog.bounds)
    t0, t1 = clip_box(*o, *d, lo, hi, 0.0, np.inf)
    if not t0 < t1:
        ap.error(f"--pixel {args.pixel[0]:g} {args.pixel[1]:g}: its ray misses the model's box")
    # where the ray meets the field, and the surface, to 1/4000 of its chord (one batch)
    ts = np.linspace(t0, t1, 4000)
    f = prog.field(o + ts[:, None] * d)
    live, solid = np.flatnonzero(f > 0.0), np.flatnonzero(f >= 0.5)
    first = ts[live[0]] if len(live) else t0
    hit = ts[solid[0]] if len(solid) else t1
    ts = np.linspace(first, hit, args.samples)
    print(f"{args.model}, pixel {args.pixel[0]:g},{args.pixel[1]:g} of {w}: the ray meets the "
          f"field near t = {first:.3f}, the surface near {hit:.3f}; over segments "
          f"{args.segment:g} long from each t, each operator's field, bound and proven "
          f"distances below / above 0.5 (those with a field on the ray)")
    print(f"{'t':>24} " + " ".join(f"{t:>10.3f}" for t in ts))
    for path, node in operators(tree, args.depth):
        sub, name = node.program(), type(node).__name__
        st, values = scratch(sub.depth), bounds_use_values(sub.code)
        rows = [lipschitz_segment(sub.arrays, tuple(o + t * d), tuple(d), args.segment, values,
                                  st)
                for t in ts]
        if all(r[0] == 0.0 for r in rows):
            continue
        label = f"{path} {name}"
        print(f"{label:>24} " + " ".join(f"{f:4.2f} {lam:5.1f}" for f, lam, _, _ in rows))
        print(f"{'':>24} " + " ".join(f"{min(b, 9.99):4.2f}/{min(a, 9.99):4.2f}"
                                      for _, _, b, a in rows))


if __name__ == "__main__":
    main()
