"""The polygonizer: closed oriented manifolds, accuracy, culling, limits, export."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh
from click.testing import CliRunner
from hypothesis import given
from hypothesis import strategies as st

import blobtree as bt
from blobtree.cli.main import main
from blobtree.mesh import Mesh, polygonize
from blobtree.mesh._kernels import block_triangles
from blobtree.mesh.export import ENCODERS
from tests.conftest import examples
from tests.trees import trees


def vertex_manifold(m: Mesh) -> bool:
    """Every vertex's faces form one fan: the link edges make a single cycle."""
    links: dict[int, list[tuple[int, int]]] = {}
    for a, b, c in m.faces.tolist():
        links.setdefault(a, []).append((b, c))
        links.setdefault(b, []).append((c, a))
        links.setdefault(c, []).append((a, b))
    for edges in links.values():
        nxt = dict(edges)
        if len(nxt) != len(edges):
            return False
        start = edges[0][0]
        v, steps = nxt[start], 1
        while v != start and v in nxt and steps <= len(edges):
            v, steps = nxt[v], steps + 1
        if v != start or steps != len(edges):
            return False
    return True


def components(m: Mesh) -> int:
    return m.component_count()


def assert_closed_manifold(m: Mesh) -> None:
    assert len(m.faces) > 0
    assert m.is_watertight
    assert len(np.unique(m.vertices, axis=0)) == len(m.vertices)  # each vertex once
    assert vertex_manifold(m)
    assert m.to_trimesh().volume > 0  # outward winding


def assert_spheres(m: Mesh, count: int) -> None:
    assert_closed_manifold(m)
    assert components(m) == count
    assert m.euler_characteristic == 2 * count


# --- the kernel on arbitrary lattice values ---------------------------------------------------


@examples(0.7)
@given(st.integers(0, 2**32 - 1), st.booleans())
def test_kernel_is_watertight_on_noise(seed, quantized):
    """Random samples (every ambiguous face and cell case; exact iso values when quantized) on
    two blocks side by side: the vertices on their common face are welded."""
    rng = np.random.default_rng(seed)
    m = 8
    v = rng.random((2 * m - 1, m, m))
    if quantized:
        v = np.round(v * 4) / 4  # many samples exactly 0.5
    for axis in (0, 1, 2):  # outside on the lattice border, so the surface closes
        idx = [slice(None)] * 3
        idx[axis] = [0, v.shape[axis] - 1]
        v[tuple(idx)] = 0.0
    blocks = np.stack([v[:m], v[m - 1:]])
    cells = np.stack(np.meshgrid(*[np.arange(m - 1)] * 3, indexing="ij"), -1).reshape(-1, 3)
    keys, _, _, centres, tris, vertex_start = block_triangles(
        blocks, np.array([[0, 0, 0], [m - 1, 0, 0]]), np.array([0, len(cells), 2 * len(cells)]),
        np.concatenate([cells, cells]), 1, np.array(v.shape), 0.5)  # boxes of one cell
    assert len(np.unique(keys)) == len(keys)
    # the vertices block by block, those on the face between the blocks with the first
    assert vertex_start[0] == 0 and vertex_start[-1] == len(keys)
    x, axis = keys // 3 // (v.shape[1] * v.shape[2]), keys % 3
    own = np.repeat([0, 1], np.diff(vertex_start))
    assert np.all(np.where(own == 0, (x < m - 1) | ((x == m - 1) & (axis != 0)),
                           (x > m - 1) | ((x == m - 1) & (axis == 0))))
    assert np.count_nonzero(own == 0) > 10 and np.count_nonzero(own == 1) > 10
    assert tris.min() >= 0 and tris.max() < len(keys) + len(centres)
    z = np.zeros((len(keys) + len(centres), 3))
    mesh = Mesh(z, tris, z, z)
    assert mesh.is_watertight
    assert vertex_manifold(mesh)


# --- scenes ----------------------------------------------------------------------------------


def test_lone_point_matches_the_sphere_of_radius_r_over_2():
    m = polygonize(bt.Point(radius=2.0, center=(0.3, -0.2, 0.1)), resolution=64)
    assert_spheres(m, 1)
    tm = m.to_trimesh()
    assert tm.volume == pytest.approx(4.0 / 3.0 * math.pi, rel=5e-3)
    assert tm.area == pytest.approx(4.0 * math.pi, rel=5e-3)
    r = np.linalg.norm(m.vertices - (0.3, -0.2, 0.1), axis=1)
    assert np.abs(r - 1.0).max() < 1e-4


