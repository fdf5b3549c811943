"""The four shell textures of Figure 12 and the textured Murex (Section 3.4)."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

import blobtree as bt
from blobtree.models import figures as F
from blobtree.nodes import Color, ControlledBlend, Texture
from blobtree.texture import shell as ST

pytestmark = pytest.mark.slow  # builds the full shell

M = importlib.import_module("blobtree.models.murex")

MAKERS = [t.make for t in ST.SHELL_TEXTURES.values()]


def luminance(rgb: np.ndarray) -> np.ndarray:
    return np.asarray(rgb, float) @ np.array([0.299, 0.587, 0.114])


@pytest.fixture(scope="module")
def shells() -> tuple[bt.Node, bt.Node]:
    return M.murex(0, textured=True), M.murex(0, textured=False)


@pytest.fixture(scope="module")
def near_surface(shells) -> np.ndarray:
    """Points within the shell's shell of field values 0.3-0.7 (around the surface)."""
    tree = shells[0]
    lo, hi = tree.bounds()
    P = np.random.default_rng(1).uniform(lo, hi, (400_000, 3))
    f = tree.field(P)
    return P[np.abs(f - 0.5) < 0.2]


# --- the textures ------------------------------------------------------------------------------


@pytest.mark.parametrize("make", MAKERS)
def test_texture_shape_dtype_and_seeding(make):
    a = make(0)
    assert a.ndim == 3 and a.shape[2] == 3 and a.dtype == np.uint8
    assert 16 <= min(a.shape[:2]) and max(a.shape[:2]) <= 256
    assert np.array_equal(a, make(0))
    assert not np.array_equal(a, make(1))
    assert a.std() > 5  # a pattern, not a flat colour


@pytest.mark.parametrize("make", MAKERS)
def test_texture_size_is_a_parameter(make):
    assert make(3, height=40, width=24).shape == (40, 24, 3)
    with pytest.raises(ValueError, match="height"):
        make(0, height=1)
    with pytest.raises(ValueError, match="seed"):
        make(-1)


def test_body_texture_tiles_in_u_and_v():
    """Figure 12(a) repeats along the spiral (one copy per section) and around the tube: the
    wrap-around step (last column to first, last row to first) is no larger than the steps
    between neighbouring texels inside the image."""
    for seed in range(4):
        a = ST.body_whorl_texture(seed).astype(int)
        assert np.abs(a[:, 0] - a[:, -1]).max() <= np.abs(np.diff(a, axis=1)).max()
        assert np.abs(a[0] - a[-1]).max() <= np.abs(np.diff(a, axis=0)).max()


@pytest.mark.parametrize("name", ["varix_spine", "canal_spine"])
def test_spine_textures_darken_toward_the_tip(name):
    a = ST.SHELL_TEXTURES[name].make(0)
    rows = luminance(a.mean(axis=1))
    assert rows[-1] < 0.5 * rows[0]
    assert ST.SHELL_TEXTURES[name].wrap == "clamp"  # the tip row stays dark at v = 1


def test_figure_12_shows_the_four_textures():
    img = F.TEXTURE_FIGURES["12"].draw()
    assert img.ndim == 3 and img.shape[2] == 3 and img.dtype == np.uint8
    assert img.shape[0] >= 256 and img.shape[1] > 4 * 128
    body = ST.body_whorl_texture(0)
    # the body texture's own colours appear in the figure
    assert np.isin(np.unique(body.reshape(-1, 3), axis=0).view("u1,u1,u1"),
                   np.unique(img.reshape(-1, 3), axis=0).view("u1,u1,u1")).mean() > 0.2
    assert "12" not in F.FIGURES


# --- the textured shell ------------------------------------------------------------------------


def test_texture_nodes_where_the_paper_puts_them(shells):
    textured, plain = shells
    texs = [n for n in textured.walk() if isinstance(n, Texture)]
    helico = [t for t in texs if t.mapping != "primitive"]
    # one per section of L_Blobtrees (Eq. 10), and one per canal of its canal sections
    assert len(helico) == M.SECTIONS + M.CANAL_SECTIONS
    body = next(n for n in textured.walk() if isinstance(n, ControlledBlend))
    assert all(isinstance(c, Texture) for c in body.children)
    assert helico[0].mapping.radius_factor * 1.0 > 1.16  # S bounds the tube (radius <= 1.16 D)
    assert sum(t.mapping == "primitive" for t in texs) == M.VARICES + 17 + 300
    assert not any(isinstance(n, Texture) for n in plain.walk())


def test_textured_shell_same_field_other_colours(shells, near_surface):
    textured, plain = shells
    P = near_surface[:20_000]
    assert np.array_equal(textured.field(P), plain.field(P))
    ct, cp = textured.albedo(P), plain.albedo(P)
    differs = np.abs(ct - cp).max(axis=1) > 0.02
    assert differs.mean() > 0.5
    # where the plain shell shows the body's single colour, the textured one shows a pattern
    on_body = np.all(np.abs(cp - M.COLOURS["body"]) < 1e-9, axis=1)
    assert on_body.sum() > 1000
    assert luminance(ct[on_body]).std() > 0.03


def test_varix_spine_tips_darker_than_bases(shells):
    """The largest spine of the last varix (Table 1, whorl 7: -40 deg, delta 1.92): the shell's
    colour near the spine's tip (cone v > 0.9) is darker than near its base (v < 0.35)."""
    textured = shells[0]
    ramp = (
        M.place(M.to_shell_frame(M.spine(1.92).rotate("z", -40.0)), M.varix_angle(21))
        .texture(lambda u, v: np.stack([v, v, v], axis=-1), wrap="clamp")
    )
    lo, hi = ramp.bounds()
    P = np.random.default_rng(2).uniform(lo, hi, (300_000, 3))
    keep = (ramp.field(P) > 0.3) & (np.abs(textured.field(P) - 0.5) < 0.1)
    P = P[keep]
    v = ramp.albedo(P)[:, 0]
    tip, base = P[v > 0.9], P[v < 0.35]
    assert len(tip) > 20 and len(base) > 20
    assert luminance(textured.albedo(tip)).mean() < 0.6 * luminance(textured.albedo(base)).mean()


def test_inside_stays_plain(shells):
    textured = shells[0]
    paints = [n for n in textured.walk() if isinstance(n, Color)]
    inside = [c for c in paints if np.allclose(c.rgb, M.COLOURS["inside"])]
    assert len(inside) == 2  # the opening and the inside wall
    assert not any(isinstance(n, Texture) for c in inside for n in c.walk())


def test_engine_equals_reference_near_the_surface(shells, near_surface):
    textured = shells[0]
    P = near_surface[np.random.default_rng(3).choice(len(near_surface), 300, replace=False)]
    f, g, c = textured.program().evaluate(P)
    fr, gr, cr = textured.reference(P)
    np.testing.assert_allclose(f, fr, atol=1e-9)
    np.testing.assert_allclose(g, gr, atol=1e-6, rtol=1e-6)
    live = f > 0
    np.testing.assert_allclose(c[live], cr[live], atol=1e-6)


def test_seed_varies_textures_not_only_geometry():
    a = M.murex(0).walk()
    b = M.murex(1).walk()
    ia = next(n for n in a if isinstance(n, Texture)).image
    ib = next(n for n in b if isinstance(n, Texture)).image
    assert not np.array_equal(ia, ib)
