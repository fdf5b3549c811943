"""The Murex cabritii model: tables, part counts, seeding, opening, attachment, bounds."""

from __future__ import annotations

import importlib
import math
from dataclasses import replace

import numpy as np
import pytest

import blobtree as bt
from blobtree.nodes import Bend
from tests.shell_geometry import spiral, suture, world

pytestmark = pytest.mark.slow  # builds the full shell

# the module, not the murex() function a package export may shadow it with
M = importlib.import_module("blobtree.models.murex")
ISO = 0.5


def count(node: bt.Node, kind: type) -> int:
    return sum(isinstance(n, kind) for n in node.walk())


@pytest.fixture(scope="module")
def shell() -> bt.Node:
    return M.murex(seed=0)


# --- the tables, transcribed from the paper --------------------------------------------------

PAPER_TABLE_1 = """\
-90							0.55
-80							0.64
-70							0.55
-60							1.14
-50							0.55
-40							1.92
-30							0.55
-20							0.82
-10						0.55	0.55
0						0.8	1.44
10						1.55	0.64
20					0.9	0.64	0.64
30					0.7	0.7	0.55
40				0.8	1.5	0.55	1.62
50		0.8	0.9	1.5	0.64	0.96	0.72
60				0.7	1.06	0.6	0.64
70							0.55
80							0.5"""

PAPER_TABLE_2 = """\
1	0.96	0.95	1.00
2	0.92	0.99	0.90
3	0.84	0.76	0.92
4	0.68	0.51	0.70
5	0.45	0.35	0.60
6	0.25	0.28	"""


def test_table_1_matches_the_paper_cell_by_cell():
    expected: dict[int, list[tuple[float, float]]] = {w: [] for w in range(1, 8)}
    for line in PAPER_TABLE_1.splitlines():
        angle, *cells = line.split("\t")
        for w, cell in enumerate(cells, start=1):
            if cell:
                expected[w].append((float(angle), float(cell)))
    assert M.TABLE_1 == expected
    assert [len(M.TABLE_1[w]) for w in range(1, 8)] == [0, 1, 1, 3, 5, 8, 18]
    assert M.DEFAULT.delta_max == 1.92


def test_table_2_matches_the_paper_cell_by_cell():
    expected: dict[int, list[float]] = {1: [], 2: [], 3: []}
    for line in PAPER_TABLE_2.splitlines():
        _, *cells = line.split("\t")
        for v, cell in enumerate(cells, start=1):
            if cell:
                expected[v].append(float(cell))
    assert M.TABLE_2 == expected
    assert [len(M.TABLE_2[v]) for v in (1, 2, 3)] == [6, 6, 5]


def test_paper_constants():
    assert M.THETA_S == pytest.approx(116 / 6)
    assert M.SECTIONS == 21 and M.INSTANCES == 126
    assert 3 * M.SECTION_DEG == M.WHORL_DEG == 348
    assert M.varix_angle(1) == pytest.approx(5.5 * 116 / 6)  # over the join of sections 0, 1
    assert M.varix_angle(21) == pytest.approx(125 * 116 / 6)  # the lip: the last instance
    steps = [M.varix_angle(k + 1) - M.varix_angle(k) for k in (1, 10, 19)]
    assert steps == pytest.approx([116] * 3)


# --- structure and counts ---------------------------------------------------------------------


def test_body_whorl_is_21_controlled_sections_of_6_instances():
    body = M.body_whorl()
    assert isinstance(body, bt.ControlledBlend)
    # the 21 sections' points, then the canals of the last 1 1/3 whorls (4 sections)
    assert len(body.children) == 21 + 4
    assert [count(s, bt.Point) for s in body.children] == [6] * 21 + [0] * 4
    assert [count(s, bt.Cone) for s in body.children] == [0] * 21 + [6] * 4
    section = {j: j for j in range(21)} | {21 + c: 17 + c for c in range(4)}
    blends = [set(p) for p in body.pairs] + [set(g) for g, _ in body.groups]
    # Eq. 10's neighbours blend whole (points and canals) ...
    for j in range(20):
        whole = {c for c, s in section.items() if s in (j, j + 1)}
        assert whole in blends, j
    # ... and no blend holds the points of two sections that are not neighbours
    for b in blends:
        points = sorted(c for c in b if c < 21)
        assert not points or points[-1] - points[0] <= 1, b
    plain = M.body_whorl(spec=replace(M.DEFAULT, canal_fuse=False))
    assert len(plain.pairs) + len(plain.groups) == 20


