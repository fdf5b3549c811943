"""Texture mapping: the field-interpolated and the bounding-surface methods (Section 3.4)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import blobtree as bt
from blobtree.texture.mapping import HelicoSurface, load_image, sample


def uv_ramp(u, v):
    return np.stack([u, v, np.zeros_like(u)], axis=-1)


def flat(rgb):
    return np.broadcast_to(np.array(rgb, dtype=float), (4, 4, 3)).copy()


def test_textured_blend_is_field_weighted_mean():
    a = bt.Point(radius=2.0).texture(flat((1, 0, 0)))
    b = bt.Point(radius=2.0, center=(1.2, 0, 0)).texture(flat((0, 0, 1)))
    P = np.array([[0.4, 0.1, 0.0], [0.7, -0.2, 0.1], [0.9, 0.0, 0.3]])
    fa, fb = a.field(P), b.field(P)
    c = (a + b).albedo(P)
    np.testing.assert_allclose(c[:, 0], fa / (fa + fb), atol=1e-12)
    np.testing.assert_allclose(c[:, 2], fb / (fa + fb), atol=1e-12)


def test_csg_takes_the_winning_childs_texture():
    a = bt.Point(radius=2.0).texture(flat((1, 0, 0)))
    b = bt.Point(radius=2.0, center=(1.0, 0, 0)).texture(flat((0, 1, 0)))
    P = np.random.default_rng(0).uniform(-0.5, 1.5, (500, 3))
    fa, fb = a.field(P), b.field(P)
    live = np.maximum(fa, fb) > 0
    c = (a | b).albedo(P)
    np.testing.assert_allclose(c[live], np.where((fa >= fb)[:, None], [1, 0, 0], [0, 1, 0])[live])
    d = (a - b).albedo(P)
    fd = np.minimum(fa, 1 - fb)
    np.testing.assert_allclose(d[fd > 0], np.where((fa <= 1 - fb)[:, None], [1, 0, 0],
                                                   [0, 1, 0])[fd > 0])


@pytest.mark.parametrize("theta, phi", [(40.0, 30.0), (100.0, 200.0), (150.0, 300.0)])
def test_point_texture_lands_at_spherical_uv(theta, phi):
    """u = longitude about +y (right-hand), v = colatitude / pi."""
    p = bt.Point(radius=2.0, center=(1, 2, 3)).texture(uv_ramp, wrap="clamp")
    t, f = math.radians(theta), math.radians(phi)
    d = np.array([math.sin(t) * math.cos(f), math.cos(t), -math.sin(t) * math.sin(f)])
    c = p.albedo((np.array([1, 2, 3]) + 0.7 * d)[None])[0]
    assert c[0] == pytest.approx(phi / 360.0, abs=2e-3)
    assert c[1] == pytest.approx(theta / 180.0, abs=2e-3)


def test_cone_texture_v_runs_along_the_axis():
    cone = bt.Cone((0, 0, 0), (2, 0, 0), radius_a=0.8, radius_b=0.4).texture(uv_ramp,
                                                                             wrap="clamp")
    for t in (0.1, 0.5, 0.9):
        c = cone.albedo(np.array([[2 * t, 0.1, 0.05]]))[0]
        assert c[1] == pytest.approx(t, abs=2e-3)


def test_torus_texture_angles():
    tor = bt.Torus(major_radius=2.0, radius=1.0).texture(uv_ramp, wrap="clamp")
    # ring angle 90 degrees (towards -z), tube angle 45 degrees (outward and up)
    q = np.array([[0.0, 0.2, -(2.0 + 0.2)]])
    c = tor.albedo(q)[0]
    assert c[0] == pytest.approx(0.25, abs=2e-3)
    assert c[1] == pytest.approx(0.125, abs=2e-3)


def test_no_seam_where_the_angle_wraps():
    stripes = lambda u, v: np.stack([0.5 + 0.5 * np.cos(2 * np.pi * 3 * u)] * 3, axis=-1)  # noqa: E731
    p = bt.Point(radius=2.0).texture(stripes)
    eps = 1e-4  # either side of u = 0 (the +x direction, z = 0)
    q = np.array([[0.7, 0.0, eps], [0.7, 0.0, -eps]])
    c = p.albedo(q)
    assert np.abs(c[0] - c[1]).max() < 1e-3


def test_bounding_surface_uv_on_the_surface_itself():
    # consecutive whorls' generating circles touch at radius D (Eq. 3): below that every point
    # of S is nearest to its own whorl, so S is exactly the swept tube
    s = HelicoSurface(gradient_weight=0.5, radius_factor=0.9)
    sp = s.spiral
    rng = np.random.default_rng(0)
    theta = rng.uniform(0, 2000, 50)
    vv = rng.uniform(0, 1, 50)
    pts = []
    for t, v in zip(theta, vv, strict=True):
        cx, cy, cz = sp.centre(t)
        radial = np.array([cx, 0, cz]) / np.hypot(cx, cz)
        r = s.radius_factor * sp.size(t) * 1.000001
        pts.append(np.array([cx, cy, cz]) + r * (math.cos(2 * math.pi * v) * radial
                                                 + math.sin(2 * math.pi * v) * np.array([0, 1, 0])))
    u, v = s.uv(np.array(pts), rng.normal(size=(50, 3)))
    np.testing.assert_allclose(u, theta / s.u_period, atol=1e-9)
    np.testing.assert_allclose(v, vv, atol=1e-9)


def test_bounding_surface_texture_engine_equals_reference():
    w = bt.models.whorl126()
    t = w.texture(uv_ramp, mapping=HelicoSurface()).rotate("y", 30).translate(0.1, 0, 0)
    P = np.random.default_rng(1).uniform(*t.bounds(), (3000, 3))
    f, _, c = t.program().evaluate(P)
    fr, _, cr = t.reference(P)
    live = fr > 0
    assert live.sum() > 300
    np.testing.assert_allclose(c[live], cr[live], atol=1e-9)


def test_bounding_surface_u_follows_the_spiral():
    """Along the whorl, u grows with theta: the texture is laid along the helico-spiral."""
    s = HelicoSurface(u_period=116.0)
    w = bt.models.whorl126().texture(uv_ramp, mapping=s, wrap="repeat")
    sp = s.spiral
    thetas = np.array([130.0, 160.0, 190.0])
    pts = np.array([sp.centre(t) for t in thetas])
    outward = pts * np.array([1, 0, 1]) / np.hypot(pts[:, 0], pts[:, 2])[:, None]
    surf = pts + 0.9 * np.array([sp.size(t) for t in thetas])[:, None] * outward
    c = w.albedo(surf)
    expected = np.mod(thetas / 116.0, 1.0)
    np.testing.assert_allclose(c[:, 0], expected, atol=0.03)


def test_images_and_errors(tmp_path):
    from PIL import Image

    img = np.zeros((2, 3, 3), dtype=np.uint8)
    img[0, 0] = (255, 0, 0)
    path = tmp_path / "t.png"
    Image.fromarray(img).save(path)
    np.testing.assert_array_equal(load_image(path), img)
    np.testing.assert_allclose(sample(img, np.array([1 / 6]), np.array([0.25]), "clamp"),
                               [[1.0, 0, 0]])
    with pytest.raises(ValueError, match="cannot read"):
        load_image(tmp_path / "missing.png")
    with pytest.raises(ValueError, match="lie in"):
        load_image(np.full((2, 2, 3), 2.0))
    with pytest.raises(ValueError, match="mapping"):
        bt.Point().texture(img, mapping="cylindrical")
    with pytest.raises(ValueError, match="wrap"):
        bt.Point().texture(img, wrap="mirror")


def test_texture_colours_flow_to_mesh_vertices():
    tree = bt.Point(radius=2.0).texture(uv_ramp) + bt.Cone((0, 0, 0), (2, 0, 0), 0.8, 0.4)
    mesh = bt.polygonize(tree, resolution=24, progress=False)
    # colours are taken just before the last Newton step moves each vertex a hair
    np.testing.assert_allclose(mesh.colors, tree.albedo(mesh.vertices), atol=0.01)
    assert mesh.colors[:, 0].std() > 0.1  # the ramp shows, not one flat colour


def test_bounding_surface_colour_where_the_field_is_flat():
    """Inside a cylinder's core the field is flat (f = 1) and its gradient rounding noise of
    either sign: the search takes no direction from it, in the engine as in the reference
    (a regression: the two followed opposite noise and painted different texels)."""
    from blobtree.engine import GRID_MIN_POINTS
    from blobtree.helico import HelicoSpiral
    from blobtree.texture.mapping import HelicoSurface
    from tests.trees import sample_points

    img = np.random.default_rng(1).random((16, 16, 3))
    mapping = HelicoSurface(spiral=HelicoSpiral(beta=22.5, rho=1.3, r0=0.3), u_period=116.0,
                            theta_max=720.0, step=0.05, max_steps=8)
    tree = bt.Cylinder(a=(0.0, 0.0, 0.0), b=(0.0, 1.0, 0.5), cylinder_radius=0.5,
                       radius=0.5).texture(img, mapping=mapping)
    for seed in (0, 5):  # each had one point on the flat core painted differently
        P = sample_points(tree, GRID_MIN_POINTS + 5000, seed)
        _, _, c = tree.program().evaluate(P)
        fr, _, cr = tree.reference(P)
        live = fr > 1e-9
        assert (fr[live] == 1.0).sum() > 100  # the flat core is sampled
        np.testing.assert_allclose(c[live], cr[live], rtol=1e-9, atol=1e-9)


def test_an_image_is_kept_contiguous_and_keyed_by_its_pixels():
    """A read-only image given in another memory order is kept C-ordered (its digest would copy
    it at every key otherwise); the digest kept for a read-only image is its pixels' digest, the
    same as a writable copy's, and another image gets its own."""
    from blobtree.texture.mapping import image_digest

    rng = np.random.default_rng(5)
    pixels = rng.integers(0, 256, (6, 4, 3), dtype=np.uint8)
    across = np.asfortranarray(pixels)
    across.setflags(write=False)
    node = bt.Point().texture(across)
    assert node.image.flags.c_contiguous and np.array_equal(node.image, pixels)
    kept = node.image
    assert image_digest(kept) == image_digest(kept) == image_digest(pixels.copy())
    other = pixels.copy()
    other[0, 0, 0] ^= 1
    other.setflags(write=False)
    assert image_digest(other) != image_digest(kept)
    assert bt.Point().texture(kept).key == node.key
