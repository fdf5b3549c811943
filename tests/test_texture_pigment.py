"""Shell patterns grown by Meinhardt's reaction-diffusion models (blobtree.texture.pigment): each
preset is checked for the property it claims, measured on the image, not against stored
outputs."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from blobtree.texture import pigment as T
from blobtree.texture.pigment import ActivatorInhibitor, grow, pigment_texture

NAMES = list(T.PATTERNS)


def level(name: str, width: int, height: int, seed: int = 0) -> np.ndarray:
    """The pigment level (0 = ground colour, 1 = full pigment) read back from the image's
    colours: the distance from the ground colour over the ground-to-pigment distance."""
    p = T.PATTERNS[name]
    img = T.meinhardt(name, width, height, seed)
    ground, pigment = np.array(p.ground), np.array(p.pigment)
    return np.linalg.norm(img - ground, axis=2) / np.linalg.norm(pigment - ground)


@pytest.fixture(scope="module")
def levels() -> dict[str, np.ndarray]:
    """Every preset at 128 cells x 256 rows, seed 0."""
    return {name: level(name, 128, 256) for name in NAMES}


def peaks(row: np.ndarray, above: float) -> int:
    """Local maxima of a row above a level."""
    return int(np.sum((row[1:-1] > row[:-2]) & (row[1:-1] >= row[2:]) & (row[1:-1] > above)))


def runs(on: np.ndarray) -> list[tuple[int, int]]:
    """The [start, end) runs of True cells in a row."""
    d = np.diff(np.concatenate([[0], on.astype(int), [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=True))


def births_and_deaths(on: np.ndarray) -> tuple[int, int]:
    """Pigmented runs that appear from nothing (no pigment next to them in the row before) and
    runs that vanish (none next to them in the row after), over all rows."""
    born = died = 0
    for now, after in itertools.pairwise(on):
        born += sum(not now[max(s - 1, 0):e + 1].any() for s, e in runs(after))
        died += sum(not after[max(s - 1, 0):e + 1].any() for s, e in runs(now))
    return born, died


def local_shifts(lv: np.ndarray, lag: int = 4, window: int = 32, reach: int = 6) -> np.ndarray:
    """How far the pattern moves sideways in ``lag`` rows: for windows of ``window`` cells with
    some pattern in them, the shift in [-reach, reach] that best correlates row i with row
    i + lag."""
    out = []
    rows, cells = lv.shape
    for i in range(0, rows - lag, 3):
        for x in range(reach, cells - window - reach, window // 2):
            here = lv[i, x:x + window]
            if here.std() < 0.05:
                continue
            scores = []
            for s in range(-reach, reach + 1):
                there = lv[i + lag, x + s:x + s + window]
                scores.append(np.corrcoef(here, there)[0, 1] if there.std() > 1e-9 else -2.0)
            out.append(int(np.argmax(scores)) - reach)
    return np.array(out)


# ----- the images ------------------------------------------------------------------------------

@pytest.mark.parametrize("name", NAMES)
def test_an_rgb_image_in_the_unit_range(name):
    img = T.meinhardt(name, 40, 24, seed=3)
    assert img.shape == (24, 40, 3) and img.dtype == np.float64
    assert np.isfinite(img).all() and img.min() >= 0.0 and img.max() <= 1.0


@pytest.mark.parametrize("name", NAMES)
def test_colours_run_from_the_ground_to_the_pigment(name, levels):
    """Both ends of the blend occur: plain ground and (nearly) full pigment."""
    lv = levels[name]
    assert lv.min() < 0.05 and lv.max() > 0.9, (lv.min(), lv.max())


@pytest.mark.parametrize("name", NAMES)
def test_deterministic_by_seed_and_different_seeds_differ(name):
    a, b, c = (T.meinhardt(name, 64, 48, seed=s) for s in (7, 7, 8))
    assert np.array_equal(a, b)
    assert np.abs(a - c).max() > 0.05


def test_the_presets_differ_from_each_other(levels):
    for x, y in itertools.combinations(NAMES, 2):
        assert np.abs(levels[x] - levels[y]).mean() > 0.05, (x, y)


@pytest.mark.parametrize("name", NAMES)
def test_continuous_from_row_to_row(name, levels):
    """Each row is grown from the one before: consecutive rows differ much less than rows drawn
    at random."""
    lv = levels[name]
    rng = np.random.default_rng(0)
    i, j = rng.integers(0, len(lv), (2, 4000))
    step = np.abs(np.diff(lv, axis=0)).mean()
    apart = np.abs(lv[i] - lv[j]).mean()
    assert step < 0.6 * apart, (step, apart)


def test_the_image_is_the_tinted_activator():
    """meinhardt() is grow() with the preset's model, steps and warm-up, through tint()."""
    p = T.PATTERNS["waves"]
    a = T.grow(50, 30, p.steps_per_row, p.model, 4, p.warmup)
    expected = T.tint(a, p.low, p.high, np.array(p.ground), np.array(p.pigment))
    assert np.array_equal(T.meinhardt("waves", 50, 30, seed=4), expected)


# ----- each preset does what it claims -------------------------------------------------------

def test_stripes_keep_their_place_along_the_lip(levels):
    """A stable Turing pattern: the profile along the lip hardly changes over 200 rows, and has
    many peaks (stripes) in it."""
    lv = levels["stripes"]
    assert np.corrcoef(lv[40], lv[-1])[0, 1] > 0.9
    assert min(peaks(row, 0.5) for row in lv[40:]) >= 6
    assert not local_shifts(lv).any()  # nothing moves sideways


