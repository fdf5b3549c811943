"""Meshes for printing: checked by an independent geometry library (manifold3d), exported at a
real size (3MF in millimetres, STL) standing up (+Z up, on z = 0, centred), GLB with +Y up,
small pieces dropped only when asked."""

import math
import zipfile

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings

import blobtree as bt
from blobtree.cli.main import main
from tests.trees import trees

m3 = pytest.importorskip("manifold3d", reason="the test extra installs manifold3d")


def manifold(mesh: bt.Mesh):
    """The mesh as a manifold3d solid (manifold3d checks it; it knows nothing of blobtree)."""
    solid = m3.Manifold(m3.Mesh(vert_properties=np.asarray(mesh.vertices, dtype=np.float32),
                                tri_verts=np.asarray(mesh.faces, dtype=np.uint32)))
    return solid


def ball(radius: float = 2.0) -> bt.Node:
    """A point primitive: its surface is the sphere of radius ``radius`` / 2."""
    return bt.Point(radius=radius)


def test_a_ball_is_one_manifold_solid_of_the_sphere_volume():
    mesh = bt.polygonize(ball(), resolution=64)
    solid = manifold(mesh)
    assert solid.status() == m3.Error.NoError
    assert len(solid.decompose()) == 1
    assert solid.volume() == pytest.approx(4.0 / 3.0 * math.pi, rel=0.01)  # radius 1


def field_volume(prog, n: int = 200) -> float:
    """The field's own estimate of the solid's volume: the share of an n^3 grid over the
    bounds (cell centres) with f >= 0.5."""
    lo, hi = (np.asarray(b) for b in prog.bounds)
    axes = [lo[k] + (np.arange(n) + 0.5) * (hi[k] - lo[k]) / n for k in range(3)]
    inside = 0
    for x in np.array_split(axes[0], 8):  # slabs
        P = np.stack(np.meshgrid(x, axes[1], axes[2], indexing="ij"), -1).reshape(-1, 3)
        inside += int((prog.field(P) >= 0.5).sum())
    return inside * float(np.prod((hi - lo) / n))


def test_whorl126_is_manifold_and_its_volume_matches_the_field():
    tree = bt.models.whorl126()
    solid = manifold(bt.polygonize(tree, resolution=128))
    assert solid.status() == m3.Error.NoError
    assert solid.volume() == pytest.approx(field_volume(tree.program()), rel=0.01)


@pytest.mark.parametrize("name", sorted(bt.models.SHELLS))
def test_built_in_shells_are_manifold_and_their_volume_matches_the_field(name):
    """Each shipped shell meshed at 128 cells is a valid manifold (manifold3d), and its volume
    is within 1% of the field's own (measured: murex -0.03%, chicoreus -0.11%, oliva -0.43%)."""
    prog = bt.models.shell(name, textured=False).program()
    solid = manifold(bt.polygonize(prog, resolution=128))
    assert solid.status() == m3.Error.NoError
    assert solid.volume() == pytest.approx(field_volume(prog, 160), rel=0.01)


@settings(max_examples=12, deadline=None)
@given(tree=trees(max_leaves=4))
def test_random_trees_mesh_into_valid_manifolds(tree):
    mesh = bt.polygonize(tree, resolution=32)
    if len(mesh.faces) == 0:
        return
    solid = manifold(mesh)
    assert solid.status() == m3.Error.NoError
    # manifold3d's volume and ours (by pieces, bubbles negative) agree
    assert solid.volume() == pytest.approx(mesh.piece_volumes().sum(), rel=1e-4, abs=1e-9)


def test_small_pieces_are_dropped_only_when_asked_and_counted():
    tree = bt.union(ball(2.0), ball(0.6).translate(5.0, 0.0, 0.0))
    mesh = bt.polygonize(tree, resolution=96)
    volumes = np.sort(np.abs(mesh.piece_volumes()))
    assert len(volumes) == 2
    assert volumes[0] == pytest.approx(4 / 3 * math.pi * 0.3**3, rel=0.08)
    kept, dropped = mesh.without_small_pieces(0.5)
    assert dropped == 1 and kept.component_count() == 1 and kept.is_watertight
    assert manifold(kept).volume() == pytest.approx(volumes[1], rel=1e-6)
    same, none = mesh.without_small_pieces(1e-9)
    assert none == 0 and len(same.faces) == len(mesh.faces)
    with pytest.raises(ValueError, match="min_volume"):
        mesh.without_small_pieces(-1.0)


