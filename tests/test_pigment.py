"""Pigment grown by Meinhardt's activator-inhibitor model (the paper's ref. [5])."""

import numpy as np
import pytest

from blobtree.models.pigment import ActivatorInhibitor, grow, pigment_texture


def peaks(a: np.ndarray, level: float) -> int:
    return int(np.sum((a[1:-1] > a[:-2]) & (a[1:-1] >= a[2:]) & (a[1:-1] > level)))


def test_the_uniform_steady_state_of_the_equations_stays():
    """Without fluctuations the lip stays at a* = r_b / r_a, b* = a*^2 / r_b (ABoSS Eq. 2.1
    with s = 1 and no basic production), whatever the diffusion."""
    m = ActivatorInhibitor(fluctuation=0.0, r_a=0.02, r_b=0.05)
    a = grow(40, 50, 10, m)
    assert np.abs(a - 0.05 / 0.02).max() < 1e-12
    assert m.steady_state() == pytest.approx((2.5, 2.5**2 / 0.05))


def test_a_pattern_forms_only_when_the_inhibitor_spreads_faster():
    """Turing's condition: with D_b >> D_a the fluctuations grow into a pattern; with equal
    diffusion they die out."""
    turing = ActivatorInhibitor(d_a=0.01, d_b=0.4)
    even = ActivatorInhibitor(d_a=0.2, d_b=0.2)
    for m, big in ((turing, True), (even, False)):
        a = grow(128, 1, 1, m, seed=1, warmup=800)[-1]
        spread = (a.max() - a.min()) / m.steady_state()[0]
        assert (spread > 1.0) if big else (spread < 0.1), spread


def test_a_wider_reaching_inhibitor_makes_fewer_stripes():
    """The pattern's wavelength grows with the inhibitor's range sqrt(D_b / r_b)."""
    counts = []
    for d_b in (0.2, 0.4):
        m = ActivatorInhibitor(d_b=d_b)
        a = grow(256, 1, 1, m, seed=3, warmup=1500)[-1]
        counts.append(peaks(a, 1.5 * m.steady_state()[0]))
    assert counts[0] > counts[1] > 10


def test_reproducible_from_the_seed():
    a, b, c = (grow(64, 20, 4, seed=s, warmup=200) for s in (5, 5, 6))
    assert np.array_equal(a, b) and not np.array_equal(a, c)


def test_texture_is_an_image_with_pale_ground_and_dark_stripes():
    img = pigment_texture(64, 48, seed=2)
    assert img.shape == (64, 48, 3) and img.dtype == np.uint8
    lightness = img.astype(int).sum(axis=2)
    assert lightness.max() - lightness.min() > 200  # stripes on the ground
    flat = pigment_texture(8, 16, ActivatorInhibitor(fluctuation=0.0))
    assert (flat == flat[0, 0]).all()  # no fluctuation, no pattern


@pytest.mark.parametrize("kw, words", [
    (dict(d_b=0.6), "d_b"), (dict(d_a=-0.1), "d_a"), (dict(r_a=0.0), "r_a"),
    (dict(fluctuation=2.0), "fluctuation"),
])
def test_bad_parameters_are_refused_by_name(kw, words):
    with pytest.raises(ValueError, match=words):
        ActivatorInhibitor(**kw)


def test_bad_sizes_are_refused_by_name():
    with pytest.raises(ValueError, match="cells"):
        grow(2, 10)
    with pytest.raises(ValueError, match="model"):
        grow(10, 10, model="stripes")
