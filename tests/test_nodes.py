"""Falloffs, primitives, operators and warps against their formulas."""

from __future__ import annotations

import math

import numpy as np
import pytest

import blobtree as bt
from blobtree import fields
from blobtree.nodes.kernel_math import power


@pytest.mark.parametrize("name", ["soft_object", "cubic"])
def test_falloff_ends_and_slopes(name):
    fid = fields.FALLOFFS[name]
    assert fields.falloff(fid, 0.0) == 1.0
    assert abs(fields.falloff(fid, 1.0)) < 1e-15
    # zero slope in r at both ends: df/dr = df/ds * 2r/R^2 -> 0 at r = 0; df/ds(1) = 0
    assert abs(fields.falloff_ds(fid, 1.0)) < 1e-12
    r = np.linspace(0, 1, 200001)
    f = fields.falloff(fid, r * r)
    slope = np.abs(np.gradient(f, r))
    assert slope[0] < 1e-4 and slope[-1] < 1e-4
    assert slope.max() <= fields.SLOPE[name]  # the Lipschitz constant we use is an upper bound
    # |df/ds| falls with s (a ray's rise bound, kernel_math.quadric_rise, takes it at the least s)
    ds = np.abs(fields.falloff_ds(fid, r * r))
    assert np.all(np.diff(ds) <= 1e-15)


def test_falloff_values_against_formulas():
    rng = np.random.default_rng(0)
    s = rng.uniform(0, 1, 1000)
    np.testing.assert_allclose(fields.soft_object(s),
                               1 - 4 / 9 * s**3 + 17 / 9 * s**2 - 22 / 9 * s, rtol=0, atol=1e-15)
    np.testing.assert_allclose(fields.cubic(s), (1 - s) ** 3, rtol=1e-13, atol=1e-15)


def test_iso_radii():
    assert fields.iso_radius("soft_object") == pytest.approx(0.5, abs=1e-12)
    assert fields.iso_radius("cubic") == pytest.approx(0.454202, abs=1e-6)


def test_lone_point_surface_at_half_radius():
    p = bt.Point(radius=2.0, center=(1, 2, 3))
    d = np.array([[1 + 1.0, 2, 3], [1, 2 - 1.0, 3], [1, 2, 3 + 1.0]])
    np.testing.assert_allclose(p.field(d), 0.5, atol=1e-12)
    assert p.field(np.array([[1 + 2.0, 2, 3]]))[0] == 0.0


def test_segment_and_cone_fields():
    s = bt.Segment((0, 0, 0), (2, 0, 0), radius=1.0)
    np.testing.assert_allclose(s.field(np.array([[1, 0.5, 0], [-0.5, 0, 0]])), 0.5, atol=1e-12)
    c = bt.Cone((0, 0, 0), (2, 0, 0), radius_a=1.0, radius_b=0.5)
    # at t = 1/2 the field radius is 0.75, so the surface is at 0.375
    assert c.field(np.array([[1.0, 0.375, 0]]))[0] == pytest.approx(0.5, abs=1e-12)


def test_torus_disc_cylinder_surfaces():
    t = bt.Torus(major_radius=2.0, radius=1.0)
    np.testing.assert_allclose(t.field(np.array([[2.5, 0, 0], [0, 0.5, 2.0]])), 0.5, atol=1e-12)
    d = bt.Disc(disc_radius=1.0, radius=1.0)
    np.testing.assert_allclose(d.field(np.array([[0.3, 0.5, 0.2], [1.5, 0, 0]])), 0.5,
                               atol=1e-12)
    c = bt.Cylinder((0, 0, 0), (0, 2, 0), cylinder_radius=0.5, radius=1.0)
    np.testing.assert_allclose(c.field(np.array([[1.0, 1.0, 0], [0.2, 2.5, 0.1]])), 0.5,
                               atol=1e-12)


