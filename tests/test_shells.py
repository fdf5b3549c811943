"""Shells from data (docs/shells.md): the spec format, the shipped species, grown spines and
pigment patterns on the shell."""

from __future__ import annotations

import importlib
import tomllib
from dataclasses import replace

import numpy as np
import pytest
import trimesh
from click.testing import CliRunner

import blobtree as bt
from blobtree.cli.main import main
from blobtree.models import SHELLS, load_spec, shell
from blobtree.models.growth import grown_varices
from blobtree.models.spec import FIELDS, read_toml, spec_from_data, to_toml
from blobtree.render.camera import framed_camera
from tests.shell_geometry import canal_length, canal_line, varix_theta, world

M = importlib.import_module("blobtree.models.murex")
MUREX = SHELLS["murex"]


def _write(tmp_path, text: str):
    path = tmp_path / "shell.toml"
    path.write_text(text)
    return path


# --- the format ----------------------------------------------------------------------------------

def test_every_shipped_spec_round_trips_through_its_full_toml():
    """to_toml writes every key; reading it back (no extends) gives the same spec."""
    for name, spec in SHELLS.items():
        data = tomllib.loads(to_toml(spec))
        assert "extends" not in data
        assert spec_from_data(data) == spec, name


def test_murex_from_a_full_spec_file_is_the_murex(tmp_path):
    """The Murex written out whole, read back from a file, builds the very tree murex() builds
    (structural key), so their fields are equal everywhere; spot-checked on points."""
    path = _write(tmp_path, to_toml(MUREX))
    built = shell(path, seed=0)
    reference = bt.models.murex(seed=0)
    assert built.key == reference.key
    lo, hi = reference.bounds()
    pts = np.random.default_rng(1).uniform(lo, hi, (400, 3))
    assert np.array_equal(built.program().field(pts), reference.program().field(pts))


def test_the_murex_spec_holds_the_paper_numbers():
    """Section 3 and Eqs. 7, 9, 14 read from species/murex.toml (Tables 1-2: test_murex)."""
    s = MUREX
    assert (s.spiral.beta, s.spiral.rho, s.spiral.r0, s.spiral.d_ratio) == (22.5, 1.3, 0.2, 0.341)
    assert (s.whorls, s.whorl_deg, s.sections_per_whorl, s.instances_per_section) == \
        (7, 348.0, 3, 6)
    assert s.theta_s == pytest.approx(116 / 6) and s.instances == 126 and s.sections == 21
    assert s.previous_whorl == (94, 108) and s.bump_blend_n == 400 and s.spine_bend == 30
    assert s.canal_sections == 4 and s.bump_sets == 5


@pytest.mark.parametrize("text, words", [
    ("name = 'x'\n", "version must be 1"),
    ("version = 2\n", "version must be 1"),
    ("version = 1\nextends = 'murex'\n[canal]\ntilt = 100\n", "canal.tilt must be"),
    ("version = 1\nextends = 'murex'\n[canal]\ntwist = 1\n", "canal.twist is not a spec key"),
    ("version = 1\nextends = 'murex'\n[hull]\nx = 1\n", "hull.x is not a spec key"),
    ("version = 1\nextends = 'murex'\ncolour = 1\n", "colour is not a spec key"),
    ("version = 1\nextends = 'murex'\n[varices]\ntable = [[]]\n", "one row per whorl (7)"),
    ("version = 1\nextends = 'murex'\n[varices]\ntable = [[], [[50]], [], [], [], [], []]\n",
     "varices.table[1][0] must be a list of 2"),
    ("version = 1\nextends = 'murex'\n[bumps]\nsets = 1.5\n", "bumps.sets must be an integer"),
    ("version = 1\nextends = 'murex'\n[canal]\nfuse = 1\n", "canal.fuse must be true or false"),
    ("version = 1\nextends = 'murex'\n[spiral]\nbeta = 30\n", "spiral.rho is missing"),
    ("version = 1\nextends = 'murex'\n[spiral]\nbeta = 95\nrho = 2\nr0 = 1\n", "spiral.beta"),
    ("version = 1\nextends = 'nautilus'\n", "extends must be one of"),
    ("version = 1\nname = 'bare'\n", "spec is missing"),
    ("version = 1\nextends = 'murex'\n[look]\ntexture = 'plaid'\n", "texture"),
    ("version = 1\nextends = 'murex'\n[opening]\nwall_join = 'glue'\n",
     "opening.wall_join must be one of ['clipped', 'union'], got 'glue'"),
    ("version = 1\nextends = 'murex'\n[varices]\ndown_canal = 3\n",
     "varices.down_canal must be a finite number >= 0 and <= 1, got 3"),
    ("version = 1\nextends = 'murex'\n[varices]\ntori = []\ndown_canal = 0.5\n",
     "varices.down_canal must be 0 when varices.tori lists none"),
    ("version = 1\nextends = 'murex'\n[canal_spines]\nbend_degrees = [20, 5]\n",
     "canal_spines.bend_degrees must be (low, high) with low <= high, got (20.0, 5.0)"),
    ("version = 1\nextends = 'murex'\n[canal_spines]\nbends = [3, 1]\n",
     "canal_spines.bends must be (low, high) with low <= high, got (3, 1)"),
    ("version = 1\n[canal\n", "not valid TOML"),
])
def test_bad_specs_are_refused_naming_the_key(tmp_path, text, words):
    path = _write(tmp_path, text)
    with pytest.raises(ValueError, match=None) as info:
        shell(path)
    assert words in str(info.value), str(info.value)
    assert str(path) in str(info.value)  # which file


