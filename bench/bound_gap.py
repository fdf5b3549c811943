"""How loose the tracer's bound is, and where: boxes the size of a camera packet touching a
model's surface from outside, each with the engine's bound on ``|grad f|`` over it (the pass
the tracer takes: value-aware for a CSG root) against the largest ``|grad f|`` sampled in it,
and the bound on the rise along the inward normal (the direction of a ray meeting the surface)
against the largest rise sampled.  A ray steps ``(0.5 - f) / bound`` (``trace.py``), so the
ratio is how much shorter its steps are than the field allows.

Then, for each box, the tree is descended from the root through operators and paint nodes
(each subtree compiled on its own, in the same frame), always into the child with the largest
bound: the *gap node* is the deepest node on that path whose bound is at least twice its
sampled gradient while that child's is not; its sum of the live children's bounds against its
own sampled gradient says whether the rule of the operator (a sum over children whose
gradients point different ways) or the children's own bounds make the gap.

Usage: python bench/bound_gap.py [--model murex] [--boxes 40] [--side 0.15] [--samples 1500]
"""

from __future__ import annotations

import argparse
import collections

import numba
import numpy as np

from blobtree.cli.scenes import resolve_scene
from blobtree.engine.bounds import bound_box_at, bounds_use_values
from blobtree.engine.point import scratch
from blobtree.nodes.kinds import Operator, Paint


@numba.njit
def _bound(prog, lo, hi, x0, d, spread, values, depth):
    """(the bound over the box [lo, hi], with ``values`` and, for spread >= 0, the rise along d)
    as the tracer's ``bound_box_at`` gives it at the point x0."""
    st = scratch(depth)
    return bound_box_at(prog, (lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]), (x0[0], x0[1], x0[2]),
                        (d[0], d[1], d[2], spread), values, st)[1]


def surface_points(prog, n: int, rng: np.random.Generator) -> np.ndarray:
    """n points on the surface f = 0.5: each inside sample bisected toward its nearest outside
    sample (all at once, 40 halvings)."""
    lo, hi = (np.asarray(b, dtype=np.float64) for b in prog.bounds)
    P = rng.uniform(lo, hi, size=(200_000, 3))
    f = prog.field(P)
    inside, outside = P[f > 0.5], P[f < 0.5]
    if len(inside) < n or len(outside) == 0:
        raise SystemExit(f"too few samples inside the model ({len(inside)}) to place {n} boxes")
    a = inside[rng.choice(len(inside), n, replace=False)]
    b = np.array([outside[np.argmin(((outside - p) ** 2).sum(axis=1))] for p in a])
    for _ in range(40):
        m = 0.5 * (a + b)
        into = prog.field(m) > 0.5
        a[into], b[~into] = m[into], m[~into]
    return 0.5 * (a + b)


def _program(node, cache: dict):
    key = id(node)
    if key not in cache:
        cache[key] = node.program()
    return cache[key]


def _steepest(prog, Q: np.ndarray) -> float:
    """The largest |grad f| sampled at Q (not 0: a ratio's denominator)."""
    return max(float(np.linalg.norm(prog.gradient(Q), axis=1).max()), 1e-12)


def _bound_of(prog, box: tuple, x0: np.ndarray) -> float:
    """The value-aware bound over the box at x0 (as the tracer takes it)."""
    values = bool(bounds_use_values(prog.code))
    return _bound(prog.arrays, box[0], box[1], x0, np.zeros(3), -1.0, values, prog.depth)


def _piece(node) -> str:
    """A piece's name: the nodes under its affine chain, down to its primitive ("Bend Cone")."""
    names = []
    while node.children:
        if node.KIND != "affine":
            names.append(type(node).__name__)
        node = node.children[0]
    return " ".join(names + [type(node).__name__])


