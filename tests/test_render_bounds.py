"""The distance-aware Lipschitz bound of point primitives that segment tracing steps by."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import blobtree as bt
from blobtree.fields import falloff_ds
from blobtree.nodes.bend import bend_stretch
from blobtree.nodes.warp import PERM_END


@pytest.mark.parametrize(
    "tree",
    [
        bt.models.whorl126(),
        (bt.Point(radius=1.5).scale(1.0, 2.0, 0.5).rotate("x", 30.0).translate(0.2, 0.0, 0.0)
         + bt.Point(radius=1.0, center=(0.7, 0.0, 0.0))) | bt.Point(radius=0.5, falloff="cubic"),
    ],
)
def test_small_box_bounds_hold(tree):
    prog = tree.program()
    lo, hi = prog.bounds
    rng = np.random.default_rng(1)
    for _ in range(150):
        c = rng.uniform(lo, hi)
        e = rng.uniform(0.0, 0.1, 3) * (hi - lo)
        bound = prog.lipschitz((c - e)[None], (c + e)[None])[0]
        P = c + rng.uniform(-1.0, 1.0, (1500, 3)) * e
        assert np.linalg.norm(prog.gradient(P), axis=1).max() <= bound * (1 + 1e-9) + 1e-12


def test_bound_follows_the_distance_to_the_centre():
    R = 2.0
    prog = bt.Point(radius=R).program()
    for rho in (0.1, 0.75, 0.95):  # a tiny box at distance rho R: the slope there, not the peak
        c = np.array([rho * R, 0.0, 0.0])
        bound = prog.lipschitz((c - 1e-9)[None], (c + 1e-9)[None])[0]
        exact = abs(falloff_ds(0, rho * rho)) * 2.0 * rho / R  # soft object
        # (exact up to the rounding up of the engine's peak slope constant)
        assert exact <= bound <= exact * (1 + 1e-4)
    c = np.array([1.1 * R, 0.0, 0.0])  # outside the support: no slope at all
    assert prog.lipschitz((c - 0.01)[None], (c + 0.01)[None])[0] == 0.0


def test_a_warps_region_is_a_ball_not_the_cube_around_it():
    """Through a warp the region is a ball about the warped centre (the query map moves points
    by at most its stretch times the distance); the cube around that ball reaches sqrt(3) times
    further.  This box's ball stays clear of the bent cone's support (its field is 0 all over
    the box) though the cube around the ball reaches it: the bound is 0, and a bent cone's
    bound holds over boxes around it."""
    cone = bt.Cone((0, 0, 0), (2, 0, 0), radius_a=0.3, radius_b=0.3).bend(30.0, 2.0)
    prog = cone.program()
    lo, hi = np.array([-0.46, 0.29, 0.29]), np.array([-0.14, 0.61, 0.61])
    rng = np.random.default_rng(0)
    assert np.all(cone.field(rng.uniform(lo, hi, (20000, 3))) == 0.0)
    # the cube would reach it: its corner is within the cone's support in the frame (before
    # the bend, the warp moves nothing: the frame point is the point, the cone's end is 0)
    reach = cone.stretch * np.linalg.norm(hi - lo) / 2.0
    assert np.linalg.norm((lo + hi) / 2.0) - np.sqrt(3.0) * reach < 0.3 <= \
        np.linalg.norm((lo + hi) / 2.0) - reach
    assert prog.lipschitz(lo[None], hi[None])[0] == 0.0
    for _ in range(100):
        c = rng.uniform(*prog.bounds)
        e = rng.uniform(0.0, 0.15, 3)
        bound = prog.lipschitz((c - e)[None], (c + e)[None])[0]
        P = c + rng.uniform(-1.0, 1.0, (1500, 3)) * e
        assert np.linalg.norm(prog.gradient(P), axis=1).max() <= bound * (1 + 1e-9) + 1e-12


def test_a_bend_stretches_a_region_as_much_as_it_does_there():
    """A bend's query map stretches by 1 / (k rho) at distance rho from the centre of curvature
    (its stretch, lips, is that at the child's nearest reach); a region on its outer side is
    stretched by at most 1, so its ball through the warp is lips times smaller.  This box is
    clear of the thick bent cone's support (its field is 0 all over it), which its ball
    grown by lips would reach: its bound is 0."""
    cone = bt.Cone((0, 0, 0), (2, 0, 0), radius_a=1.0, radius_b=1.0).bend(90.0, 2.0)
    prog = cone.program()
    lo, hi = np.array([-0.95, -0.95, -0.1]), np.array([-0.75, -0.75, 0.1])
    rng = np.random.default_rng(0)
    assert np.all(cone.field(rng.uniform(lo, hi, (20000, 3))) == 0.0)
    # (before the bend, the warp moves nothing; the cone's end is at the origin, R = 1)
    centre, half = np.linalg.norm((lo + hi) / 2.0), np.linalg.norm(hi - lo) / 2.0
    assert centre - cone.stretch * half < 1.0 <= centre - half
    assert prog.lipschitz(lo[None], hi[None])[0] == 0.0
    for _ in range(100):  # and the bound holds over boxes all around it
        c = rng.uniform(*prog.bounds)
        e = rng.uniform(0.0, 0.3, 3)
        bound = prog.lipschitz((c - e)[None], (c + e)[None])[0]
        P = c + rng.uniform(-1.0, 1.0, (1500, 3)) * e
        assert np.linalg.norm(prog.gradient(P), axis=1).max() <= bound * (1 + 1e-9) + 1e-12


@given(st.floats(5.0, 175.0), st.floats(0.7, 3.0), st.tuples(*[st.floats(-3.0, 3.0)] * 3),
       st.tuples(*[st.floats(0.001, 1.0)] * 3))
@settings(max_examples=60, deadline=None)
def test_bend_stretch_bounds_the_jacobian_over_a_box(degrees, length, centre, half):
    """``bend_stretch`` over a box (canonical axes) is at least the norm of the query map's
    Jacobian at every point of it (or inf: the box reaches the centre of curvature's side)."""
    node = bt.Cone((0, 0, 0), (length, 0, 0), 0.2, 0.1).bend(degrees, length)
    params = np.concatenate([np.zeros(PERM_END), node.pack()])
    lo, hi = np.array(centre) - half, np.array(centre) + half
    bound = bend_stretch(params, 0, *lo, *hi)
    P = np.vstack([np.random.default_rng(1).uniform(lo, hi, (2000, 3)),
                   np.array(np.meshgrid(*zip(lo, hi, strict=True))).reshape(3, -1).T])
    _, J = node.warp_points(P)  # (axis x toward +y: the canonical axes are the frame's)
    assert np.linalg.norm(J, ord=2, axis=(1, 2)).max() <= bound * (1 + 1e-12)


_A = bt.Point(radius=1.0)
_B = bt.Point(radius=0.6, center=(0.55, 0.1, 0.0))


@pytest.mark.parametrize("tree", [
    bt.union(_A, _B), bt.intersection(_A, _B), bt.difference(_A, _B),
    bt.difference(_A, _B, smooth=0.1), bt.super_blend(_A, _B, n=400.0),
    bt.controlled_blend([_A, _B, _A.scale(0.5)], pairs=[(0, 2)], groups=[((1, 2), 4.0)]),
])
def test_csg_bound_drops_the_child_that_cannot_set_the_field(tree):
    """Over small boxes, the bound that knows the field at a point of the box (the ray
    tracer's) holds, is never above the plain rule (max or sum of the children's bounds), and
    is below it wherever the child with the larger bound cannot win anywhere in the box."""
    from blobtree.engine import bounds as K
    from blobtree.engine.point import scratch

    prog = tree.program()
    st = scratch(prog.depth)
    rng = np.random.default_rng(7)
    lower = further = 0
    both = rng.uniform(-1.0, 1.2, (20000, 3))  # box centres where both children have a field
    both = both[(_A.field(both) > 0.0) & (_B.field(both) > 0.0)][:300]
    for c in both:
        e = rng.uniform(0.002, 0.05, 3)
        box = (*(c - e), *(c + e))
        rule = K.lipschitz_box(prog.arrays, box, st)
        f, bound, below, above = K.bound_box_at(prog.arrays, box, tuple(c), (0.0, 0.0, 0.0, -1.0),
                                                True, st)
        P = c + rng.uniform(-1.0, 1.0, (400, 3)) * e
        fp, gp, _ = prog.evaluate(P)
        assert np.linalg.norm(gp, axis=1).max() <= bound * (1 + 1e-9) + 1e-12
        assert bound <= rule
        lower += bound < 0.9 * rule
        # below 0.5 as far as it says, and further than the bound alone proves where a term
        # of a min (or every child of a max) stays below on its own
        distance = np.linalg.norm(P - c, axis=1)
        assert np.all(fp[distance < below * (1 - 1e-9)] <= 0.5 + 1e-12)
        assert np.all(fp[distance < above * (1 - 1e-9)] >= 0.5 - 1e-12)
        plain = abs(0.5 - f) / bound if bound > 0 else np.inf
        assert max(below, above) >= plain * (1 - 1e-12)
        further += max(below, above) > 1.1 * plain
    assert lower >= 20  # (30-133 of the 300 boxes, by operator)
    if not isinstance(tree, bt.SuperBlend | bt.ControlledBlend):
        assert further >= 10


@pytest.mark.parametrize("tree", [_A + _B, bt.difference(_A, _B, smooth=0.1)])
def test_program_bound_at_gives_the_field_a_bound_and_safe_distances(tree):
    """``Program.bound_at`` (the mesher's cull), by either path (a blend root takes the plain
    bound and the batch field, a CSG root the value-aware pass): the field at each box's point,
    a bound over the box, and distances within which the field stays below / above 0.5."""
    prog = tree.program()
    rng = np.random.default_rng(3)
    c = rng.uniform(-1.0, 1.2, (200, 3))
    e = rng.uniform(0.01, 0.1, (200, 3))
    f, bound, below, above = prog.bound_at(c - e, c + e, c).T
    assert np.allclose(f, prog.field(c), rtol=0, atol=1e-12)
    for q in range(len(c)):
        P = c[q] + rng.uniform(-1.0, 1.0, (300, 3)) * e[q]
        fp, gp, _ = prog.evaluate(P)
        assert np.linalg.norm(gp, axis=1).max() <= bound[q] * (1 + 1e-9) + 1e-12
        distance = np.linalg.norm(P - c[q], axis=1)
        assert np.all(fp[distance < below[q] * (1 - 1e-9)] <= 0.5 + 1e-12)
        assert np.all(fp[distance < above[q] * (1 - 1e-9)] >= 0.5 - 1e-12)