def test_a_missing_spec_file_is_named(tmp_path):
    with pytest.raises(ValueError, match="cannot read"):
        load_spec(tmp_path / "nope.toml")
    with pytest.raises(ValueError, match="spec must be a shipped shell"):
        load_spec(42)


def test_a_spec_extending_another_changes_only_what_it_lists(tmp_path):
    path = _write(tmp_path, "version = 1\nextends = 'murex'\nname = 'Short canal'\n"
                            "[canal]\nstraight = 1.0\n")
    spec = load_spec(path)
    assert spec == replace(MUREX, name="Short canal", canal_straight=1.0)


def test_every_spec_key_is_documented():
    doc = open("docs/shells.md").read()
    for key in [*FIELDS, "spiral.beta", "spiral.rho", "spiral.r0", "spiral.d_ratio", "extends"]:
        assert f"`{key}`" in doc, key


# --- the species ---------------------------------------------------------------------------------

@pytest.mark.parametrize("name", sorted(SHELLS))
def test_every_shipped_species_renders_and_meshes_watertight(name):
    """Each spec builds, ray traces with the shell visible in the middle of its own view, and
    meshes to a closed surface."""
    tree = shell(name, seed=0)
    spec = SHELLS[name]
    assert tree.display == (spec.up, spec.view)
    cam = framed_camera(tree.program(), 24, 24, view=spec.view, up=spec.up)
    img = bt.render(tree, 24, 24, camera=cam, shadows=False)
    background = bt.render(bt.Point(radius=1e-3, center=(1e5, 0, 0)), 24, 24, camera=cam,
                           shadows=False)
    assert np.abs(img[12, 12].astype(int) - background[12, 12].astype(int)).sum() > 30
    mesh = bt.polygonize(tree, resolution=40)
    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    assert len(mesh.faces) > 1000 and tm.is_watertight


@pytest.mark.parametrize("resolution", [128, 320])
@pytest.mark.parametrize("name", sorted(SHELLS))
def test_every_shipped_shell_is_one_solid(name, resolution):
    """Printability: every shipped shell meshes to one closed solid (bubbles sealed inside it, wound
    inward, are part of it).  bench/print_pieces.py checks every 32 cells from 128 to 512."""
    mesh = bt.polygonize(shell(name, textured=False), resolution=resolution)
    assert mesh.is_watertight and mesh.solid_count() == 1


def test_a_sharp_lip_leaves_slivers_the_rounded_one_does_not():
    """The test of the test: the Oliva carved with the paper's sharp differences has a sliver
    of its lip as a second solid at 256 cells; rounded as shipped, one solid."""
    sharp = replace(SHELLS["oliva"], lip_smooth=0.0, cut_smooth=0.0)
    assert bt.polygonize(shell(sharp, textured=False), resolution=256).solid_count() > 1
    assert bt.polygonize(shell("oliva", textured=False), resolution=256).solid_count() == 1


def test_the_species_differ_from_the_murex():
    oliva, chicoreus = SHELLS["oliva"], SHELLS["chicoreus"]
    assert oliva.canal_sections == 0 and not any(oliva.table_1) and oliva.bump_sets == 0
    assert chicoreus.spine_branches == 2 and not any(chicoreus.table_1[:4])
    assert len({shell(n).key for n in SHELLS}) == len(SHELLS)