def gap_node(node, box: tuple, x0: np.ndarray, Q: np.ndarray, cache: dict):
    """The gap node of the box (module doc): (its type, live children, its bound, its sampled
    gradient, the sum of its live children's bounds), or None where the root is within 2."""
    found = None
    bound = _bound_of(_program(node, cache), box, x0)
    while True:
        true = _steepest(_program(node, cache), Q)
        if bound <= 2.0 * true:
            return found
        if not isinstance(node, Operator | Paint):
            return _piece(node), 0, bound, true, bound
        kids = []
        for child in node.children:
            lo, hi = (np.asarray(b) for b in _program(child, cache).bounds)
            if np.all(hi >= box[0]) and np.all(lo <= box[1]):
                kb = _bound_of(_program(child, cache), box, x0)
                if kb > 0.0:
                    kids.append((kb, child))
        found = (type(node).__name__, len(kids), bound, true, sum(k for k, _ in kids))
        if not kids:
            return found
        bound, node = max(kids, key=lambda k: k[0])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default="murex")
    ap.add_argument("--boxes", type=int, default=40)
    ap.add_argument("--side", type=float, default=0.15,
                    help="the boxes' side in scene units (0.15: an 8x8-pixel packet of the "
                         "Murex's 512 picture)")
    ap.add_argument("--samples", type=int, default=1500)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    if args.boxes < 1 or not args.side > 0.0 or args.samples < 10:
        ap.error(f"--boxes must be >= 1, --side > 0 and --samples >= 10, got {args.boxes}, "
                 f"{args.side}, {args.samples}")
    rng = np.random.default_rng(args.seed)
    tree = resolve_scene(args.model)
    prog = tree.program()
    S = surface_points(prog, args.boxes, rng)
    G = prog.gradient(S)
    inward = G / np.linalg.norm(G, axis=1)[:, None]  # the field grows into the model
    values = bool(bounds_use_values(prog.code))
    rows, gaps, cache = [], collections.defaultdict(list), {}
    for s, d in zip(S, inward, strict=True):
        c = s - d * 0.5 * args.side  # the box's centre, just outside the surface
        box = (c - 0.5 * args.side, c + 0.5 * args.side)
        Q = rng.uniform(*box, size=(args.samples, 3))
        grads = prog.gradient(Q)
        a = prog.arrays
        rows.append((_bound(a, *box, c, d, -1.0, values, prog.depth),
                     _bound(a, *box, c, d, -1.0, False, prog.depth),
                     _bound(a, *box, c, d, 0.0, False, prog.depth),
                     np.linalg.norm(grads, axis=1).max(), max((grads @ d).max(), 1e-12)))
        found = gap_node(tree, box, c, Q, cache)
        if found is not None:
            gaps[found[:2]].append(found[2:])
    R = np.array(rows)

    def spread(x: np.ndarray) -> str:
        q1, q2, q3 = np.percentile(x, [25, 50, 75])
        return f"median {q2:.2f} (quartiles {q1:.2f} to {q3:.2f})"

    kind = "value-aware" if values else "plain"
    print(f"{args.model}: {args.boxes} boxes of side {args.side:g} touching the surface from "
          f"outside, {args.samples} samples each; bound pass {kind}")
    print(f"  bound / sampled max |grad f|:          {spread(R[:, 0] / R[:, 3])}")
    print(f"  plain bound / value-aware bound:       {spread(R[:, 1] / R[:, 0])}")
    print(f"  rise bound along the inward normal / plain bound: {spread(R[:, 2] / R[:, 1])}")
    print(f"  rise bound / sampled max rise:         {spread(R[:, 2] / R[:, 4])}")
    print(f"  sampled max |grad f|:                  {spread(R[:, 3])}")
    print("gap nodes (bound >= 2x sampled gradient, the child with the largest bound not):")
    print(f"  {'node':<18}{'live children':>14}{'boxes':>7}{'bound/grad':>12}"
          f"{'children sum/grad':>19}")
    for (name, kids), found in sorted(gaps.items(), key=lambda g: -len(g[1])):
        f = np.array(found)
        print(f"  {name:<18}{kids:>14}{len(f):>7}{np.median(f[:, 0] / f[:, 1]):>12.2f}"
              f"{np.median(f[:, 2] / f[:, 1]):>19.2f}")


if __name__ == "__main__":
    main()