def test_vertices_lie_on_the_iso_surface():
    tree = bt.Point(radius=1.0) + bt.Segment((0.3, 0, 0), (1.2, 0.4, 0), radius=0.6)
    m = polygonize(tree, resolution=40)
    err = np.abs(tree.program().field(m.vertices) - 0.5)
    # linear interpolation alone leaves errors near 1e-2 here
    assert err.max() < 5e-4
    assert np.percentile(err, 99) < 1e-6


def test_normals_point_out_and_agree_with_faces():
    tree = (bt.Point(radius=1.0) + bt.Point(radius=0.8, center=(0.7, 0.2, 0))).color((1, 0, 0))
    m = polygonize(tree, resolution=32)
    fn = m.to_trimesh().face_normals
    vn = m.normals[m.faces].sum(axis=1)
    assert np.mean(np.einsum("ij,ij->i", fn, vn) > 0) > 0.999
    assert np.allclose(np.linalg.norm(m.normals, axis=1), 1.0)
    assert np.allclose(m.colors, (1, 0, 0))


def test_normal_where_the_gradient_vanishes_is_the_faces_normal():
    """A vertex with no gradient takes the area-weighted normal of its faces (here the corner
    of a tetrahedron at the origin, whose three faces point along -x, -y and -z)."""
    from blobtree.mesh.polygonizer import _normals

    verts = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    tris = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    grad = np.array([[0.0, 0, 0], [-2, 0, 0], [0, -3, 0], [0, 0, -4]])
    n = _normals(grad, verts, tris)
    np.testing.assert_allclose(n[0], -np.ones(3) / np.sqrt(3))
    np.testing.assert_allclose(n[1:], np.eye(3))


def test_whorl126_is_closed_and_manifold():
    m = polygonize(bt.models.whorl126(), resolution=48)
    assert_closed_manifold(m)
    assert components(m) == 1


def _tetrahedra_sharing_an_edge() -> Mesh:
    """Two closed tetrahedra (outward faces) with the edge 0-1 in common: four faces at that
    edge.  The second is the first turned half a turn about z (vertices 2, 3 -> 4, 5), which
    keeps its faces' winding outward."""
    v = np.array([[0, 0, 0], [0, 0, 1], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]], float)
    tet = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    faces = np.concatenate([tet, np.where(tet == 2, 4, np.where(tet == 3, 5, tet))])
    return Mesh(v, faces, v, v)


def test_is_watertight_refuses_holes_flips_and_extra_faces():
    """Mesh.is_watertight against trimesh's checks (edges shared by two faces, consistent
    winding) on a closed mesh, two disjoint copies, and the same with one face removed, flipped
    or repeated, and on two tetrahedra sharing an edge."""
    m = polygonize(bt.Point(radius=1.0), resolution=12)
    v, f = m.vertices, m.faces
    two = Mesh(np.concatenate([v, v + 5.0]), np.concatenate([f, f + len(v)]),
               np.concatenate([m.normals] * 2), np.concatenate([m.colors] * 2))
    cases = {"closed": (m, True), "two copies": (two, True),
             "hole": (Mesh(v, f[1:], m.normals, m.colors), False),
             "flipped": (Mesh(v, np.concatenate([f[:1, ::-1], f[1:]]), m.normals, m.colors),
                         False),
             "repeated": (Mesh(v, np.concatenate([f, f[:1]]), m.normals, m.colors), False),
             "doubled": (Mesh(v, np.concatenate([f, f]), m.normals, m.colors), False),
             "edge of four faces": (_tetrahedra_sharing_an_edge(), False)}
    for name, (mesh, expected) in cases.items():
        tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
        assert mesh.is_watertight == expected, name
        assert (tm.is_watertight and tm.is_winding_consistent) == expected, name