@pytest.mark.parametrize("make, bad", [
    (lambda v: bt.Point(radius=v), -1.0),
    (lambda v: bt.Point(radius=v), 0.0),
    (lambda v: bt.Point(radius=v), float("nan")),
    (lambda v: bt.Point(center=(0, v, 0)), float("inf")),
    (lambda v: bt.Segment((0, 0, 0), (v, 0, 0)), 0.0),
    (lambda v: bt.Cone((0, 0, 0), (1, 0, 0), radius_a=v, radius_b=1), -0.1),
    (lambda v: bt.Torus(major_radius=v), 0.0),
    (lambda v: bt.Cylinder((0, 0, 0), (0, 1, 0), cylinder_radius=v), -2.0),
    (lambda v: bt.Point().scale(v), 0.0),
    (lambda v: bt.Point().translate(v, 0, 0), float("nan")),
    (lambda v: bt.super_blend(bt.Point(), n=v), 0.5),
])
def test_bad_parameters_are_refused_by_name(make, bad):
    with pytest.raises(ValueError) as e:
        make(bad)
    assert repr(bad) in str(e.value) or str(bad) in str(e.value) or "zero" in str(e.value) \
        or "differ" in str(e.value)


def test_bad_parameter_names_the_parameter():
    with pytest.raises(ValueError, match="radius_a"):
        bt.Cone((0, 0, 0), (1, 0, 0), radius_a=-1, radius_b=1)
    with pytest.raises(ValueError, match="pairs"):
        bt.controlled_blend([bt.Point(), bt.Point()], pairs=[(0, 2)])
    with pytest.raises(ValueError, match="axis"):
        bt.Point().rotate("w", 10)