def _out_to(tree: bt.Node, start: np.ndarray, direction: np.ndarray, reach: float) -> float:
    """How far from ``start`` along ``direction`` (world) the tree's solid reaches: the last
    crossing of the surface within ``reach``, sampled every reach / 800."""
    t = np.linspace(0.0, reach, 801)
    inside = np.flatnonzero(tree.field(start + t[:, None] * direction) >= 0.5)
    return float(t[inside[-1]]) if len(inside) else 0.0


def test_varices_run_down_the_canal_as_ridges_carrying_the_spines():
    """varices.down_canal = 0.9: below each varix with a row of Table 2 (the last three, at the
    paper's angles) a ridge runs down the canal's outer side, standing more than 0.03 D out of
    the canal from 0.1 to 0.85 of its length (measured: 0.05-0.27 D), and ends by 0.95 (the
    canal bare again, as without it); the axis of each of Table 2's spines of the row runs
    through it."""
    spec = replace(MUREX, varices_down_canal=0.9)
    body = bt.models.body_whorl(spec=spec)
    ridged = bt.blend(body, *bt.models.varices(spec))
    plain = bt.blend(body, *bt.models.varices(MUREX))
    length = canal_length(spec)
    for row, k in enumerate((19, 20, 21), 1):
        theta = varix_theta(k)
        for frac, stands in [*((f, True) for f in np.linspace(0.1, 0.85, 10)), (0.95, False)]:
            p, n = canal_line(spec, frac * length)
            start = world([*p, 0.0], theta)[0]
            outward = world([*(p + n), 0.0], theta)[0] - start
            bare, ridge = _out_to(plain, start, outward, 2.0), _out_to(ridged, start, outward, 2.0)
            assert (ridge - bare > 0.03) == stands, (k, frac)  # outward is D long
        ridge = M.canal_ridge(k, spec)
        for base, degrees in M.canal_spine_frames(row, spec):  # each spine's axis crosses it
            a = np.radians(degrees)
            axis = base + np.linspace(0.0, 0.5, 51)[:, None] * (np.cos(a), np.sin(a))
            assert ridge.field(world(np.c_[axis, np.zeros(51)], theta)).max() >= 0.5, k


# --- grown spines and patterns -------------------------------------------------------------------

#: Table 1's range of deltas (the paper's: whorl 7, 80 and -40 degrees).
TABLE_1_DELTAS = (0.5, 1.92)


def _interior_extrema(deltas) -> tuple[int, int]:
    """(spines longer or shorter than both neighbours, spines with two neighbours) of a row."""
    d = np.asarray(deltas)
    m = d[1:-1]
    return int(np.sum(((m > d[:-2]) & (m > d[2:])) | ((m < d[:-2]) & (m < d[2:])))), len(m)


def test_grown_spines_change_gradually():
    """The activator-inhibitor's spines, one row per varix: their number never falls from
    varix to varix and rises by at most 3 over a whorl (Table 1 jumps by 10, from 8 to 18); a
    spine once placed stays (within 2 degrees) on the next varix; every spine lies on the
    lip."""
    spec = replace(MUREX, varix_placement="grown")
    rows = grown_varices(spec)
    assert len(rows) == 21
    counts = np.array([len(row) for row in rows])
    assert counts[:3].sum() == 0 and counts[-1] >= 8 and np.all(np.diff(counts) >= 0)
    assert np.all(counts[3:] - counts[:-3] <= 3)
    paper_steps = np.diff([len(row) for row in MUREX.table_1])
    assert paper_steps.max() >= 10
    for before, after in zip(rows[3:-1], rows[4:], strict=True):
        for alpha, _ in before:
            assert min(abs(alpha - a) for a, _ in after) <= 2.0
    assert all(-90 <= a <= 90 for row in rows for a, _ in row)
    assert grown_varices(replace(spec, name="again")) == rows  # deterministic