def test_sampling_in_chunks_gives_the_same_mesh(monkeypatch):
    """The lattice is sampled SAMPLE_CHUNK points at a time (bounded scratch memory): tiny
    chunks give exactly the mesh of one chunk."""
    from blobtree.mesh import polygonizer

    tree = bt.Point(radius=2.0) - bt.Point(radius=1.6, center=(0.9, 0.3, 0))
    whole = polygonize(tree, resolution=40)
    monkeypatch.setattr(polygonizer, "SAMPLE_CHUNK", 100)
    chunked = polygonize(tree, resolution=40)
    np.testing.assert_array_equal(chunked.vertices, whole.vertices)
    np.testing.assert_array_equal(chunked.faces, whole.faces)


def test_difference_with_creases():
    tree = bt.Point(radius=2.0) - bt.Point(radius=1.6, center=(0.9, 0.3, 0))
    assert_spheres(polygonize(tree, resolution=40), 1)
    tree = bt.Point(radius=2.0) & bt.Segment((-1, 0, 0), (1, 0, 0), radius=1.2)
    assert_spheres(polygonize(tree, resolution=40), 1)


def test_separate_components():
    tree = bt.Point(radius=1.0) + bt.Point(radius=0.6, center=(2, 0, 0)) | bt.Torus(
        major_radius=1.0, radius=0.4).translate(0, 3, 0)
    m = polygonize(tree, resolution=64)
    assert_closed_manifold(m)
    assert components(m) == 3
    assert m.euler_characteristic == 2 + 2 + 0  # two spheres and a torus


def test_warped_primitives():
    tree = bt.Segment((0, 0, 0), (2, 0, 0), radius=0.6).bend(60, 2.0, axis="x", toward="y")
    tree = tree + bt.Cone((0, 0, 0), (0, 2, 0), radius_a=0.8, radius_b=0.3).twist(45, axis="y")
    assert_spheres(polygonize(tree, resolution=48), 1)


@examples(0.17)
@given(st.tuples(*[st.floats(0.0, 1.0)] * 3))
def test_thin_spine_two_cells_wide_stays_one_piece(offset):
    """A skewed segment whose visible diameter is 2.2 cells, at any offset to the lattice."""
    h = 0.05
    a = np.array((-1.0, -0.8, -0.6)) + np.array(offset) * h
    spine = bt.Segment(a, a + (2.0, 1.7, 1.3), radius=2.0 * 1.1 * h)  # visible radius R / 2
    assert_spheres(polygonize(spine, cell_size=h), 1)


def test_bounds_cut_the_solid_and_cap_it():
    lo, hi = np.array([-1.2, -1.2, -1.2]), np.array([1.2, 1.2, 0.0])
    m = polygonize(bt.Point(radius=2.0), resolution=48, bounds=(lo, hi))
    assert_spheres(m, 1)
    assert m.vertices[:, 2].max() <= 1e-12
    assert m.to_trimesh().volume == pytest.approx(2.0 / 3.0 * math.pi, rel=1e-2)


def test_cell_size_form_equals_resolution_form():
    tree = bt.Point(radius=1.0)
    lo, hi = tree.program().bounds
    a = polygonize(tree, resolution=20)
    b = polygonize(tree, cell_size=float(np.max(hi - lo)) / 20)
    assert np.array_equal(a.faces, b.faces) and np.allclose(a.vertices, b.vertices)


def test_empty_solid_gives_an_empty_mesh():
    far_apart = bt.Point(radius=1.0) & bt.Point(radius=1.0, center=(5, 0, 0))
    assert len(polygonize(far_apart, resolution=16).faces) == 0
    touching = bt.Point(radius=1.0) & bt.Point(radius=1.0, center=(1.9, 0, 0))  # f < 0.5
    m = polygonize(touching, resolution=16)
    assert len(m.faces) == 0 and len(m.vertices) == 0


@examples(0.25)
@given(trees(max_leaves=5))
def test_random_trees_mesh_closed(tree):
    m = polygonize(tree, resolution=24)
    if len(m.faces):
        assert m.is_watertight
        assert vertex_manifold(m)


# --- cost follows the surface ----------------------------------------------------------------


class CountingProgram:
    """A program that counts the points evaluated."""

    def __init__(self, prog):
        self.prog, self.bounds, self.points = prog, prog.bounds, []

    def field(self, P):
        self.points.append(np.array(P))
        return self.prog.field(P)

    def evaluate(self, P):
        self.points.append(np.array(P))
        return self.prog.evaluate(P)

    def bound_at(self, lo, hi, at):
        self.points.append(np.array(at))
        return self.prog.bound_at(lo, hi, at)