@pytest.mark.parametrize("resolution", range(128, 513, 32))
def test_body_whorl_is_one_piece(resolution):
    """The canals fused leave no closed tunnel at any resolution bench/print_pieces.py meshes
    (128-512 cells, every 32): one solid, and no bubble sealed inside it at the resolutions
    the tests mesh shells at (at 480 cells Eq. 10's crease where whorl 2 meets whorl 1, far
    from the canal, seals two bubbles of 1e-8 units^3)."""
    mesh = bt.polygonize(M.body_whorl(), resolution=resolution)
    assert mesh.is_watertight and mesh.solid_count() == 1
    if resolution in (128, 192, 256, 320):
        assert mesh.component_count() == 1


def test_without_the_fuse_the_body_seals_bubbles():
    """The test of the test above: Eq. 10's pairs alone leave tunnels between the canals."""
    plain = M.body_whorl(spec=replace(M.DEFAULT, canal_fuse=False))
    assert bt.polygonize(plain, resolution=192).component_count() > 1


def test_the_canal_fuse_leaves_the_suture_as_eq_10_makes_it():
    """Along the whole last whorl (every half instance step up to the last instance) the
    surface across the outer suture lies where it lies without the fuse, to 0.005 D (the
    sampling step): a groove under half a D deep.  The test of the test: fusing whole
    sections a whorl apart (17 with 20) fills half of it along the last 100 degrees."""
    thetas = M.instance_angle(125) - np.arange(0.0, 348.0, M.THETA_S / 2)
    fused = M.body_whorl()
    plain = M.body_whorl(spec=replace(M.DEFAULT, canal_fuse=False))
    got = np.array([suture(fused.field, t) for t in thetas])
    expected = np.array([suture(plain.field, t) for t in thetas])
    np.testing.assert_allclose(got, expected, atol=0.005)
    assert np.all(got < 0.5)
    secs = M.sections()
    whole = bt.controlled_blend(secs, pairs=[(j, j + 1) for j in range(20)]
                                + [(17, 19), (17, 20), (18, 20)])
    filled = np.array([suture(whole.field, t) for t in thetas])
    assert np.sum(filled > 0.6) >= 100 / (M.THETA_S / 2) - 1


@pytest.mark.slow
@pytest.mark.parametrize("resolution", [128, 256])
def test_the_murex_is_one_piece(resolution):
    """Printability: the whole Murex meshes to one connected solid, no bubbles, no islands.
    The test of the test: with the paper's form of Eq. 15 as a union, sharp differences and a
    wall that only touches the previous whorl (wall_scale 0.95), the same mesh has many pieces."""
    mesh = bt.polygonize(M.murex(seed=0, textured=False), resolution=resolution)
    assert mesh.is_watertight and mesh.component_count() == 1
    old = replace(M.DEFAULT, wall_scale=0.95, inside_instances=(112, 127), lip_smooth=0.0,
                  cut_smooth=0.0)
    carved = bt.difference(M.outer_shell(0, old, False), M.opening(old))
    touching = bt.union(carved, M.inside_wall(old))
    assert bt.polygonize(touching, resolution=resolution).component_count() > 5


