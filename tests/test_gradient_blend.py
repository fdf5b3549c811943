"""The gradient-based blend (``bt.gradient_blend``, after Gourmel et al. 2013): its field against
the formula written out here from the children's own fields, the union where the shapes do not
meet, no bulge over two crossing cylinders, sound bounds, refused parameters, and the Murex's
``bumps.join = "gradient"``."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import blobtree as bt
from blobtree.models.murex import bumps
from blobtree.render import intersect
from tests.conftest import examples
from tests.trees import check_box_bounds, trees

A = bt.Segment((-2.0, 0.0, 0.0), (2.0, 0.0, 0.0), radius=1.0)  # two crossing cylinders
B = bt.Segment((0.0, 0.0, -2.0), (0.0, 0.0, 2.0), radius=1.0)


def formula(a, b, P, step, floor, power, contact):
    """h = max + (1 - c^2)^power t(min): c the cosine between the forward-difference gradients
    of a and b over ``step`` (directions shrunk below ``floor``), t the lower field's share
    (0 below ``contact``, rising linearly to it at 0.5, itself above, at most 1)."""
    def direction(node):
        f = node.field(P)
        D = np.stack([(node.field(P + step * e) - f) / step for e in np.eye(3)], axis=1)
        return f, D / np.maximum(np.linalg.norm(D, axis=1), floor)[:, None]

    fa, na = direction(a)
    fb, nb = direction(b)
    c = np.clip((na * nb).sum(axis=1), -1.0, 1.0)
    low = np.minimum(fa, fb)
    t = np.where(low >= 0.5, np.minimum(low, 1.0),
                 np.clip((low - contact) / (1.0 - 2.0 * contact), 0.0, None))
    return np.maximum(fa, fb) + (1.0 - c * c) ** power * t


@pytest.mark.parametrize("power, contact", [(1.0, 0.0), (3.0, 0.3)])
def test_field_follows_the_formula_from_the_childrens_fields(power, contact):
    a, b = A, bt.Point(radius=1.3).translate(0.4, 0.7, 0.1) + B
    g = bt.gradient_blend(a, b, step=0.05, floor=0.02, power=power, contact=contact)
    P = np.random.default_rng(1).uniform(-2.5, 2.5, (4000, 3))
    want = formula(a, b, P, 0.05, 0.02, power, contact)
    assert np.allclose(g.field(P), want, rtol=0, atol=1e-12)
    assert np.allclose(g.reference(P)[0], want, rtol=0, atol=1e-12)


def test_union_where_either_field_is_zero_and_never_below_it():
    g = bt.gradient_blend(A, B)
    P = np.random.default_rng(2).uniform(-3.0, 3.0, (20000, 3))
    fa, fb, f = A.field(P), B.field(P), g.field(P)
    union = np.maximum(fa, fb)
    assert np.all(f >= union)
    apart = (fa == 0.0) | (fb == 0.0)
    assert apart.sum() > 5000 and np.array_equal(f[apart], union[apart])
    assert np.any(f[~apart] > union[~apart] + 0.05)  # and it does blend where both are there


def test_contact_blends_only_where_both_fields_reach_it():
    g = bt.gradient_blend(A, B, contact=0.3)
    P = np.random.default_rng(3).uniform(-2.0, 2.0, (20000, 3))
    fa, fb, f = A.field(P), B.field(P), g.field(P)
    weak = np.minimum(fa, fb) <= 0.3
    assert np.array_equal(f[weak], np.maximum(fa, fb)[weak])


def _outermost(tree, direction, reach=2.0):
    """How far from the origin along ``direction`` the surface lies (dense samples)."""
    t = np.linspace(0.0, reach, 20001)
    f = tree.field(np.outer(t, direction))
    return t[np.nonzero(f >= 0.5)[0].max()]


def test_no_bulge_over_crossing_cylinders_and_a_fillet_in_their_crease():
    """Over the crossing the cylinders' gradients are parallel: the gradient blend stays at the
    union's height (the sum bulges by a third); in the crease they are perpendicular: it fills
    it as the sum does; away from the crossing it is the union, exactly."""
    union, total, joined = A | B, A + B, bt.gradient_blend(A, B, power=2.0)
    up = np.array([0.0, 1.0, 0.0])
    assert _outermost(union, up) == pytest.approx(0.5, abs=1e-3)
    assert _outermost(total, up) > 0.6
    assert abs(_outermost(joined, up) - _outermost(union, up)) < 0.005
    crease = np.array([1.0, 0.0, 1.0]) / np.sqrt(2.0)
    assert _outermost(joined, crease) > _outermost(union, crease) + 0.1
    assert _outermost(joined, crease) == pytest.approx(_outermost(total, crease), abs=0.01)
    # along a cylinder, away from the other: the same surface as the union
    P = np.random.default_rng(4).uniform(-1.0, 1.0, (5000, 3)) + [3.0, 0.0, 0.0]
    P[:, 0] = np.clip(P[:, 0], 1.6, 4.0)
    assert np.array_equal(joined.field(P), union.field(P))


@pytest.mark.parametrize("tree", [bt.gradient_blend(A, B, power=2.0),
                                  bt.gradient_blend(A, B, contact=0.3) + bt.Point(radius=0.5),
                                  bt.difference(bt.gradient_blend(A, B), bt.Point(radius=0.6))])
def test_bounds_hold_over_small_boxes(tree):
    """``Program.bound_at`` (the value-aware pass where the root has a bound kernel, else the
    plain ``scaled`` rule) and ``Program.lipschitz``: each bound is at least every gradient
    sampled in its box, and the field keeps its side of 0.5 within the safe distances."""
    prog = tree.program()
    rng = np.random.default_rng(5)
    c = rng.uniform(-1.3, 1.3, (150, 3))
    e = rng.uniform(0.005, 0.08, (150, 3))
    f, bound, below, above = prog.bound_at(c - e, c + e, c).T
    plain = prog.lipschitz(c - e, c + e)
    assert np.allclose(f, prog.field(c), rtol=0, atol=1e-12)
    for q in range(len(c)):
        P = c[q] + rng.uniform(-1.0, 1.0, (300, 3)) * e[q]
        fp, gp, _ = prog.evaluate(P)
        slope = np.linalg.norm(gp, axis=1).max()
        assert slope <= bound[q] * (1 + 1e-9) + 1e-12
        assert slope <= plain[q] * (1 + 1e-9) + 1e-12
        distance = np.linalg.norm(P - c[q], axis=1)
        assert np.all(fp[distance < below[q] * (1 - 1e-9)] <= 0.5 + 1e-12)
        assert np.all(fp[distance < above[q] * (1 - 1e-9)] >= 0.5 - 1e-12)


def test_the_tracer_finds_the_surface_the_field_has():
    """Rays straight down onto the crossing hit where dense sampling finds the surface."""
    tree = bt.gradient_blend(A, B, contact=0.2)
    xs = np.linspace(-1.4, 1.4, 8)  # no ray grazes a cylinder (|x|, |z| = 0.5)
    origins = np.array([[x, 3.0, z] for x in xs for z in xs])
    t = intersect(tree, origins, np.tile([0.0, -1.0, 0.0], (len(origins), 1)))
    ys = np.linspace(3.0, -3.0, 60001)
    for o, hit in zip(origins, t, strict=True):
        f = tree.field(np.column_stack([np.full_like(ys, o[0]), ys, np.full_like(ys, o[2])]))
        inside = np.nonzero(f >= 0.5)[0]
        if len(inside) == 0:
            assert not np.isfinite(hit)
        else:
            assert hit == pytest.approx(3.0 - ys[inside[0]], abs=2e-3)


def test_ties_take_the_first_childs_colour_in_engine_and_reference():
    """Two copies of a segment (its ends swapped): beyond their common end their fields agree
    up to rounding, which went one way in the engine and the other in the reference, so the
    colours differed (found by the thorough hypothesis profile).  Ties go to the first child."""
    from blobtree.engine import GRID_MIN_POINTS
    from blobtree.nodes.texture import Texture

    image = np.random.default_rng(0).uniform(0.0, 1.0, (4, 4, 3))
    first = bt.Segment((0, 0, 1), (0, 0, 0), radius=1.0)
    second = Texture(bt.Segment((0, 0, 0), (0, 0, 1), radius=1.0), image=image,
                     mapping="primitive", wrap="repeat")
    tree = bt.GradientBlend(first, second, step=0.0, floor=0.0, power=1.0, contact=0.0)
    P = np.random.default_rng(1).uniform(-1.0, 1.0, (GRID_MIN_POINTS + 5000, 3))
    P[:, 2] = np.random.default_rng(2).uniform(-1.0, 0.0, len(P))  # beyond the common end
    f, _, c = tree.program().evaluate(P)
    fr, _, cr = tree.reference(P)
    live = fr > 1e-9
    assert live.sum() > 5000
    np.testing.assert_allclose(c[live], cr[live], atol=1e-9)


@pytest.mark.parametrize("kwargs, name", [({"power": 0.5}, "power"), ({"contact": 0.5}, "contact"),
                                          ({"step": -1.0}, "step"), ({"floor": np.nan}, "floor"),
                                          ({"step": 5e-324}, "step"), ({"floor": 1e-300}, "floor")])
def test_bad_parameters_are_refused_by_name(kwargs, name):
    with pytest.raises(ValueError, match=name):
        bt.gradient_blend(A, B, **kwargs)


def test_it_takes_exactly_two_shapes():
    with pytest.raises(ValueError, match="exactly 2"):
        bt.GradientBlend(A, B, A)


def test_scene_files_keep_it(tmp_path):
    tree = bt.gradient_blend(A, B, power=2.0, contact=0.25).color((0.5, 0.2, 0.1))
    bt.save(tree, tmp_path / "g.json")
    assert bt.load(tmp_path / "g.json") == tree


def test_murex_bumps_join_by_the_gradient_blend_where_asked():
    """``bumps.join = "gradient"``: each section with bumps is a gradient blend of it and their
    union; wherever no bump reaches, the shell's field is the paper's."""
    paper = bt.models.murex(textured=False, inside=False)
    ours = bt.models.murex(textured=False, inside=False, bump_join="gradient")
    joins = [n for n in ours.walk() if isinstance(n, bt.GradientBlend)]
    with_bumps = [k for k in range(1, bt.models.SHELLS["murex"].sections) if bumps(None, [k])]
    assert len(joins) == len(with_bumps) > 10
    assert not any(isinstance(n, bt.GradientBlend) for n in paper.walk())
    bump_set = [n.children[1] for n in joins]
    lo, hi = ours.bounds()
    P = np.random.default_rng(6).uniform(lo, hi, (20000, 3))
    clear = np.all([b.field(P) == 0.0 for b in bump_set], axis=0)
    assert clear.sum() > 1000
    assert np.allclose(ours.field(P[clear]), paper.field(P[clear]), rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="join"):
        bt.models.shell({"version": 1, "extends": "murex", "bumps": {"join": "sum"}})


@examples(0.5)
@given(trees(max_leaves=4), trees(max_leaves=4), st.integers(0, 2**31), st.floats(0.02, 0.4),
       st.floats(1.0, 4.0), st.floats(0.0, 0.45))
def test_bounds_hold_for_random_children(a, b, seed, frac, power, contact):
    """The gradient blend of two random trees: the engine's field at a point of a box is the
    reference's, and both bound passes (value-aware and plain) bound every gradient sampled in
    the box and keep the field on its side of 0.5 within the distances they give."""
    tree = bt.gradient_blend(a, b.translate(0.3, 0.1, 0.0), power=power, contact=contact)
    check_box_bounds(tree, seed, frac, 20)


def test_nested_blends_with_automatic_steps_stay_equal_to_the_reference():
    """A gradient blend's own Lipschitz bound is far above its slopes, so a parent's automatic
    step (a fifth of 1 / L) would shrink to the rounding level at three levels of nesting and
    its differences would be noise; the step is kept to at least a thousandth of the child's
    box, and engine and reference agree."""
    inner = bt.gradient_blend(bt.Point(radius=1.0).translate(0.5, 0.0, 0.0), bt.Point(radius=1.0))
    tree = bt.gradient_blend(A, bt.gradient_blend(bt.Point(radius=1.0), inner))
    smaller = min(np.linalg.norm(hi - lo) for lo, hi in (c.bounds() for c in tree.children))
    assert tree.used_step >= 1e-3 * smaller
    lo, hi = tree.bounds()
    P = np.random.default_rng(7).uniform(lo, hi, (3000, 3))
    np.testing.assert_allclose(tree.field(P), tree.reference(P)[0], rtol=1e-9, atol=1e-12)


def test_no_blending_across_a_gap():
    """Two parallel cylinders 0.2 apart: the sum bridges the gap (their fields add above 0.5
    between them); there their gradients are opposed, and the gradient blend leaves it open,
    within 0.02 of the union (forward differences, one-sided, tilt both directions a little the
    same way, so they are not exactly opposed)."""
    far = bt.Segment((-2.0, 1.2, 0.0), (2.0, 1.2, 0.0), radius=1.0)
    line = np.column_stack([np.zeros(1201), np.linspace(0.52, 0.68, 1201), np.zeros(1201)])
    assert (A + far).field(line).min() > 0.5
    joined = bt.gradient_blend(A, far).field(line)
    assert joined.max() < 0.5
    assert np.abs(joined - (A | far).field(line)).max() < 0.02


def test_a_small_detail_is_not_blown_up():
    """A small point on a large one: the sum lifts its top by 0.14; the gradient blend keeps it
    within 0.005 of the union's (the two gradients are parallel there)."""
    big, small = bt.Point(radius=4.0), bt.Point(radius=0.6).translate(0.0, 2.0, 0.0)
    up = np.array([0.0, 1.0, 0.0])
    union_top = _outermost(big | small, up, reach=4.0)
    assert _outermost(big + small, up, reach=4.0) > union_top + 0.1
    assert abs(_outermost(bt.gradient_blend(big, small), up, reach=4.0) - union_top) < 0.005