def test_samples_follow_the_surface():
    prog = bt.Point(radius=2.0).program()
    counts = {}
    for n in (64, 128):
        counting = CountingProgram(prog)
        polygonize(counting, resolution=n)
        pts = np.concatenate(counting.points)
        counts[n] = len(pts)
        r = np.linalg.norm(pts, axis=1)
        # far from the surface (at r = 1) only the centres of the culled octree boxes
        assert np.mean(np.abs(r - 1.0) > 0.5) < 0.05
    assert counts[128] < 0.1 * 129**3  # of the dense lattice
    assert counts[128] / counts[64] < 5.0  # about 4x per doubling, not 8x


# --- limits and errors -----------------------------------------------------------------------


def test_refuses_a_resolution_that_does_not_fit():
    with pytest.raises(ValueError, match="resolution too large.*GiB"):
        polygonize(bt.Point(radius=1.0), resolution=10**6)
    with pytest.raises(ValueError, match="resolution too large"):
        polygonize(bt.Point(radius=1.0), resolution=200, max_memory=10**6)


@pytest.mark.parametrize("model, resolution", [("whorl126", 96), ("murex", 96)])
def test_the_memory_check_estimates_the_triangles_closely(model, resolution, monkeypatch):
    """The finest culling level's sampled estimate (what the memory budget is checked against)
    is within 10% of the triangles made, where the count of culled boxes alone is 1 to 4 times
    off (the Murex's loose Lipschitz bound keeps many boxes the surface does not cross)."""
    from blobtree.mesh import polygonizer as P

    seen = []
    monkeypatch.setattr(P, "MAX_TRIANGLES_PER_BOX", 10**12)  # always sample, however small
    check = P._check_budget
    monkeypatch.setattr(P, "_check_budget", lambda tri, boxes, *a, **k: (
        seen.append((tri, boxes)), check(tri, boxes, *a, **k))[1])
    mesh = polygonize(getattr(bt.models, model)(), resolution)
    estimate, boxes = seen[-1]
    assert boxes > 0 and abs(estimate / len(mesh.faces) - 1.0) < 0.1