def test_grown_spines_alternate_long_and_short():
    """The second, slower pattern sets the sizes: they stay within Table 1's range and cover at
    least 70 % of it; the three varices of every whorl with spines differ; and on the last
    whorl long and short spines alternate as in Table 1, whose whorl 7 has 11 of its 16
    spines with two neighbours longer or shorter than both: at least 60 % here too, where the
    placement by one pattern alone gave spines within 1.15-1.25 of each other."""
    rows = grown_varices(replace(MUREX, varix_placement="grown"))
    deltas = [d for row in rows for _, d in row]
    lo, hi = TABLE_1_DELTAS
    assert lo <= min(deltas) and max(deltas) <= hi
    assert max(deltas) - min(deltas) >= 0.7 * (hi - lo)
    for w in range(2, 8):
        assert len(set(rows[3 * w - 3:3 * w])) == 3, w
    assert _interior_extrema([d for _, d in MUREX.table_1[6]]) == (11, 16)
    for row in rows[-3:]:
        extrema, interior = _interior_extrema([d for _, d in row])
        assert extrema >= 0.6 * interior


def test_a_pattern_changes_only_the_colours():
    """murex(pattern=...) grows pigment on the body: the field is the Murex's, the albedo is
    not, and it differs between patterns."""
    plain = bt.models.murex(seed=0, textured=False)
    waves = bt.models.murex(seed=0, pattern="waves")
    stripes = bt.models.murex(seed=0, pattern="stripes")
    lo, hi = plain.bounds()
    pts = np.random.default_rng(2).uniform(lo, hi, (60000, 3))
    f = plain.program().field(pts)
    assert np.array_equal(f, waves.program().field(pts))
    near = pts[(f > 0.45) & (f < 0.55)]
    assert len(near) > 20
    a, b = waves.program().albedo(near), stripes.program().albedo(near)
    assert np.abs(a - b).max() > 0.1
    with pytest.raises(ValueError, match="texture|name"):
        bt.models.murex(pattern="plaid").program().albedo(near[:2])


def test_a_grown_pattern_is_grown_once_for_numbers_it_does_not_depend_on():
    """The pigment of a shell is kept between builds: changing a number the pattern does not
    read (the varices) builds the tree without growing it again, and the shell is the one built
    from nothing; another seed grows another."""
    oliva = SHELLS["oliva"]
    M._grown_image.cache_clear()
    shell(oliva)
    other = replace(oliva, spine_length=oliva.spine_length * 1.1)
    kept = shell(other)
    assert M._grown_image.cache_info().hits == 1
    M._grown_image.cache_clear()
    assert shell(other) == kept
    image = M._grown_image.cache_info().currsize
    shell(other, seed=1)
    assert M._grown_image.cache_info().currsize == image + 1
    assert not M._paper_textures(0)["body"].flags.writeable  # kept images cannot be changed


# --- the command line ----------------------------------------------------------------------------

def test_cli_lists_the_species_and_prints_a_spec_that_renders(tmp_path):
    runner = CliRunner()
    listed = runner.invoke(main, ["models"])
    assert listed.exit_code == 0
    for name, spec in SHELLS.items():
        assert name in listed.output and spec.name in listed.output
    out = tmp_path / "mine.toml"
    r = runner.invoke(main, ["spec", "oliva", "-o", str(out)])
    assert r.exit_code == 0, r.output
    assert load_spec(out) == SHELLS["oliva"]
    assert read_toml(out)["name"] == "Oliva porphyria"
    png = tmp_path / "mine.png"
    r = runner.invoke(main, ["render", str(out), "-o", str(png), "--size", "16x16",
                             "--no-shadows"])
    assert r.exit_code == 0, r.output
    assert png.stat().st_size > 0
    ply = tmp_path / "mine.ply"
    r = runner.invoke(main, ["mesh", str(out), "-o", str(ply), "--resolution", "24"])
    assert r.exit_code == 0, r.output
    assert "watertight: yes" in r.output and ply.stat().st_size > 0


def test_the_parts_are_functions_not_modules():
    """bt.models.whorl is Eq. 9's function (a submodule of that name once shadowed it)."""
    assert callable(bt.models.whorl) and callable(bt.models.shell) and callable(bt.models.murex)


def test_render_without_a_camera_uses_the_view_the_shell_carries():
    """bt.render(tree) frames a shell along its spec's view, apex up, as the preview does."""
    tree = shell("oliva", textured=False)
    spec = SHELLS["oliva"]
    own = framed_camera(tree.program(), 32, 32, view=spec.view, up=spec.up)
    assert np.array_equal(bt.render(tree, 32, 32, shadows=False),
                          bt.render(tree, 32, 32, camera=own, shadows=False))