def _hollow(cavity: float = 0.4) -> bt.Node:
    """A ball 4 across with a cavity ``cavity`` / 2 in radius sealed inside, and a ball 0.4
    across beside it."""
    return bt.union(bt.difference(ball(4.0), ball(cavity)), ball(0.8).translate(4.0, 0.0, 0.0))


def test_bubbles_alone_can_be_dropped():
    mesh = bt.polygonize(_hollow(0.8), resolution=96)
    volumes = np.sort(mesh.piece_volumes())
    assert len(volumes) == 3 and mesh.solids_and_bubbles() == (2, 1)
    assert volumes[0] == pytest.approx(-4 / 3 * math.pi * 0.4**3, rel=0.05)  # the cavity
    kept, dropped = mesh.without_small_pieces(1.0, bubbles_only=True)  # the small ball stays
    assert dropped == 1 and kept.solids_and_bubbles() == (2, 0) and kept.is_watertight
    assert manifold(kept).volume() == pytest.approx(volumes[1:].sum(), rel=1e-6)


def test_print_files_drop_bubbles_a_nozzle_cannot_print_unless_kept(tmp_path):
    """At 4 mm tall the cavity is 0.4 mm across (0.034 mm^3, under a 0.4 mm cube): dropped from
    a 3MF by default, kept with --keep-bubbles and in formats that are not print files."""
    import trimesh

    scene = tmp_path / "hollow.json"
    bt.save(_hollow(), scene)

    def mesh(out, *extra):
        r = CliRunner().invoke(main, ["mesh", str(scene), "-o", str(tmp_path / out), "-r", "96",
                                      "--height", "4mm", *extra])
        assert r.exit_code == 0, r.output
        return r.output, trimesh.load(tmp_path / out, force="mesh", process=False)

    said, printed = mesh("p.3mf")
    assert "dropped 1 bubble under 0.064 mm^3" in said and "solids: 2," in said
    assert len(printed.split(only_watertight=False)) == 2
    for out, extra in (("k.3mf", ["--keep-bubbles"]), ("k.ply", [])):
        said, kept = mesh(out, *extra)
        assert "dropped" not in said and "solids: 2 (and 1 bubble sealed inside)" in said
        assert len(kept.split(only_watertight=False)) == 3
    said, _ = mesh("big.3mf", "--height", "40mm")  # 4 mm across: a printer keeps it as a void
    assert "dropped" not in said and "1 bubble sealed inside" in said


def _scene(tmp_path):
    tree = bt.union(bt.Cone((0, -1, 0), (0, 2, 0), radius_a=1.0, radius_b=0.6),
                    ball(0.5).translate(3.0, 0.0, 0.0))
    path = tmp_path / "s.json"
    bt.save(tree, path)
    return path


def test_3mf_at_a_real_height_in_millimetres(tmp_path):
    scene, out = _scene(tmp_path), tmp_path / "shell.3mf"
    r = CliRunner().invoke(main, ["mesh", str(scene), "-o", str(out), "-r", "64",
                                  "--height", "8cm", "--min-piece", "2000"])
    assert r.exit_code == 0, r.output
    assert "80 mm tall" in r.output and "dropped 1 piece" in r.output and "solids: 1" in r.output
    with zipfile.ZipFile(out) as z:
        model = z.read("3D/3dmodel.model").decode()
    assert 'unit="millimeter"' in model
    import trimesh

    loaded = trimesh.load(out, force="mesh")
    assert loaded.extents[2] == pytest.approx(80.0, abs=1e-3)  # up (+y here) along +Z
    assert loaded.bounds[0][2] == pytest.approx(0.0, abs=1e-4)  # on the plate
    assert np.allclose(loaded.bounds.mean(axis=0)[:2], 0.0, atol=1e-4)  # centred
    assert loaded.is_watertight


def test_stl_keeps_working_and_height_scales_it(tmp_path):
    import trimesh

    scene, out = _scene(tmp_path), tmp_path / "shell.stl"
    r = CliRunner().invoke(main, ["mesh", str(scene), "-o", str(out), "-r", "48",
                                  "--height", "1.5in"])
    assert r.exit_code == 0, r.output
    assert "solids: 2" in r.output  # nothing dropped unless asked
    assert trimesh.load(out, force="mesh").extents[2] == pytest.approx(38.1, abs=1e-3)