def test_a_budget_the_mesh_fits_in_is_accepted():
    tree = bt.models.whorl126()
    need = len(polygonize(tree, 64).faces) * 160 + 20_000 * 90
    assert len(polygonize(tree, 64, max_memory=2 * need).faces) > 0
    with pytest.raises(ValueError, match="resolution too large"):
        polygonize(tree, 64, max_memory=need // 4)


@pytest.mark.parametrize(
    "kwargs, word",
    [
        ({"resolution": 1}, "resolution"),
        ({"resolution": 10.5}, "resolution"),
        ({"cell_size": -1.0}, "cell_size"),
        ({"cell_size": float("nan")}, "cell_size"),
        ({"resolution": 10, "cell_size": 0.1}, "either"),
        ({"bounds": ((0, 0, 0), (1, 1))}, "bounds"),
        ({"bounds": ((0, 0, 0), (1, -1, 1))}, "bounds"),
    ],
)
def test_bad_arguments(kwargs, word):
    with pytest.raises(ValueError, match=word):
        polygonize(bt.Point(radius=1.0), **kwargs)


# --- export ----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def small_mesh():
    tree = (bt.Point(radius=1.0).color((0.9, 0.2, 0.1))
            + bt.Point(radius=1.0, center=(0.8, 0, 0)).color((0.1, 0.3, 0.9)))
    return polygonize(tree, resolution=24)


def test_stl_records_follow_the_format(tmp_path):
    """Binary STL read back by the format's layout: 80-byte header, uint32 count, then per
    triangle 12 little-endian floats (unit normal, corners) and a zero uint16; a degenerate
    triangle's normal is zero."""
    v = np.array([[0, 0, 0], [2, 0, 0], [0, 3, 0], [1, 0, 0]], float)
    faces = np.array([[0, 1, 2], [0, 2, 1], [0, 1, 3]])  # the last has no area
    data = Mesh(v, faces, v, v).save(tmp_path / "t.stl").read_bytes()
    assert len(data) == 84 + 50 * 3 and int.from_bytes(data[80:84], "little") == 3
    rec = np.frombuffer(data[84:], dtype=[("f", "<f4", 12), ("a", "<u2")])
    assert np.array_equal(rec["f"][:, :3], [[0, 0, 1], [0, 0, -1], [0, 0, 0]])
    assert np.array_equal(rec["f"][:, 3:].reshape(3, 3, 3), v[faces])
    assert np.all(rec["a"] == 0)


@pytest.mark.parametrize("ext", [".ply", ".obj", ".stl", ".glb"])
def test_formats_round_trip(small_mesh, tmp_path, ext):
    path = small_mesh.save(tmp_path / f"m{ext}")
    loaded = trimesh.load(path, force="mesh", process=ext != ".stl")
    assert len(loaded.faces) == len(small_mesh.faces)
    if ext == ".stl":
        loaded.merge_vertices()
    assert loaded.is_watertight
    assert loaded.volume == pytest.approx(small_mesh.to_trimesh().volume, rel=1e-4)
    if ext == ".ply":
        rgb = loaded.visual.vertex_colors[:, :3] / 255.0
        assert rgb[:, 0].max() > 0.8 and rgb[:, 2].max() > 0.8
        # written here, not by trimesh: trimesh reads back every vertex, normal, colour and face
        assert np.array_equal(loaded.faces, small_mesh.faces)
        assert np.allclose(loaded.vertices, small_mesh.vertices, atol=1e-6)
        raw = loaded.metadata["_ply_raw"]["vertex"]["data"]  # (trimesh recomputes normals)
        normals = np.stack([raw["nx"], raw["ny"], raw["nz"]], axis=-1).reshape(-1, 3)
        assert np.allclose(normals, small_mesh.normals, atol=1e-6)
        assert np.array_equal(loaded.visual.vertex_colors[:, :3],
                              np.round(small_mesh.colors * 255))
    if ext == ".stl":  # each face's unit normal follows its winding (float32 corners: 1e-4)
        assert np.allclose(loaded.face_normals, small_mesh.to_trimesh().face_normals, atol=1e-4)
    assert list(tmp_path.iterdir()) == [path]


def test_save_is_atomic(small_mesh, tmp_path, monkeypatch):
    """An error or Ctrl-C while writing leaves the old file whole and no temporary behind."""
    import os

    path = tmp_path / "m.ply"
    path.write_bytes(b"old")

    def interrupted(src, dst):
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        small_mesh.save(path)
    monkeypatch.undo()

    def failing(*args, **kwargs):
        raise RuntimeError("exporter failed")

    # PLY is encoded here, OBJ by trimesh: a failure in either writes nothing
    monkeypatch.setitem(ENCODERS, "ply", failing)
    monkeypatch.setattr(trimesh.Trimesh, "export", failing)
    obj = tmp_path / "m.obj"
    obj.write_bytes(b"old")
    for target in (path, obj, tmp_path / "new.ply", tmp_path / "new.obj"):
        with pytest.raises(RuntimeError):
            small_mesh.save(target)
    assert path.read_bytes() == b"old" and obj.read_bytes() == b"old"
    assert sorted(tmp_path.iterdir()) == sorted([path, obj])


def test_save_rejects_unknown_extension(small_mesh, tmp_path):
    with pytest.raises(ValueError, match=r"extension '\.xyz' is not one of ply, obj, stl, glb"):
        small_mesh.save(tmp_path / "m.xyz")


# --- command line ----------------------------------------------------------------------------


def test_cli_mesh(tmp_path):
    scene = tmp_path / "s.json"
    bt.save(bt.Point(radius=1.0) + bt.Point(radius=1.0, center=(0.9, 0, 0)), scene)
    out = tmp_path / "out.ply"
    r = CliRunner().invoke(main, ["mesh", str(scene), "-o", str(out), "--resolution", "24"])
    assert r.exit_code == 0, r.output
    assert "triangles" in r.output and "watertight: yes" in r.output
    assert trimesh.load(out).is_watertight
    r = CliRunner().invoke(main, ["mesh", str(scene), "-o", str(out), "--resolution", "1000000"])
    assert r.exit_code != 0 and "resolution too large" in r.output