def test_waves_travel_along_the_lip_both_ways(levels):
    """Oblique lines: the pigment moves sideways from row to row, in both directions (inverted
    V's where a pacemaker starts two waves, V's where two waves meet)."""
    shifts = local_shifts(levels["waves"])
    assert len(shifts) > 100
    assert np.median(np.abs(shifts)) >= 1
    assert (shifts > 0).mean() > 0.05 and (shifts < 0).mean() > 0.05


def test_waves_annihilate_where_they_meet(levels):
    """Pigmented runs vanish (two waves meet) and new ones appear (a pacemaker fires)."""
    born, died = births_and_deaths(levels["waves"] > 0.5)
    assert born >= 3 and died >= 3
    assert births_and_deaths(levels["stripes"] > 0.5)[0] == 0


def test_triangles_open_and_close(levels):
    """Oliva porphyria: the number of waves (pigmented runs per row) and the pigmented share of
    the row rise and fall, many new waves appear and many vanish, and they travel both ways."""
    lv = levels["triangles"]
    on = lv > 0.5
    count = np.array([len(runs(row)) for row in on])
    assert count.max() - count.min() >= 6, (count.min(), count.max())
    share = on.mean(axis=1)
    assert share.std() > 0.25 * share.mean() and share.max() > 2 * share.min(), share
    born, died = births_and_deaths(on)
    assert born >= 20 and died >= 20, (born, died)
    shifts = local_shifts(lv)
    assert (shifts > 0).mean() > 0.2 and (shifts < 0).mean() > 0.2


def test_bands_run_parallel_to_the_growing_edge(levels):
    """All cells oscillate in phase: the pigment changes down the rows, not along them, and it
    comes back several times."""
    lv = levels["bands"]
    across = lv.std(axis=1).mean()  # along each row
    down = lv.mean(axis=1).std()  # between rows
    assert down > 5 * across, (down, across)
    dark = lv.mean(axis=1) > 0.5
    assert np.sum(dark[1:] & ~dark[:-1]) >= 3  # at least three lines


# ----- presets, sheet, errors ------------------------------------------------------------------

def test_presets_cite_their_equations():
    assert len(T.PATTERNS) >= 3
    kinds = {p.kind for p in T.PATTERNS.values()}
    assert {"activator-inhibitor", "activator-substrate"} <= kinds
    for name, p in T.PATTERNS.items():
        assert "ABoSS" in p.doc and "a'" in p.doc, name
        assert p.steps_per_row >= 1 and p.warmup > 0


def test_a_pattern_is_frozen_and_checked():
    p = T.PATTERNS["stripes"]
    with pytest.raises(AttributeError):
        p.warmup = 3
    with pytest.raises(ValueError, match="ground"):
        T.Pattern(p.model, 1, 0, (2.0, 0.0, 0.0), p.pigment, 0.0, 1.0, "")
    with pytest.raises(ValueError, match="high"):
        T.Pattern(p.model, 1, 0, p.ground, p.pigment, 1.0, 1.0, "")
    with pytest.raises(ValueError, match="model"):
        T.Pattern("stripes", 1, 0, p.ground, p.pigment, 0.0, 1.0, "")


def test_the_sheet_shows_every_preset_with_its_name():
    w, h = 24, 40
    sheet = T.pattern_sheet(w, h, seed=1)
    assert sheet.dtype == np.uint8 and sheet.ndim == 3 and sheet.shape[2] == 3
    assert sheet.shape[0] > h and sheet.shape[1] >= len(NAMES) * w
    for name in NAMES:  # each tile appears somewhere in the top band
        tile = T.to_uint8(T.meinhardt(name, w, h, seed=1))
        found = any(np.array_equal(sheet[y:y + h, x:x + w], tile)
                    for y in range(0, sheet.shape[0] - h) for x in range(0, sheet.shape[1] - w))
        assert found, name
    label = sheet[-12:]
    assert (label.sum(axis=2) < 200).any()  # dark text under the tiles


@pytest.mark.parametrize("kw, words", [
    (dict(width=0), "width"), (dict(height=-1), "height"), (dict(name="nope"), "name"),
    (dict(seed=-1), "seed"), (dict(width=2.5), "width"), (dict(height=True), "height"),
])
def test_bad_input_is_refused_by_name(kw, words):
    args = dict(name="stripes", width=16, height=8, seed=0) | kw
    with pytest.raises(ValueError, match=words) as err:
        T.meinhardt(**args)
    assert repr(kw[words]) in str(err.value)  # the value given


def test_an_unknown_name_lists_the_presets():
    with pytest.raises(ValueError) as err:
        T.meinhardt("nope", 16, 8)
    assert all(name in str(err.value) for name in NAMES)


@pytest.mark.parametrize("cls, kw, words", [
    (T.ActivatorSubstrate, dict(d_a=0.5), "d_a"), (T.ActivatorSubstrate, dict(r_a=0.0), "r_a"),
    (T.HormoneWaves, dict(s_b=0.0), "s_b"), (T.HormoneWaves, dict(r_c=1.5), "r_c"),
    (T.ActivatorInhibitor, dict(s_a=-1.0), "s_a"),
])
def test_bad_model_parameters_are_refused_by_name(cls, kw, words):
    with pytest.raises(ValueError, match=words):
        cls(**kw)


def test_grow_takes_only_a_model():
    with pytest.raises(ValueError, match="model"):
        T.grow(10, 10, model=T.PATTERNS["waves"])


# ----- the shell's pigment texture (pigment_texture) ----------------------------------------


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