@pytest.mark.parametrize("height", ["tall", "0mm", "-3cm", "5km", "1e9mm"])
def test_bad_heights_are_refused_by_name(tmp_path, height):
    r = CliRunner().invoke(main, ["mesh", str(_scene(tmp_path)), "-o",
                                  str(tmp_path / "x.stl"), "--height", height])
    assert r.exit_code == 2 and "--height" in r.output and "such as 80mm" in r.output


# --- which way up ------------------------------------------------------------------------------

def _marked():
    """A ball 3 across at y = -1 and one 1 across at y = +2, joined by a rod along y: which end
    is up shows by the width at the top."""
    rod = bt.Cylinder((0, -1, 0), (0, 2, 0), cylinder_radius=0.2, radius=0.4)
    return bt.union(ball(3.0).translate(0.0, -1.0, 0.0), ball(1.0).translate(0.0, 2.0, 0.0), rod)


def _width_near(vertices: np.ndarray, top: bool) -> float:
    """The width along x of the tenth of the height at the top (or the bottom)."""
    z = vertices[:, 2]
    near = z > z.max() - 0.1 * np.ptp(z) if top else z < z.min() + 0.1 * np.ptp(z)
    return float(np.ptp(vertices[near, 0]))


@pytest.mark.parametrize("up", [(0, 1, 0), (0, -1, 0), (0, 0, -1), (1, 0, 0), (0.3, -0.5, 0.8)])
def test_standing_puts_up_along_z_on_the_plate_centred(up):
    mesh = bt.polygonize(_marked(), resolution=48)
    stood = mesh.standing(up)
    u = np.asarray(up, float) / np.linalg.norm(up)
    # heights above the plate are the distances along up from the lowest point
    along = mesh.vertices @ u
    assert np.allclose(stood.vertices[:, 2], along - along.min(), atol=1e-9)
    lo, hi = stood.vertices.min(axis=0), stood.vertices.max(axis=0)
    assert lo[2] == pytest.approx(0.0, abs=1e-12) and np.allclose((lo + hi)[:2], 0.0, atol=1e-9)
    # a rigid motion: distances, volume and outward normals kept
    i, j = 0, len(mesh.vertices) - 1
    assert np.linalg.norm(stood.vertices[i] - stood.vertices[j]) == pytest.approx(
        np.linalg.norm(mesh.vertices[i] - mesh.vertices[j]))
    assert stood.piece_volumes().sum() == pytest.approx(mesh.piece_volumes().sum())
    assert np.allclose(stood.normals @ [0, 0, 1], mesh.normals @ u, atol=1e-9)
    assert stood.is_watertight


def test_the_default_up_stands_the_small_end_on_top_and_up_turns_it_over(tmp_path):
    import trimesh

    path = tmp_path / "marked.json"
    bt.save(_marked(), path)
    for up, small_on_top in ((None, True), ("0,-1,0", False)):
        out = tmp_path / "m.3mf"
        args = ["mesh", str(path), "-o", str(out), "-r", "48", "--height", "60mm"]
        r = CliRunner().invoke(main, args + ([] if up is None else ["--up", up]))
        assert r.exit_code == 0, r.output
        loaded = trimesh.load(out, force="mesh")
        assert loaded.extents[2] == pytest.approx(60.0, abs=1e-3)
        top, bottom = (_width_near(loaded.vertices, end) for end in (True, False))
        assert (top < bottom) == small_on_top


def test_a_shell_stands_apex_up():
    """The shells are shown apex up (``Node.shown``, the specs' ``up``): the apex, the model's
    lowest point along y (Eq. 8 grows the shell toward +y), is the top of the print."""
    for name in bt.models.SHELLS:
        tree = bt.models.shell(name, textured=False)
        mesh = bt.polygonize(tree, resolution=48)
        stood = mesh.standing(tree.display[0])
        apex = np.argmin(mesh.vertices[:, 1])
        assert stood.vertices[apex, 2] == pytest.approx(stood.vertices[:, 2].max())


