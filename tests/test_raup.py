"""Raup's coiling parameters (blobtree.models.raup, HelicoSpiral.from_raup): the mapping onto
Eqs. 1-3 against its closed form, and the shells' geometry measured on their fields."""

from __future__ import annotations

import math

import numpy as np
import pytest

import blobtree as bt
from blobtree.helico import MUREX_SPIRAL, HelicoSpiral
from blobtree.models import raup, raup_spec
from blobtree.models.spec import spec_from_data


def test_the_murex_spiral_in_raups_terms_and_back():
    """Eq. 7 (beta 22.5 deg, rho 1.3, D/R 0.341) is W = 1.3, T = cot 22.5 deg = 1 + sqrt 2 and
    D = (1 - 0.341) / (1 + 0.341); those give the same spiral back."""
    W, D, T = MUREX_SPIRAL.raup
    assert (W, D, T) == pytest.approx((1.3, 0.659 / 1.341, 1.0 + math.sqrt(2.0)), rel=1e-12)
    back = HelicoSpiral.from_raup(W, D, T, MUREX_SPIRAL.r0)
    for theta in (0.0, 116.0, 1000.0, 2436.0):
        assert back.centre(theta) == pytest.approx(MUREX_SPIRAL.centre(theta), rel=1e-12)
        assert back.size(theta) == pytest.approx(MUREX_SPIRAL.size(theta), rel=1e-12)


def test_a_spec_may_give_its_spiral_in_raups_terms():
    murex = bt.models.load_spec("murex")
    W, D, T = MUREX_SPIRAL.raup
    spec = spec_from_data({"version": 1, "extends": "murex",
                           "spiral": {"W": W, "D": D, "T": T, "r0": 0.2}},
                          resolve=lambda name: murex)
    assert spec.spiral.centre(500.0) == pytest.approx(MUREX_SPIRAL.centre(500.0), rel=1e-12)
    with pytest.raises(ValueError, match="needs all of"):
        spec_from_data({"version": 1, "extends": "murex", "spiral": {"W": 2.0, "beta": 30}},
                       resolve=lambda name: murex)


@pytest.mark.parametrize(("args", "name"), [((1.0, 0.2, 1.0), "W"), ((2.0, 1.0, 1.0), "D"),
                                           ((2.0, -0.1, 1.0), "D"), ((2.0, 0.2, -1.0), "T")])
def test_raups_parameters_outside_their_ranges_are_refused(args, name):
    with pytest.raises(ValueError, match=f"^{name} must be"):
        HelicoSpiral.from_raup(*args)


def _radial_hits(tree, spiral, theta, reach=3.0, n=3001):
    """Distances from the axis, along the horizontal ray from the axis through the spiral's
    centre at theta (at the centre's height), where the surface is crossed."""
    x, y, z = spiral.centre(theta)
    out = np.array([x, 0.0, z]) / math.hypot(x, z)
    t = np.linspace(0.0, reach * spiral.radius(theta), n)
    f = tree.field(np.array([0.0, y, 0.0]) + t[:, None] * out)
    inside = f >= 0.5
    return t[1:][inside[1:] != inside[:-1]]


def test_t_zero_is_a_planispiral():
    """T = 0: no displacement along the axis, so the shell is its own mirror image in y = 0."""
    tree = raup(2.0, 0.3, 0.0, whorls=3)
    P = np.random.default_rng(0).uniform(*tree.bounds(), size=(20_000, 3))
    assert np.allclose(tree.field(P), tree.field(P * [1.0, -1.0, 1.0]), atol=1e-12)
    lo, hi = tree.bounds()
    assert lo[1] == pytest.approx(-hi[1], rel=1e-9)


def test_d_zero_whorls_reach_the_axis_and_d_above_zero_opens_the_umbilicus():
    """The field on the coiling axis: inside the shell for D = 0, zero for D = 0.3."""
    for D, reaches in ((0.0, True), (0.3, False)):
        tree = raup(2.0, D, 2.0, whorls=3)
        lo, hi = tree.bounds()
        y = np.linspace(lo[1], hi[1], 2000)
        on_axis = tree.field(np.stack([0.0 * y, y, 0.0 * y], axis=1))
        assert (on_axis.max() >= 0.5) == reaches, D


def test_the_umbilicus_widens_with_d_as_raups_d_says():
    """The whorl's outer edge lies R + r from the axis and its inner edge R - r, r = k R with
    k = (1 - D) / (1 + D), measured at the centre's height of the third whorl: the umbilicus (the
    inner edge's distance) widens with D.  Where r nears R the blended tube swells toward the
    axis (the instances crowd on the inside of the turn), so the inner edge is held to Raup's
    only from D = 0.3."""
    theta = 2.5 * 360.0
    inner = []
    for D in (0.1, 0.3, 0.6):
        spiral = raup_spec(2.0, D, 2.0).spiral
        k, R = (1.0 - D) / (1.0 + D), spiral.radius(theta)
        hits = _radial_hits(raup(2.0, D, 2.0, whorls=3), spiral, theta) / R
        assert len(hits) == 2 and hits[1] == pytest.approx(1.0 + k, abs=0.04), D
        if D >= 0.3:
            assert hits[0] == pytest.approx(1.0 - k, abs=0.06), D
        inner.append(hits[0])
    assert inner == sorted(inner) and inner[0] > 0.0


def test_w_is_the_growth_of_the_generating_curve_over_one_turn():
    """The tube's width across, at the same point of two successive turns, grows by W."""
    W = 2.5
    spiral = raup_spec(W, 0.4, 2.0).spiral
    tree = raup(W, 0.4, 2.0, whorls=3)
    widths = []
    for theta in (1.25 * 360.0, 2.25 * 360.0):
        hits = _radial_hits(tree, spiral, theta)
        widths.append(hits[1] - hits[0])
    assert widths[1] / widths[0] == pytest.approx(W, rel=0.01)


def test_the_figure_is_raups_cube_in_a_labelled_grid(tmp_path):
    """``blobtree figures --only raup``: one cell per (W, D, T) of the figure's corner of the
    cube, W down the rows, each cell a shell on the backdrop with its label under it."""
    from click.testing import CliRunner
    from PIL import Image

    from blobtree.cli.main import main
    from blobtree.models.figures import RAUP_D, RAUP_T, RAUP_W

    rows, cols, side, gap, label = len(RAUP_W), len(RAUP_D) * len(RAUP_T), 18, 8, 18
    r = CliRunner().invoke(main, ["figures", "-o", str(tmp_path), "--only", "raup", "--height",
                                  str(rows * side), "--samples", "1", "--no-shadows"])
    assert r.exit_code == 0, r.output
    img = np.asarray(Image.open(tmp_path / "figure-raup.png").convert("RGB")).astype(int)
    assert img.shape == (gap + rows * (side + label + gap), gap + cols * (side + gap), 3)
    for i in range(rows):
        for j in range(cols):
            y, x = gap + i * (side + label + gap), gap + j * (side + gap)
            cell = img[y:y + side, x:x + side]
            under = img[y + side:y + side + label, x:x + side]
            assert np.ptp(cell) > 40, (i, j)  # a shell, not an empty backdrop
            assert (under < 128).any(), (i, j)  # its label's dark text