def test_super_blend_exact_for_large_n():
    a = bt.Point(radius=1.0)
    b = bt.Point(radius=1.0, center=(0.5, 0, 0))
    P = np.random.default_rng(0).uniform(-1, 1.5, (2000, 3))
    fa, fb = a.field(P), b.field(P)
    for n in (1, 2, 10, 400, 1000):
        f = bt.super_blend(a, b, n=n).field(P)
        assert np.all(np.isfinite(f))
        m = np.maximum(fa, fb)
        expected = np.where(m > 0, m * ((fa / np.where(m > 0, m, 1)) ** n
                                        + (fb / np.where(m > 0, m, 1)) ** n) ** (1 / n), 0)
        np.testing.assert_allclose(f, expected, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(bt.super_blend(a, b, n=1).field(P), fa + fb, rtol=1e-12)
    # n -> infinity tends to the union (Eq. 5)
    assert np.abs(bt.super_blend(a, b, n=1000).field(P) - m).max() < 1e-3


def test_super_blend_of_many_small_fields_does_not_underflow():
    # 400 primitives whose fields are ~0.1 at the origin: f^400 underflows float64 (1e-400)
    nodes = [bt.Point(radius=1.0, center=(0.86, 0, 0)).rotate("z", 360 * i / 400)
             for i in range(400)]
    f = bt.super_blend(*nodes, n=400).field(np.zeros((1, 3)))[0]
    single = nodes[0].field(np.zeros((1, 3)))[0]
    assert 0 < single < 0.2
    assert f == pytest.approx(single * 400 ** (1 / 400), rel=1e-9)


def test_csg_operators():
    a = bt.Point(radius=2.0)
    b = bt.Point(radius=2.0, center=(1, 0, 0))
    P = np.random.default_rng(1).uniform(-2, 3, (1000, 3))
    fa, fb = a.field(P), b.field(P)
    np.testing.assert_allclose((a | b).field(P), np.maximum(fa, fb))
    np.testing.assert_allclose((a & b).field(P), np.minimum(fa, fb))
    np.testing.assert_allclose((a - b).field(P), np.minimum(fa, 1 - fb))
    np.testing.assert_allclose((a + b).field(P), fa + fb)


def test_controlled_blend_pairs():
    a, b, c = (bt.Point(radius=1.0, center=(x, 0, 0)) for x in (0.0, 0.6, 1.2))
    P = np.random.default_rng(2).uniform(-1, 2.2, (1000, 3))
    fa, fb, fc = a.field(P), b.field(P), c.field(P)
    f = bt.controlled_blend([a, b, c], pairs=[(0, 1), (1, 2)]).field(P)
    np.testing.assert_allclose(f, np.maximum(fa + fb, fb + fc))
    # a and c never blend: where b is 0, the field is max(fa, fc), not their sum
    g = bt.controlled_blend([a, b, c], pairs=[(0, 1)]).field(P)
    np.testing.assert_allclose(g, np.maximum(fa + fb, fc))


def test_colour_rules():
    red = bt.Point(radius=2.0).color((1, 0, 0))
    blue = bt.Point(radius=2.0, center=(1, 0, 0)).color((0, 0, 1))
    P = np.array([[0.3, 0.1, 0.0], [0.5, 0.0, 0.2]])
    fr, fb = red.field(P), blue.field(P)
    c = (red + blue).albedo(P)
    np.testing.assert_allclose(c[:, 0], fr / (fr + fb))
    np.testing.assert_allclose(c[:, 2], fb / (fr + fb))
    u = (red | blue).albedo(P)
    winner = np.where(fr >= fb, 0, 2)
    assert np.all(u[np.arange(2), winner] == 1.0)


def test_rotation_right_hand_rule():
    p = bt.Point(radius=1.0, center=(1, 0, 0)).rotate("z", 90)
    assert p.field(np.array([[0.0, 1.0, 0.0]]))[0] == pytest.approx(1.0)
    q = bt.Point(radius=1.0, center=(0, 0, 1)).rotate("y", 90)  # z -> x about y
    assert q.field(np.array([[1.0, 0.0, 0.0]]))[0] == pytest.approx(1.0)


def test_scale_translate():
    p = bt.Point(radius=1.0).scale(2, 1, 1).translate(5, 0, 0)
    np.testing.assert_allclose(p.field(np.array([[6.0, 0, 0], [5.0, 0.5, 0]])), 0.5, atol=1e-12)


def test_bend_curves_toward_positive_y():
    length, deg = 2.0, 90.0
    spine = bt.Segment((0, 0, 0), (length, 0, 0), radius=0.2).bend(deg, length)
    k = math.radians(deg) / length
    # the skeleton's end maps to the end of a quarter circle of radius 1/k centred at (0, 1/k)
    tip = np.array([[math.sin(k * length) / k, (1 - math.cos(k * length)) / k, 0.0]])
    assert spine.field(tip)[0] == pytest.approx(1.0, abs=1e-12)
    assert spine.field(np.array([[length, 0.0, 0.0]]))[0] == 0.0
    mid = np.array([[math.sin(k) / k, (1 - math.cos(k)) / k, 0.0]])
    assert spine.field(mid)[0] == pytest.approx(1.0, abs=1e-12)


def test_bend_map_kernel_matches_the_reference_before_on_and_past_the_arc():
    """The compiled query map (on the arc: arc length and distance from the centre, no sine or
    cosine) against the reference's rotate-and-translate form, map and Jacobian."""
    from blobtree.nodes.bend import bend_map

    bend = bt.Segment((0, 0, 0), (2, 0, 0), radius=0.2).bend(50, 2.0)
    packed = np.concatenate([bend.canonical.reshape(-1), bend.pack()])
    P = np.random.default_rng(4).uniform((-1.0, -1.0, -0.5), (3.0, 1.0, 0.5), (3000, 3))
    Q, J = bend.warp_points(P)
    out = np.array([bend_map(packed, 0, *p) for p in P])
    np.testing.assert_allclose(out[:, :3], Q, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(out[:, 3:].reshape(-1, 3, 3), J, rtol=1e-12, atol=1e-12)
    phi = np.arctan2(P[:, 0], 1.0 / bend.k - P[:, 1])
    regions = (phi <= 0.0), (phi > 0.0) & (phi < bend.k * bend.length), phi >= bend.k * bend.length
    assert all(r.sum() > 100 for r in regions)  # before, on and past the arc


def test_branch_free_atan2_matches_numpy_in_every_octant():
    """kernel_math.atan2 (a polynomial, so loops over points vectorise) against numpy's arctan2:
    every octant, both sides of the reduction at tan(pi/8), tiny and huge ratios, axes."""
    import numba

    from blobtree.nodes import kernel_math

    rng = np.random.default_rng(7)
    angle = rng.uniform(-math.pi, math.pi, 20000)
    radius = 10.0 ** rng.uniform(-200, 200, 20000)
    y, x = radius * np.sin(angle), radius * np.cos(angle)
    near = math.pi / 8 + rng.uniform(-1e-9, 1e-9, 2000)  # around the reduction's switch
    y = np.concatenate([y, np.sin(near), [0.0, 0.0, 1.0, -1.0, 0.0, 1e-300, 1.0]])
    x = np.concatenate([x, np.cos(near), [1.0, -1.0, 0.0, 0.0, 0.0, 1.0, 1e-300]])

    @numba.njit
    def run(y, x, out):
        for i in range(y.shape[0]):
            out[i] = kernel_math.atan2(y[i], x[i])

    out = np.empty(len(y))
    run(y, x, out)
    ref = np.arctan2(y, x)
    assert np.abs(out - ref).max() <= 4.5e-16
    assert np.all(np.abs(out - ref) <= 1e-15 * np.abs(ref) + 1e-300)


def test_twist_and_taper_move_the_shape():
    bar = bt.Segment((-1, 0, 0), (1, 0, 0), radius=0.2).translate(0, 0, 0)
    tw = bt.Segment((0, 0, 0), (0, 2, 0), radius=0.2).translate(0.5, 0, 0).twist(90, axis="y")
    # at height y = 1 the offset point (0.5, ., 0) has turned 90 degrees about +y: x -> -z
    assert tw.field(np.array([[0.0, 1.0, -0.5]]))[0] == pytest.approx(1.0, abs=1e-12)
    tp = bar.rotate("z", 90).translate(0.5, 1, 0).taper(1.0, axis="y")
    # cross-section scaled by 1 + y: at y = 1 the skeleton at x = 0.5 moves to x = 1.0
    assert tp.field(np.array([[1.0, 1.0, 0.0]]))[0] == pytest.approx(1.0, abs=1e-12)


def test_warp_validation():
    with pytest.raises(ValueError, match="too tight"):
        bt.Point(radius=1.0, center=(1, 0, 0)).bend(180, 0.5)
    with pytest.raises(ValueError, match="taper"):
        bt.Segment((0, -2, 0), (0, 2, 0), radius=0.3).taper(1.0, axis="y")
    with pytest.raises(ValueError, match="degrees"):
        bt.Point().bend(0, 1.0)


def test_points_are_validated():
    p = bt.Point()
    with pytest.raises(ValueError, match="shape"):
        p.field(np.zeros((3,)))
    with pytest.raises(ValueError, match="finite"):
        p.field(np.array([[np.nan, 0, 0]]))


def test_sum_of_nodes_and_flattening():
    nodes = [bt.Point(center=(i, 0, 0)) for i in range(5)]
    s = sum(nodes)
    assert isinstance(s, bt.Blend) and len(s.children) == 5


def test_warp_of_an_empty_child_is_empty():
    empty = bt.Point(radius=1.0) & bt.Point(radius=1.0, center=(5, 0, 0))
    for w in (empty.bend(10, 1.0), empty.twist(30), empty.taper(0.1)):
        lo, hi = w.bounds()
        assert np.all(lo > hi)
        assert np.all(w.field(np.zeros((3, 3))) == 0.0)


def test_whole_number_powers_match_pow():
    for n in (0.0, 1.0, 2.0, 30.0, 40.0, 120.0, 400.0, 2.5, 40.25, 1e5):
        for x in (0.0, 0.3, 0.9, 0.999, 1.0):
            assert power(x, n) == pytest.approx(x ** n, rel=1e-13, abs=1e-300)


def test_a_chain_of_affine_nodes_folds_into_one_map():
    """``Affine.folded``: the first node below a chain of affine nodes and the chain's maps
    composed, which frames the node below in one product (``framed``): the same map, within
    rounding, as the nodes' own maps applied one after another, and the points it maps."""
    from blobtree import geometry as geo

    cone = bt.Cone((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), radius_a=0.3, radius_b=0.1)
    top = cone.rotate("z", 30.0).translate(1.0, 2.0, 3.0).scale(0.5, 2.0, 1.5).rotate("x", 70.0)
    bottom, M = top.folded
    assert bottom is cone
    nodes, expected = top, geo.IDENTITY
    while nodes.KIND == "affine":
        expected, nodes = geo.compose(expected, nodes.matrix), nodes.child
    np.testing.assert_allclose(M, expected, rtol=0, atol=1e-14)
    L = geo.affine(np.diag([2.0, 1.0, 1.0]), np.array([0.0, 1.0, 0.0]))
    node, framed = top.below(L)
    assert node is cone
    P = np.random.default_rng(1).normal(size=(5, 3))
    np.testing.assert_allclose(geo.apply(framed, P), geo.apply(L, geo.apply(expected, P)),
                               atol=1e-13)
