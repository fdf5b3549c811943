"""The difference with rounded edges (``Difference.smooth``, for printable shells): a
polynomial smooth minimum of f_1 and 1 - f_2 over a band of field values, checked against the
formula, the sharp difference, finite differences and the compiled engine."""

import numpy as np
import pytest

import blobtree as bt

P = np.random.default_rng(5).uniform(-1.8, 2.4, (4000, 3))
A = bt.Point(radius=1.6).color((1, 0, 0))
B = bt.Cone((0.9, -1.5, 0.0), (0.6, 1.5, 0.3), radius_a=1.0, radius_b=0.7).color((0, 0, 1))
FA, FB = A.field(P), B.field(P)


def smooth_min(x: np.ndarray, y: np.ndarray, k: float) -> np.ndarray:
    """min(x, y) - k h^2 / 4, h = max(k - |x - y|, 0) / k: the formula the docstring states."""
    h = np.maximum(k - np.abs(x - y), 0.0) / k
    return np.minimum(x, y) - k * h * h / 4.0


@pytest.mark.parametrize("k", [0.05, 0.2, 0.5])
def test_rounded_difference_follows_the_formula(k):
    tree = bt.difference(A, B, smooth=k)
    expect = np.maximum(smooth_min(FA, 1.0 - FB, k), 0.0)
    np.testing.assert_allclose(tree.field(P), expect, rtol=0, atol=1e-13)
    f, g, c = tree.reference(P)
    np.testing.assert_allclose(f, expect, rtol=0, atol=1e-13)
    np.testing.assert_allclose(tree.gradient(P), g, rtol=1e-9, atol=1e-11)
    some = f > 0.0
    np.testing.assert_allclose(tree.albedo(P)[some], c[some], rtol=0, atol=1e-12)


def test_it_only_removes_material_near_the_edge_and_is_sharp_elsewhere():
    k = 0.2
    sharp, rounded = bt.difference(A, B).field(P), bt.difference(A, B, smooth=k).field(P)
    assert np.all(rounded <= sharp + 1e-15) and np.all(rounded >= sharp - k / 4 - 1e-15)
    away = np.abs(FA - (1.0 - FB)) >= k
    assert away.sum() > 1000 and np.array_equal(rounded[away], sharp[away])
    assert np.any(rounded[~away] < sharp[~away] - 1e-3)


def test_smooth_0_is_the_sharp_difference():
    expect = np.maximum(np.minimum(FA, 1.0 - FB), 0.0)
    assert np.array_equal(bt.difference(A, B, smooth=0.0).field(P), expect)


def test_its_gradient_is_the_field_s_derivative():
    tree = bt.difference(A, B, smooth=0.3)
    f = tree.field(P)
    pts = P[(f > 0.05) & (f < 0.95)][:300]
    e = 1e-6
    fd = np.stack([(tree.field(pts + d) - tree.field(pts - d)) / (2 * e)
                   for d in np.eye(3) * e], axis=1)
    np.testing.assert_allclose(tree.gradient(pts), fd, rtol=1e-4, atol=1e-5)


def test_a_rounded_edge_is_blunt():
    """A knife edge: a ball cut by a slightly offset, slightly smaller ball leaves a crescent
    whose horns taper to nothing.  Along rays from the centre the sharp cut leaves walls as thin
    as the sampling finds; rounded, the thinnest wall left is several times thicker."""
    outer, inner = bt.Point(radius=2.0), bt.Point(radius=1.9, center=(0.12, 0.0, 0.0))
    r = np.linspace(0.0, 2.0, 4001)
    phi = np.linspace(0.0, np.pi, 721)
    pts = np.stack([np.outer(np.cos(phi), r), np.outer(np.sin(phi), r),
                    np.zeros((phi.size, r.size))], axis=-1).reshape(-1, 3)
    thinnest = []
    for k in (0.0, 0.2):
        inside = bt.difference(outer, inner, smooth=k).field(pts).reshape(phi.size, -1) >= 0.5
        walls = inside.sum(axis=1) * (r[1] - r[0])
        thinnest.append(walls[walls > 0].min())
    assert thinnest[1] > 3.0 * thinnest[0]


def test_bad_smooth_is_refused_by_name():
    with pytest.raises(ValueError, match="smooth"):
        bt.difference(A, B, smooth=-0.1)
    with pytest.raises(ValueError, match="smooth"):
        bt.difference(A, B, smooth=0.9)
