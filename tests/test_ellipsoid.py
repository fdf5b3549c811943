"""The ellipsoid primitive against its closed form (the generic engine, bounds, Lipschitz and
scene-file tests cover it through the registry)."""

from __future__ import annotations

import numpy as np
import pytest

import blobtree as bt
from blobtree.fields import falloff_array


def test_a_lone_ellipsoid_has_its_surface_at_half_its_radii():
    e = bt.Ellipsoid(radii=(2.0, 1.0, 0.5), center=(0.3, -0.2, 0.1))
    c = np.array([0.3, -0.2, 0.1])
    tips = c + np.diag([1.0, 0.5, 0.25])  # radii / 2 along each axis: s = 1/4, f = 0.5
    np.testing.assert_allclose(e.field(np.vstack([tips, 2 * c - tips])), 0.5, atol=1e-12)
    np.testing.assert_allclose(e.field(c[None]), 1.0)
    assert e.field(c[None] + [[2.01, 0, 0]])[0] == 0.0


def test_field_and_gradient_follow_the_formula():
    radii, centre = np.array([1.5, 0.7, 1.1]), np.array([0.1, 0.2, -0.3])
    e = bt.Ellipsoid(radii=radii, center=centre, falloff="cubic")
    P = np.random.default_rng(4).uniform(-1.5, 1.5, (500, 3))
    u = (P - centre) / radii
    f, df = falloff_array("cubic", (u * u).sum(axis=1))
    np.testing.assert_allclose(e.field(P), f, atol=1e-12)
    np.testing.assert_allclose(e.gradient(P), df[:, None] * 2 * u / radii, atol=1e-12)


def test_an_ellipsoid_is_a_stretched_point():
    """An independent formulation: a unit point scaled by the radii (Eq. 8's s node)."""
    e = bt.Ellipsoid(radii=(1.8, 0.6, 1.2))
    p = bt.Point(radius=1.0).scale(1.8, 0.6, 1.2)
    P = np.random.default_rng(5).uniform(-2, 2, (2000, 3))
    np.testing.assert_allclose(e.field(P), p.field(P), atol=1e-12)
    np.testing.assert_allclose(e.gradient(P), p.gradient(P), atol=1e-12)
    lo, hi = e.bounds()
    np.testing.assert_allclose(hi, [1.8, 0.6, 1.2])
    np.testing.assert_allclose(lo, -hi)


def test_rotated_bounds_are_the_exact_box_of_the_ellipsoid():
    e = bt.Ellipsoid(radii=(2.0, 0.5, 0.5)).rotate("z", 90)
    lo, hi = e.bounds()
    np.testing.assert_allclose(hi, [0.5, 2.0, 0.5], atol=1e-12)


@pytest.mark.parametrize("radii", [(0, 1, 1), (-1, 1, 1), (1, 1), (1, "a", 1)])
def test_bad_radii_are_refused_by_name(radii):
    with pytest.raises(ValueError, match="radii"):
        bt.Ellipsoid(radii=radii)