def test_each_format_has_its_frame(tmp_path):
    """3MF, and STL with --height, stand on the plate (+Z up); GLB has the up along +Y (glTF);
    PLY, OBJ and STL without --height keep the model's frame."""
    import trimesh

    path = tmp_path / "marked.json"
    bt.save(_marked(), path)
    own = bt.polygonize(_marked(), resolution=32)
    lo, hi = own.vertices.min(axis=0), own.vertices.max(axis=0)
    for ext, extra, expected_lo in (
            ("ply", [], lo), ("obj", [], lo), ("stl", [], lo),
            ("stl", ["--height", "50mm"], None), ("glb", ["--up", "0,0,1"], None)):
        out = tmp_path / f"m.{ext}"
        r = CliRunner().invoke(main, ["mesh", str(path), "-o", str(out), "-r", "32", *extra])
        assert r.exit_code == 0, r.output
        got = trimesh.load(out, force="mesh", process=False)
        if expected_lo is not None:
            assert np.allclose(got.bounds, [lo, hi], atol=1e-5)
        elif ext == "stl":
            assert got.bounds[0][2] == pytest.approx(0.0, abs=1e-4)
            assert got.extents[2] == pytest.approx(50.0, abs=1e-3)
        else:  # the model's z, its up here, along glTF's +Y
            assert got.extents[1] == pytest.approx(hi[2] - lo[2], abs=1e-5)
    bad = CliRunner().invoke(main, ["mesh", str(path), "-o", str(tmp_path / "x.3mf"),
                                    "--up", "0,0,0"])
    assert bad.exit_code == 2 and "--up" in bad.output and "non-zero direction" in bad.output


# --- thin parts ----------------------------------------------------------------------------------

def test_a_rod_is_measured_as_a_spine_of_its_diameter():
    """A cylinder skeleton of radius 0.3 with field radius 0.2 has the visible radius
    0.3 + 0.1 (Wyvill's surface at R / 2): every point of its side is a rod 0.8 across."""
    from blobtree.mesh.thickness import measure
    rod = bt.Cylinder((0, 0, 0), (4, 0, 0), cylinder_radius=0.3, radius=0.2)
    mesh = bt.polygonize(rod, resolution=48)
    side = mesh.vertices[np.abs(mesh.vertices[:, 0] - 2.0) < 1.0]
    th = measure(rod.program(), side, step=0.02, depth=3.0)
    assert th.rods.all()
    assert np.allclose(th.across, 0.8, atol=0.01)
    assert th.thinnest(th.sheets) is None


def test_a_hollow_ball_is_measured_as_a_wall_of_its_thickness():
    """Point(4) - Point(3): a spherical wall from radius 1.5 to 2, 0.5 thick everywhere."""
    from blobtree.mesh.thickness import measure
    hollow = bt.difference(bt.Point(radius=4.0), bt.Point(radius=3.0))
    mesh = bt.polygonize(hollow, resolution=48)
    th = measure(hollow.program(), mesh.vertices, step=0.02, depth=3.0)
    assert th.sheets.all()
    assert np.allclose(th.across, 0.5, atol=0.01)
    t, where = th.thinnest(th.sheets)
    assert t == pytest.approx(0.5, abs=0.01) and np.linalg.norm(where) > 1.4


def test_info_reports_thin_parts_at_a_print_height(tmp_path):
    """A rod 0.8 across and 4.2 long (flat ends 0.1 past the skeleton, R / 2), printed 48 mm
    tall along +y: 0.8 * 48 / 4.2 = 9.14 mm across."""
    rod = bt.Cylinder((0, 0, 0), (0, 4, 0), cylinder_radius=0.3, radius=0.2)
    path = tmp_path / "rod.json"
    bt.save(rod, path)
    r = CliRunner().invoke(main, ["info", str(path), "--height", "48mm", "--resolution", "48"])
    assert r.exit_code == 0, r.output
    line = next(x for x in r.output.splitlines() if "thinnest spine" in x)
    assert float(line.split(":")[1].split("mm")[0]) == pytest.approx(0.8 * 48 / 4.2, rel=0.02)
    assert "thinnest wall (sheet): none found" in r.output
    bad = CliRunner().invoke(main, ["info", str(path), "--height", "-3mm"])
    assert bad.exit_code == 2 and "--height" in bad.output
