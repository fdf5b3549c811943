"""Hypothesis strategies for random BlobTrees, derived from the node registry.

Every registered node type gets a strategy built from its declared parameters: each parameter
kind (``blobtree.nodes.params``) says how to draw a value (its ``sample`` range), children come
from the recursive tree strategy within the type's ``ARITY``, and a draw the type's own checks
refuse (a zero-length cone, a bend tighter than its child) is rejected.  A new node type is
therefore in the generated trees with no code here; ``test_registry.py`` checks that it is.
"""

from __future__ import annotations

import numpy as np
from hypothesis import reject
from hypothesis import strategies as st

import blobtree as bt
from blobtree import checks as C
from blobtree.helico import HelicoSpiral
from blobtree.nodes import params as K
from blobtree.texture.mapping import HelicoSurface

#: The one bounding-surface mapping the generated trees use (cheap: few steps, two whorls).
HELICO = HelicoSurface(spiral=HelicoSpiral(r0=0.3), radius_factor=1.0, theta_max=720.0,
                       max_steps=8)


def value(kind: C.Kind, children: int) -> st.SearchStrategy:
    """A strategy for one parameter of this kind (``children``: how many the node has)."""
    if isinstance(kind, C.Number):
        return st.floats(*kind.sample)
    if isinstance(kind, C.Vec3):  # and RGB
        return st.tuples(*[st.floats(*kind.sample)] * 3)
    if isinstance(kind, C.Choice):
        return st.sampled_from(kind.options)
    if isinstance(kind, K.Axis):
        return st.sampled_from(["x", "y", "z", (1.0, 2.0, -0.5)])
    if isinstance(kind, K.Pairs):
        pair = st.tuples(st.integers(0, children - 1), st.integers(0, children - 1))
        return st.lists(pair.filter(lambda p: p[0] != p[1]), min_size=1, max_size=3)
    if isinstance(kind, K.Groups):
        members = st.lists(st.integers(0, children - 1), min_size=1, max_size=children,
                           unique=True)
        group = st.one_of(members, st.tuples(members, st.one_of(st.none(),
                                                                 st.floats(1.0, 8.0))))
        return st.lists(group, max_size=3)
    if isinstance(kind, K.Image):
        return st.integers(0, 99).map(lambda seed: np.random.default_rng(seed).integers(
            0, 256, (3, 5, 3)).astype(np.uint8))
    if isinstance(kind, K.Mapping):
        return st.sampled_from(["primitive", HELICO])
    raise TypeError(f"no strategy for parameter kind {type(kind).__name__}: add one here")


def node_of(cls: type[bt.Node], children: st.SearchStrategy | None) -> st.SearchStrategy:
    """Nodes of one registered type, children drawn from ``children``."""
    lo, hi = cls.ARITY

    @st.composite
    def make(draw):
        kids = []
        if hi != 0:
            n = draw(st.integers(max(lo, 2 if hi is None else lo), min(hi or 4, 4)))
            kids = [draw(children) for _ in range(n)]
        values = {p.name: draw(value(p.kind, len(kids))) for p in cls.PARAMS}
        try:
            return cls(*kids, **values)
        except ValueError:
            reject()

    return make()


def _kinds(*kinds: str, smooth_only: bool = False) -> list[type[bt.Node]]:
    return [c for c in bt.nodes.REGISTRY.values() if c.KIND in kinds
            and not (smooth_only and c.KIND == "operator" and not c.SMOOTH)]


def trees(smooth_only: bool = False, max_leaves: int = 8) -> st.SearchStrategy:
    """Random trees of every registered type; ``smooth_only`` leaves out the operators whose
    gradient jumps (``Operator.SMOOTH`` False: the CSG operators, the controlled blend)."""
    leaves = st.one_of([node_of(c, None) for c in _kinds("primitive")])
    inner = _kinds("operator", "affine", "warp", "paint", smooth_only=smooth_only)
    return st.recursive(leaves, lambda kids: st.one_of([node_of(c, kids) for c in inner]),
                        max_leaves=max_leaves)


def sample_points(tree: bt.Node, n: int, seed: int, grow: float = 0.2) -> np.ndarray:
    """Uniform points in the tree's bounds, grown by a fraction on every side."""
    lo, hi = tree.bounds()
    if np.any(lo > hi):  # empty support (e.g. a disjoint intersection): sample around it
        lo, hi = np.full(3, -2.0), np.full(3, 2.0)
    pad = grow * (hi - lo) + 1e-3
    return np.random.default_rng(seed).uniform(lo - pad, hi + pad, (n, 3))


def box_bounds_setup(tree: bt.Node, seed: int, frac: float):
    """(The tree's program arrays, bound scratch, a generator, the size of boxes ``frac`` of
    its extent) for sampling bounds over boxes; None for an empty tree."""
    from blobtree.engine.point import scratch

    prog = tree.program()
    lo, hi = tree.bounds()
    if np.any(lo > hi):
        return None
    return (prog.arrays, scratch(prog.depth), np.random.default_rng(seed),
            frac * (hi - lo) + 1e-3)


def check_box_bounds(tree: bt.Node, seed: int, frac: float, count: int) -> None:
    """Over ``count`` boxes of ``frac`` of the tree's extent, at sampled corners, both bound
    passes of ``bound_box_at`` (value-aware and plain) give the reference's field at a point of
    the box, bound every gradient sampled in it, and keep the field on its side of 0.5 within
    the distances they give."""
    from blobtree.engine import bounds as K

    setup = box_bounds_setup(tree, seed, frac)
    if setup is None:
        return
    arrays, st, rng, size = setup
    for corner in sample_points(tree, count, seed):
        x = rng.uniform(corner, corner + size)
        Q = rng.uniform(corner, corner + size, (200, 3))
        fq, gq, _ = tree.reference(Q)
        distance = np.linalg.norm(Q - x, axis=1)
        for values in (True, False):
            f, bound, below, above = K.bound_box_at(arrays, (*corner, *(corner + size)),
                                                    tuple(x), (0.0, 0.0, 0.0, -1.0), values, st)
            np.testing.assert_allclose(f, tree.reference(x[None])[0][0], rtol=1e-9,
                                       atol=1e-12)
            assert np.linalg.norm(gq, axis=1).max() <= bound * (1 + 1e-9) + 1e-12
            assert np.all(fq[distance < below * (1 - 1e-9)] <= 0.5 + 1e-12)
            assert np.all(fq[distance < above * (1 - 1e-9)] >= 0.5 - 1e-12)