def test_eq_15_clipped_is_eq_15_where_the_wall_is_inside():
    """shell() computes S - (O - W), the union of Eq. 15 with the wall clipped to the shell:
    with sharp differences the same field as max(min(S, 1 - O), min(S, W)) (distributivity),
    checked at points.  Rounded as shipped, it stays within the rounding's reach of that field:
    each rounded min lies within smooth / 4 of the min, and min, 1 - f and the clamp pass
    differences on unchanged, so at most lip_smooth / 4 + 3 cut_smooth / 4 (Eq. 14's cut, the
    wall's own and the wall's hole in the opening)."""
    spec = replace(M.DEFAULT, lip_smooth=0.0, cut_smooth=0.0)
    s, o, w = M.outer_shell(0, spec, False), M.opening(spec), M.inside_wall(spec)
    lo, hi = o.bounds()
    pts = np.random.default_rng(3).uniform(lo, hi, (20000, 3))
    fs, fo, fw = (t.program().field(pts) for t in (s, o, w))
    expected = np.minimum(np.maximum(np.minimum(fs, 1.0 - np.minimum(fo, 1.0)),
                                     np.minimum(fs, fw)), 1.0)
    got = np.minimum(M.shell(spec, textured=False).program().field(pts), 1.0)
    assert np.allclose(got, expected, atol=1e-12)
    rounded = np.minimum(M.murex(seed=0, textured=False).program().field(pts), 1.0)
    reach = (M.DEFAULT.lip_smooth + 3.0 * M.DEFAULT.cut_smooth) / 4.0
    assert np.all(np.abs(rounded - expected) <= reach + 1e-12)
    assert np.abs(rounded - expected).max() > 0.1 * reach  # the rounding acts somewhere


def test_eq_15_as_the_papers_union():
    """opening.wall_join = "union" is Eq. 15 as printed: with sharp differences the field is
    max(min(S, 1 - O), W) at every point.  The shipped wall is larger than the body, so there
    it shows outside the shell, where the clipped form has nothing."""
    spec = replace(M.DEFAULT, lip_smooth=0.0, cut_smooth=0.0, wall_join="union")
    s, o, w = M.outer_shell(0, spec, False), M.opening(spec), M.inside_wall(spec)
    lo, hi = w.bounds()
    pts = np.random.default_rng(4).uniform(lo, hi, (20000, 3))
    fs, fo, fw = (t.program().field(pts) for t in (s, o, w))
    expected = np.minimum(np.maximum(np.minimum(fs, 1.0 - np.minimum(fo, 1.0)), fw), 1.0)
    got = np.minimum(M.shell(spec, textured=False).program().field(pts), 1.0)
    assert np.allclose(got, expected, atol=1e-12)
    outside = (fw >= ISO) & (fs < ISO)
    assert outside.sum() > 100
    clipped = M.shell(replace(spec, wall_join="clipped"), textured=False)
    assert np.all(clipped.program().field(pts[outside]) < ISO)


@pytest.mark.parametrize("resolution", [128, 256])
def test_the_murex_with_the_papers_union_is_one_solid(resolution):
    """Both forms of Eq. 15 mesh to one solid (bench/print_pieces.py's measure: bubbles sealed
    inside belong to it); the shipped spec clips the wall for its look (figure walls)."""
    tree = M.murex(seed=0, textured=False, wall_join="union")
    mesh = bt.polygonize(tree, resolution=resolution)
    assert mesh.is_watertight and mesh.solid_count() == 1


@pytest.mark.parametrize("resolution", [128, 256])
def test_the_murex_with_varices_down_the_canal_is_one_solid(resolution):
    """The ridges down the canal (varices.down_canal) keep the Murex one solid."""
    tree = M.murex(seed=0, textured=False, varices_down_canal=0.9)
    mesh = bt.polygonize(tree, resolution=resolution)
    assert mesh.is_watertight and mesh.solid_count() == 1


def test_whorl_places_instances_by_eq_8():
    w = M.whorl(3, 5)
    assert count(w, bt.Point) == 3
    r, h, _ = spiral(4 * M.THETA_S)
    t = math.radians(4 * M.THETA_S)
    centre = np.array([[r * math.cos(t), h, -r * math.sin(t)]])
    assert w.field(centre)[0] > 0.9


@pytest.mark.parametrize("w", range(1, 8))
def test_varix_counts_follow_table_1(w):
    v = M.varix(w)
    assert count(v, bt.Cone) == len(M.TABLE_1[w])
    assert count(v, bt.Torus) == 2
    assert count(v, Bend) == len(M.TABLE_1[w])


def test_three_varices_per_whorl():
    vs = M.varices()
    assert len(vs) == 21
    per_whorl = [sum(count(v, bt.Cone) for v in vs[3 * (w - 1):3 * w]) for w in range(1, 8)]
    assert per_whorl == [3 * len(M.TABLE_1[w]) for w in range(1, 8)]
    assert sum(count(v, bt.Torus) for v in vs) == 42


def test_bumps_five_sets_of_one_per_second_spine():
    for w in range(2, 8):
        ks = [k for k in range(1, 21) if k // 3 + 1 == w]
        assert len(ks) == 3
        assert len(M.bumps(0, intervals=ks)) == 3 * 5 * math.ceil(len(M.TABLE_1[w]) / 2)
    assert len(M.bumps(0)) == 15 * (1 + 1 + 2 + 3 + 4 + 9)


def test_canal_spine_rows_follow_table_2():
    spines = M.canal_spines(0)
    assert len(spines) == 17
    assert [count(s, bt.Cone) for s in spines] == [1] * 17
    for row, sizes in M.TABLE_2.items():
        frames = M.canal_spine_frames(row)
        assert len(frames) == len(sizes)
        gaps = np.diff([b for b, _ in frames], axis=0)
        assert np.all(np.linalg.norm(gaps, axis=1) > 0.2)
    # bent one to three times, 3-9 degrees each
    for s in spines:
        bends = [n for n in s.walk() if isinstance(n, Bend)]
        assert 1 <= len(bends) <= 3
        assert all(3.0 <= b.degrees <= 9.0 for b in bends)
    assert all(count(s, Bend) == 0 for s in M.canal_spines(None))


def test_whole_shell_structure_and_size(shell):
    # Eq. 15 as B_shell - (B_opening - B_inside_wall) (see murex.shell), Eq. 14 inside
    assert isinstance(shell, bt.Difference)
    outer, hole = shell.children
    assert isinstance(hole, bt.Difference)
    opening, wall = hole.children
    assert opening.key == M.opening().color(M.COLOURS["inside"]).key
    assert wall.key == M.inside_wall().color(M.COLOURS["inside"]).key
    prims = count(shell, bt.Primitive)
    assert 500 < prims < 3000
    assert count(shell, bt.SuperBlend) == 1
    sb = next(n for n in shell.walk() if isinstance(n, bt.SuperBlend))
    assert sb.n == 400 and len(sb.children) == 1 + 300


def test_opening_subtracts_previous_whorl_instances_94_to_108():
    op = M.opening()
    assert isinstance(op, bt.Difference)
    inside, previous = op.children
    assert count(previous, bt.Point) == 15
    a, b = M.DEFAULT.inside_instances
    assert count(inside, bt.Point) == b - a + 1
    assert count(inside, bt.Cone) == 8 * (b - a + 1)  # 4 inner-canal + 4 extension cones


# --- seeding ----------------------------------------------------------------------------------


def test_same_seed_same_field_other_seed_moves_bumps_and_spines():
    rng = np.random.default_rng(7)
    lo, hi = M.murex(seed=3).bounds()
    P = rng.uniform(lo, hi, (3000, 3))
    assert np.array_equal(M.murex(seed=3).field(P), M.murex(seed=3).field(P))

    def near(parts):
        pts = []
        for p in parts:
            a, b = p.bounds()
            pts.append(rng.uniform(a, b, (40, 3)))
        return np.concatenate(pts)

    for build in (M.bumps, M.canal_spines):
        a, b = bt.blend(*build(1)), bt.blend(*build(2))
        Q = near(build(1))
        assert np.array_equal(a.field(Q), bt.blend(*build(1)).field(Q))
        assert not np.allclose(a.field(Q), b.field(Q))


# --- the opening --------------------------------------------------------------------------------


def _radial_profile(tree, instance, alpha_deg, r_max=1.6, n=161):
    """Field along a ray in the generating plane from the instance's centre, at alpha."""
    r = np.linspace(0.0, r_max, n)
    a = math.radians(alpha_deg)
    local = np.stack([r * math.cos(a), r * math.sin(a), 0 * r], axis=1)
    return r, tree.field(world(local, M.instance_angle(instance)))


def test_aperture_is_hollow_with_a_wall_around_it(shell):
    centre = world(np.zeros((1, 3)), M.instance_angle(125))
    assert shell.field(centre)[0] < ISO
    for instance, alpha in ((125, -15.0), (122, 0.0), (118, -45.0), (115, 30.0)):
        r, f = _radial_profile(shell, instance, alpha)
        inside = f >= ISO
        assert not inside[0], (instance, alpha)
        first = int(np.argmax(inside))
        assert first > 0 and r[first] > 0.5
        rest = ~inside[first:]
        last = first + int(np.argmax(rest)) if rest.any() else len(r) - 1  # runs into a varix
        assert r[last] - r[first] >= 0.1, (instance, alpha, r[first], r[last])


# --- attachment and bounds ----------------------------------------------------------------------


def _spine_axis_world(whorl_index, k, samples=12, choices=M.DEFAULT):
    """Sample points on each varix spine's bent axis (Eqs. 11-13), world coordinates."""
    c = choices
    length = c.spine_length
    rho = length / math.radians(M.DEFAULT.spine_bend)
    phi = np.linspace(0.0, math.radians(M.DEFAULT.spine_bend), samples)
    arc = np.stack([rho * np.sin(phi), rho * (1 - np.cos(phi)), 0 * phi], axis=1)
    out = []
    for alpha, delta in M.TABLE_1[whorl_index]:
        p = arc * (delta, delta, M.DEFAULT.delta_max) + (c.spine_offset, 0.0, 0.0)
        a = math.radians(alpha)
        rot = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
        out.append(world(p @ rot.T, M.varix_angle(k)))
    return out


def test_no_varix_spine_floats_free(shell):
    for k in range(1, 22):
        for axis in _spine_axis_world(M.whorl_of_varix(k), k):
            assert np.all(shell.field(axis) >= ISO), k


def test_no_canal_spine_floats_free(shell):
    straight = M.body_whorl() + bt.blend(*M.canal_spines(None))
    for row, sizes in M.TABLE_2.items():
        theta = M.varix_angle(18 + row)
        for size, (base, direction) in zip(sizes, M.canal_spine_frames(row), strict=True):
            t = np.linspace(0.0, M.DEFAULT.canal_spine_length * size, 10)[:, None]
            d = (math.cos(math.radians(direction)), math.sin(math.radians(direction)), 0.0)
            axis = world(np.array([base[0], base[1], 0.0]) + t * d, theta)
            assert np.all(straight.field(axis) >= ISO)
            assert shell.field(axis[:1])[0] >= ISO  # the bent ones share the base


def test_canal_follows_its_centre_line():
    body = M.body_whorl()
    _, _, length = M._canal_geometry(M.DEFAULT)
    pts = np.array([[*M.canal_centreline(t)[0], 0.0] for t in np.linspace(0, length, 15)])
    assert body.field(world(pts, M.instance_angle(110))).min() >= ISO
    end = M.canal_centreline(length)[0]
    assert end[0] == pytest.approx(M.AXIS_X + M.DEFAULT.canal_gap)


def test_every_part_lies_within_bounds(shell):
    lo, hi = shell.bounds()
    pts = [a for k in range(1, 22) for a in _spine_axis_world(M.whorl_of_varix(k), k)]
    pts += [np.array(b.bounds()) .mean(axis=0)[None] for b in M.bumps(0)]
    pts = np.concatenate(pts)
    assert np.all(pts >= lo) and np.all(pts <= hi)
    rng = np.random.default_rng(1)
    span = hi - lo
    P = rng.uniform(lo - 0.3 * span, hi + 0.3 * span, (60000, 3))
    outside = np.any((P < lo) | (P > hi), axis=1)
    assert np.all(shell.field(P[outside]) == 0.0)
    assert np.any(shell.field(P[~outside]) >= ISO)


# --- bad input ----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: M.varix(0), "whorl_index"),
        (lambda: M.varix(8), "whorl_index"),
        (lambda: M.varix(1, tori=False), "whorl_index"),
        (lambda: M.whorl(5, 3), "b"),
        (lambda: M.whorl(-1, 3), "a"),
        (lambda: M.varix_angle(22), "k"),
        (lambda: M.canal_spine_frames(4), "row"),
        (lambda: M.spine(-1.0), "delta"),
        (lambda: M.canal_spine(float("nan")), "size"),
        (lambda: M.bumps(0, intervals=[21]), "intervals"),
        (lambda: M.murex(seed=-1), "seed"),
        (lambda: M.murex(spine_lenght=2.0), "spine_lenght"),
    ],
)
def test_bad_input_names_the_parameter(call, name):
    with pytest.raises(ValueError, match=name):
        call()
