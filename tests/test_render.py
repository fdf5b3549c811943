"""The direct ray tracer against analytic answers: spheres, silhouettes, thin spines, shadows."""

from __future__ import annotations

import importlib
import io
import math
import threading

import numpy as np
import pytest
from hypothesis import given
from PIL import Image

import blobtree as bt
from blobtree.render import (
    LOOKS,
    Camera,
    Light,
    RenderSettings,
    intersect,
    render,
    render_tile,
    save_image,
    tiles,
)
from blobtree.render.camera import default_camera
from blobtree.render.shade import SRGB_STEPS, default_lights, linear_to_srgb_byte, pack_lights
from tests.conftest import examples
from tests.trees import trees

BLACK = (0.0, 0.0, 0.0)


def covered(img: np.ndarray, background=(0, 0, 0)) -> np.ndarray:
    """Pixels that differ from the background."""
    return np.any(img != np.array(background, dtype=np.uint8), axis=2)


# ----- intersections ------------------------------------------------------------------------
def test_lone_point_is_a_sphere_of_half_its_radius():
    centre = np.array([0.3, -0.2, 0.1])
    tree = bt.Point(radius=2.0, center=tuple(centre))  # surface: radius 1
    rng = np.random.default_rng(0)
    origins = centre + rng.normal(size=(200, 3)) * 0.1 + np.array([0.0, 0.0, 5.0])
    targets = centre + rng.uniform(-0.6, 0.6, size=(200, 3))
    d = targets - origins
    t = intersect(tree, origins, d)
    # analytic: smallest root of |o + t d - c|^2 = 1
    oc = origins - centre
    a, b, c = (d * d).sum(1), 2 * (oc * d).sum(1), (oc * oc).sum(1) - 1.0
    expected = (-b - np.sqrt(b * b - 4 * a * c)) / (2 * a)
    np.testing.assert_allclose(t, expected, rtol=0, atol=1e-7)


def first_mesh_hit(mesh, o: np.ndarray, d: np.ndarray) -> float:
    """Smallest t > 0 where the ray o + t d meets a triangle of the mesh (Moller-Trumbore over
    all triangles), inf if none."""
    v0, v1, v2 = (mesh.vertices[mesh.faces[:, k]] for k in range(3))
    e1, e2 = v1 - v0, v2 - v0
    p = np.cross(d, e2)
    det = (e1 * p).sum(1)
    ok = np.abs(det) > 1e-14
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = o - v0
    u = (s * p).sum(1) * inv
    q = np.cross(s, e1)
    v = (q @ d) * inv
    t = (q * e2).sum(1) * inv
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    return float(t[hit].min()) if hit.any() else math.inf


def test_hits_agree_with_the_polygonizers_mesh():
    """Rays aimed at the body of a blended, warped tree hit where they cross its mesh, to within
    a twentieth of a mesh cell (the flat triangles' own error)."""
    tree = (bt.Point(radius=2.0) + bt.Point(radius=1.6, center=(1.2, 0.3, 0.0))
            + bt.Cone((0.0, 0.0, 0.0), (2.4, 0.0, 0.0), 1.2, 0.5).bend(40.0, 2.4))
    resolution = 96
    mesh = bt.polygonize(tree, resolution=resolution, progress=False)
    lo, hi = tree.bounds()
    cell = float((hi - lo).max()) / resolution
    rng = np.random.default_rng(3)
    dirs = rng.normal(size=(40, 3))
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    targets = np.array([0.5, 0.4, 0.0]) + rng.uniform(-0.2, 0.2, size=(40, 3))
    origins = targets - 6.0 * dirs
    t = intersect(tree, origins, dirs)
    expected = np.array([first_mesh_hit(mesh, o, d) for o, d in zip(origins, dirs, strict=True)])
    assert np.all(np.isfinite(t)) and np.all(np.isfinite(expected))
    np.testing.assert_allclose(t, expected, rtol=0, atol=0.05 * cell)


def test_rays_that_miss_give_nan_and_tmax_cuts():
    tree = bt.Point(radius=2.0)
    o = np.array([[0.0, 0.0, 5.0], [0.0, 1.2, 5.0], [0.0, 0.0, 5.0]])
    d = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, -1.0], [0.0, 0.0, -1.0]])
    t = intersect(tree, o, d, tmax=np.array([10.0, 10.0, 3.9]))
    assert t[0] == pytest.approx(4.0, abs=1e-9)
    assert np.isnan(t[1]) and np.isnan(t[2])


def test_thin_spine_beside_a_big_body_is_never_missed():
    # A spine about two pixels wide next to a large blob (a large Lipschitz bound nearby).
    spine = bt.Cone((0.0, -1.2, 0.0), (0.0, 1.2, 0.0), radius_a=0.1, radius_b=0.08)
    tree = spine | bt.Point(radius=3.0, center=(2.6, 0.0, 0.0))
    cam = Camera(eye=(0.0, 0.0, 4.0), target=(0.0, 0.0, 0.0), fov=40.0)
    img = render(tree, 64, 64, camera=cam, background=BLACK, shadows=False)
    hit = covered(img)
    # Rows the spine spans (|y| < 1.1 at depth 4): every one has a hit near the centre column.
    half = math.tan(math.radians(20.0)) * 4.0
    rows = [j for j in range(64) if abs((1 - 2 * (j + 0.5) / 64) * half) < 1.1]
    assert all(hit[j, 28:36].any() for j in rows)


def _assert_pixels_find_surfaces(tree: bt.Node, n: int, camera: Camera | None = None) -> None:
    """Every pixel whose ray (through its centre) runs inside the surface (field >= 0.5, by
    dense samples of the reference) for longer than a pixel's width there is covered, and none
    whose ray stays clearly outside (field < 0.49) is."""
    lo, hi = tree.bounds()
    cam = camera or default_camera(tree.program(), n, n)
    img = render(tree, n, n, camera=cam, background=(0.0, 0.0, 1.0), shadows=False)
    fwd, right, up = cam.basis()
    half = math.tan(math.radians(cam.fov) / 2.0)  # the image plane's half height at depth 1
    eye = np.array(cam.eye)
    far = float(np.linalg.norm(np.maximum(np.abs(eye - lo), np.abs(eye - hi))))
    ts = np.linspace(0.0, far, 1001)
    sx = (2 * (np.arange(n) + 0.5) / n - 1)[None, :, None]
    sy = (1 - 2 * (np.arange(n) + 0.5) / n)[:, None, None]
    D = (fwd + half * (sx * right + sy * up)).reshape(-1, 3)
    D /= np.linalg.norm(D, axis=1)[:, None]
    f = tree.reference((eye + ts[None, :, None] * D[:, None, :]).reshape(-1, 3))[0]
    inside = f.reshape(n * n, len(ts)) >= 0.5
    hit = np.any(img != [0, 0, 255], axis=2).ravel()
    peak = f.reshape(n * n, len(ts)).max(axis=1)
    assert not np.any(hit & (peak < 0.49))
    for k in np.flatnonzero(inside.any(axis=1) & ~hit):  # a missed surface must be thin
        start = int(np.argmax(inside[k]))
        run = np.argmin(inside[k, start:]) if not inside[k, start:].all() else len(ts) - start
        assert run * (ts[1] - ts[0]) <= 2.0 * ts[start] * half / n, (k, peak[k])


@examples(0.25)
@given(trees())
def test_packets_find_every_surface_a_pixel_crosses(tree):
    """On random trees the packet tracer's rise bounds never step over a surface a pixel's ray
    crosses, nor find one it does not."""
    lo, hi = tree.bounds()
    if not (np.all(lo <= hi) and np.all(np.isfinite(lo))):
        return
    _assert_pixels_find_surfaces(tree, 24)


def test_packets_find_small_blobs_and_a_disc_edge_on():
    """Rays that pass small blobs at every depth, and a thin disc nearly edge on, find each
    one a pixel's ray runs through: the rays leave some blobs (no rise) while nearing others."""
    rng = np.random.default_rng(3)
    blobs = [bt.Point(radius=0.25, center=tuple(c)) for c in rng.uniform(-1.5, 1.5, (40, 3))]
    disc = bt.Point(radius=2.0).scale(1.0, 0.04, 1.0)
    cam = Camera(eye=(0.3, 0.25, 6.0), target=(0.0, 0.0, 0.0), fov=40.0)
    _assert_pixels_find_surfaces(bt.Blend(disc, *blobs), 48, cam)


def test_silhouette_area_matches_projected_disc():
    tree = bt.Point(radius=2.0)  # sphere of radius 1
    dist, fov, n = 4.0, 40.0, 64
    cam = Camera(eye=(0.0, 0.0, dist), target=(0.0, 0.0, 0.0), fov=fov)
    img = render(tree, n, n, camera=cam, background=BLACK, shadows=False)
    r_px = math.tan(math.asin(1.0 / dist)) / math.tan(math.radians(fov / 2)) * n / 2
    area = covered(img).sum()
    assert area == pytest.approx(math.pi * r_px**2, rel=0.03)


def test_no_holes_at_grazing_angles():
    disc = bt.Point(radius=2.0).scale(1.0, 0.04, 1.0)  # a thin flat disc, seen nearly edge on
    cam = Camera(eye=(0.0, 0.12, 5.0), target=(0.0, 0.0, 0.0), fov=30.0)
    img = render(disc, 64, 48, camera=cam, background=BLACK, shadows=False)
    hit = covered(img)
    cols = np.nonzero(hit.any(axis=0))[0]
    assert len(cols) > 30
    for x in cols[2:-2]:  # every column is one unbroken vertical run
        ys = np.nonzero(hit[:, x])[0]
        assert ys[-1] - ys[0] + 1 == len(ys)


# ----- shading ------------------------------------------------------------------------------
def test_shadow_darkens_the_ground_behind_an_occluder():
    ground = bt.Point(radius=2.0).scale(3.0, 0.25, 3.0)
    ball = bt.Point(radius=0.8, center=(0.0, 1.2, 0.0))
    tree = ground | ball
    cam = Camera(eye=(0.0, 5.0, 5.0), target=(0.0, 0.0, 0.0), fov=45.0)
    light = [Light(direction=(0.0, -1.0, 0.0))]
    lit = render(tree, 48, 48, camera=cam, lights=light, shadows=False).astype(int)
    shadowed = render(tree, 48, 48, camera=cam, lights=light, shadows=True).astype(int)
    darker = (shadowed.sum(axis=2) < lit.sum(axis=2) - 30)
    assert darker.sum() > 20
    # The darkened pixels are ground under the ball: below the ball's image, near the middle.
    ys, xs = np.nonzero(darker)
    assert abs(xs.mean() - 23.5) < 4
    # Away from the shadow nothing changes.
    assert (shadowed[:, :8] == lit[:, :8]).all()


def test_convex_object_has_no_shadow_acne():
    tree = bt.Point(radius=2.0)
    cam = Camera(eye=(1.0, 2.0, 4.0), target=(0.0, 0.0, 0.0), fov=40.0)
    a = render(tree, 48, 48, camera=cam, shadows=True)
    b = render(tree, 48, 48, camera=cam, shadows=False)
    assert (a == b).all()


def test_albedo_colours_the_image_and_background_is_exact():
    tree = bt.Point(radius=2.0).color((1.0, 0.0, 0.0))
    cam = Camera(eye=(0.0, 0.0, 4.0), target=(0.0, 0.0, 0.0), fov=40.0)
    img = render(tree, 32, 32, camera=cam, background=(0.0, 0.0, 1.0))
    assert (img[0, 0] == [0, 0, 255]).all()
    centre = img[16, 16].astype(int)
    assert centre[0] > 100 and centre[1] < 60 and centre[2] < 60


def test_lambert_shading_is_gamma_encoded():
    tree = bt.Point(radius=2.0)  # default albedo 0.8 grey
    cam = Camera(eye=(0.0, 0.0, 4.0), target=(0.0, 0.0, 0.0), fov=40.0)
    light = [Light(direction=(0.0, 0.0, -1.0))]  # shines along the view: n.l = 1 at the centre
    img = render(tree, 33, 33, camera=cam, lights=light, background=BLACK, ambient=0.0,
                 specular=0.0)
    # The albedo is an sRGB colour: lit head-on, the pixel shows it exactly (0.8 -> 204).
    assert tuple(img[16, 16]) == (204, 204, 204)
    # Off centre, Lambert's n.l scales the *linear* albedo, then the result is sRGB-encoded.
    px = 26
    half = np.tan(np.radians(20.0))
    d = np.array([[(2 * (px + 0.5) / 33 - 1) * half, 0.0, -1.0]])
    t = intersect(tree, np.array([[0.0, 0.0, 4.0]]), d)[0]
    p = np.array([0.0, 0.0, 4.0]) + t * d[0]
    ndl = p[2] / np.linalg.norm(p)
    lin = ((0.8 + 0.055) / 1.055) ** 2.4 * ndl
    expected = round(255 * (1.055 * lin ** (1 / 2.4) - 0.055))
    assert abs(int(img[16, px, 0]) - expected) <= 1
    side = [Light(direction=(1.0, 0.0, 0.0))]  # shines toward +x: only the -x half is lit
    img = render(tree, 33, 33, camera=cam, lights=side, background=BLACK, ambient=0.0,
                 specular=0.0).astype(int)
    assert img[16, 9].sum() > 3 * 60 and img[16, 24].sum() == 0


def test_srgb_bytes_round_the_iec_encoding():
    def encode(c):  # IEC 61966-2-1, then rounded to 8 bits
        c = np.clip(c, 0.0, 1.0)
        s = np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)
        return np.floor(s * 255.0 + 0.5).astype(int)

    rng = np.random.default_rng(3)
    steps = np.repeat(SRGB_STEPS, 4) * (1.0 + rng.choice([-1e-9, 1e-9, -1e-6, 1e-6], 1020))
    c = np.concatenate([rng.uniform(-0.2, 1.2, 20_000), rng.uniform(0.0, 0.004, 2000), steps,
                        [0.0, 1.0, -1.0, 2.0]])
    got = np.array([linear_to_srgb_byte(x) for x in c])
    assert np.array_equal(got, encode(c))
    assert set(got) == set(range(256))


FRONT = Camera(eye=(0.0, 0.0, 6.0), target=(0.0, 0.0, 0.0), fov=40.0)


def _front_hits(tree, n: int):
    """(which of FRONT's n x n pixel-centre rays hit ``tree`` (``intersect``), their hit points,
    the tree's program)."""
    half = np.tan(np.radians(20.0))
    u = (2 * (np.arange(n) + 0.5) / n - 1) * half
    d = np.stack([np.tile(u, n), -np.repeat(u, n), -np.ones(n * n)], axis=1)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.tile([0.0, 0.0, 6.0], (n * n, 1))
    t = intersect(tree, o, d)
    hit = t >= 0
    return hit, o[hit] + t[hit, None] * d[hit], tree.program()


def _lit_bytes(srgb: np.ndarray, light: np.ndarray) -> np.ndarray:
    """8-bit sRGB of sRGB albedos lit by ``light`` (per point), by the IEC formulas."""
    lin = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4) * light[:, None]
    return np.round(255 * np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055))


def test_each_pixel_shows_its_own_blended_albedo():
    # A red and a green blob blended: the albedo changes from pixel to pixel within a packet
    # (the shader reuses a decoded albedo only where the field's colour is the same).
    tree = (bt.Point(radius=2.0).translate(-0.9, 0, 0).color((0.8, 0.2, 0.2))
            + bt.Point(radius=2.0).translate(0.9, 0, 0).color((0.2, 0.8, 0.2)))
    n = 40
    img = render(tree, n, n, camera=FRONT, lights=[Light(direction=(0.0, 0.0, -1.0))],
                 background=BLACK, ambient=0.0, specular=0.0, shadows=False).astype(int)
    hit, p, prog = _front_hits(tree, n)
    g = prog.gradient(p)
    ndl = np.clip((g / np.linalg.norm(g, axis=1, keepdims=True)) @ [0.0, 0.0, -1.0], 0, 1)
    srgb = prog.albedo(p)
    expected = _lit_bytes(srgb, ndl)
    got = img.reshape(-1, 3)[hit]
    assert len(np.unique(srgb[:, 0].round(6))) > 50  # the albedo varies across the image
    assert np.abs(got - expected).max() <= 2
    assert np.mean(np.abs(got - expected) > 0) < 0.02


def test_ambient_occlusion_follows_the_field_along_each_normal():
    # Ambient light only, with occlusion: each pixel is its albedo times 1 - occlusion, the
    # occlusion from the field sampled along the normal (shade._occlusions, in batches on the
    # packet's program or the full one) against its formula on the engine's field.
    tree = (bt.Point(radius=1.6).translate(-0.7, 0, 0)
            + bt.Point(radius=1.6).translate(0.7, 0.3, -0.4)
            + bt.Point(radius=1.2).translate(0.0, -0.9, 0.6)).color((0.7, 0.6, 0.5))
    n, strength, radius = 40, 0.9, 0.08
    img = render(tree, n, n, camera=FRONT, lights=[], background=BLACK, ambient=1.0, sky=0.0,
                 occlusion=strength, occlusion_radius=radius, shadows=False).astype(int)
    hit, p, prog = _front_hits(tree, n)
    lo, hi = prog.bounds
    reach = radius * np.linalg.norm(np.asarray(hi) - np.asarray(lo))
    g = prog.gradient(p)
    slope = np.linalg.norm(g, axis=1)
    normal = -g / slope[:, None]
    k = np.arange(1, 5)
    dist = reach * k / 4
    f = prog.field((p[:, None, :] + dist[None, :, None] * normal[:, None, :]).reshape(-1, 3))
    excess = f.reshape(-1, 4) - np.maximum(0.5 - slope[:, None] * dist, 0.0)
    occ = (np.clip(excess / 0.5, 0.0, 1.0) / k).sum(axis=1) / (1.0 / k).sum()
    expected = _lit_bytes(prog.albedo(p), 1.0 - strength * occ)
    got = img.reshape(-1, 3)[hit]
    shown = got.max(axis=1) > 0  # (a grazing ray at the silhouette may miss on either side)
    assert np.mean(~shown) < 0.01 and np.all(img.reshape(-1, 3)[~hit] == 0)
    assert np.mean(occ[shown] > 0.05) > 0.05  # the creases are occluded
    assert np.abs(got - expected)[shown].max() <= 2
    assert np.mean(np.abs(got - expected)[shown] > 0) < 0.02


def test_warm_kernels_loads_the_ray_tracer_on_another_thread():
    from blobtree.render import warm_kernels

    tiles_module = importlib.import_module("blobtree.render.tiles")  # (not render.tiles())
    thread = warm_kernels()
    assert thread.daemon and thread is not threading.current_thread()
    thread.join(timeout=600)
    assert not thread.is_alive()
    assert tiles_module._render_blocks.signatures  # loaded (or compiled) for the real render


# ----- sampling, tiles and reproducibility -----------------------------------------------------
def test_antialiasing_is_reproducible_and_only_changes_edges():
    tree = bt.Point(radius=2.0)
    cam = Camera(eye=(0.0, 0.0, 4.0), target=(0.0, 0.0, 0.0), fov=40.0)
    a = render(tree, 32, 32, camera=cam, samples=4, background=BLACK)
    b = render(tree, 32, 32, camera=cam, samples=4, background=BLACK)
    one = render(tree, 32, 32, camera=cam, samples=1, background=BLACK)
    assert (a == b).all()
    assert not (a == one).all()
    edge = covered(a) != covered(one)
    assert edge.sum() < 0.2 * covered(one).sum()
    c = render(tree, 32, 32, camera=cam, samples=4, background=BLACK, seed=7)
    assert not (a == c).all()


@pytest.mark.parametrize("samples", [1, 3])
def test_tiles_assemble_into_identical_bytes(samples):
    tree = bt.models.whorl126()
    prog = tree.program()
    w, h = 40, 30
    whole = render(prog, w, h, samples=samples)
    cam = default_camera(prog, w, h)
    settings = RenderSettings(width=w, height=h, samples=samples, **LOOKS["studio"])
    lights = default_lights(cam)
    out = np.zeros_like(whole)
    for x0, y0, x1, y1 in [(0, 0, 17, 11), (17, 0, 40, 11), (0, 11, 40, 30)]:
        out[y0:y1, x0:x1] = render_tile(prog, cam, lights, settings, x0, y0, x1, y1)
    assert (out == whole).all()
    assert (render(prog, w, h, samples=samples, tile=7) == whole).all()


def test_a_render_is_stopped_by_its_flag():
    """A tile traced with its stop flag set draws no packet; unset, the tile's pixels; and
    local_tiles raises Stopped rather than hand out a tile it may have cut short."""
    from blobtree.render import Stopped, local_tiles
    from blobtree.render.tiles import _render_blocks, render_arguments

    prog = bt.models.whorl126().program()
    cam = default_camera(prog, 32, 32)
    settings = RenderSettings(width=32, height=32, **LOOKS["studio"])
    lights = default_lights(cam)
    packed = (prog, cam.packed(32, 32), pack_lights(lights), settings, 0, 0, 32, 32)
    for flag, expected in ((1, np.full((32, 32, 3), 7, np.uint8)),
                           (0, render_tile(prog, cam, lights, settings, 0, 0, 32, 32))):
        args = render_arguments(*packed, np.full(1, flag, dtype=np.int8))
        args[3][:] = 7
        _render_blocks(*args)
        assert (args[3] == expected).all()
    stop = np.ones(1, dtype=np.int8)
    with pytest.raises(Stopped):
        next(local_tiles(prog, cam, lights, settings, list(tiles(32, 32, 16)), 2, stop))


def test_default_tile_is_the_largest_that_keeps_every_thread_busy():
    from blobtree.render import FEW_TILES, SMALL_TILE, TILE_SIDES, TILES_PER_THREAD, tile_side

    for w, h, threads in ((1600, 1600, 2), (1024, 1024, 2), (800, 600, 1), (512, 512, 2),
                          (256, 256, 2), (128, 128, 2), (64, 64, 2), (4000, 300, 8), (1, 1, 1)):
        side = tile_side(w, h, threads)
        count = {s: -(-w // s) * -(-h // s) for s in (*TILE_SIDES, SMALL_TILE)}
        busy = [s for s in TILE_SIDES if count[s] >= TILES_PER_THREAD * threads]
        if busy:
            assert side == max(busy)
        elif count[min(TILE_SIDES)] >= FEW_TILES * threads:
            assert side == min(TILE_SIDES)
        else:  # a small picture: smaller tiles, enough of them or the smallest
            assert SMALL_TILE <= side < min(TILE_SIDES)
            assert count[side] >= FEW_TILES * threads or side == SMALL_TILE
    assert tile_side(1600, 1600, 2) > tile_side(256, 256, 2) > tile_side(128, 128, 2)


def test_tiles_cover_the_image_once():
    cover = np.zeros((50, 70), dtype=int)
    for x0, y0, x1, y1 in tiles(70, 50, 16):
        cover[y0:y1, x0:x1] += 1
    assert (cover == 1).all()


def test_default_camera_frames_the_whole_tree():
    tree = bt.Point(radius=2.0, center=(5.0, 1.0, -2.0)) + bt.Point(radius=1.0,
                                                                     center=(6.0, 1.5, -2.0))
    img = render(tree, 48, 48, background=BLACK, shadows=False)
    hit = covered(img)
    assert not hit[0].any() and not hit[-1].any() and not hit[:, 0].any() and not hit[:, -1].any()
    assert hit.mean() > 0.1


# ----- arguments and files ------------------------------------------------------------------
@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"width": 0}, "width"),
        ({"height": -3}, "height"),
        ({"samples": 0}, "samples"),
        ({"background": (255, 0, 0)}, "background"),
        ({"lights": ["sun"]}, "lights[0]"),
        ({"threads": 0}, "threads"),
        ({"camera": "front"}, "camera"),
    ],
)
def test_bad_render_arguments_name_the_parameter(kwargs, name):
    args = {"width": 8, "height": 8, **kwargs}
    with pytest.raises(ValueError, match=re_name(name)):
        render(bt.Point(radius=1.0), **args)


def re_name(name: str) -> str:
    return name.replace("[", r"\[").replace("]", r"\]")


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"fov": 200.0}, "fov"),
        ({"fov": 0.0}, "fov"),
        ({"eye": (np.nan, 0.0, 1.0)}, "eye"),
        ({"eye": (0.0, 0.0, 0.0)}, "eye"),
        ({"up": (0.0, 0.0, 1.0)}, "up"),
        ({"target": (1.0, 2.0)}, "target"),
    ],
)
def test_bad_camera_arguments_name_the_parameter(kwargs, name):
    args = {"eye": (0.0, 0.0, 5.0), "target": (0.0, 0.0, 0.0), **kwargs}
    with pytest.raises(ValueError, match=name) as err:
        Camera(**args)
    assert str(list(kwargs.values())[0])[:4] in str(err.value)


def test_bad_light_and_tile_arguments():
    with pytest.raises(ValueError, match="direction"):
        Light()
    with pytest.raises(ValueError, match="intensity"):
        Light(direction=(0, -1, 0), intensity=-1.0)
    settings = RenderSettings(width=8, height=8)
    cam = Camera(eye=(0.0, 0.0, 5.0))
    with pytest.raises(ValueError, match="tile"):
        render_tile(bt.Point(radius=1.0).program(), cam, [], settings, 0, 0, 9, 8)


@pytest.mark.parametrize("shape", [(1, 1), (3, 2), (37, 101), (200, 333)])
def test_png_pieces_deflated_apart_join_into_the_image(monkeypatch, shape):
    """The PNG writer's own encoding (Sub filter, deflated in pieces on several threads) decodes,
    through Pillow's independent decoder with its CRC checks, to the very pixels written; pieces
    far smaller than the image force many joins, at every offset in a row."""
    from blobtree.render import image

    rng = np.random.default_rng(shape[0])
    img = rng.integers(0, 256, (*shape, 3), dtype=np.uint8)
    img[: shape[0] // 2] //= 16  # some rows that compress, some that do not
    for piece in (7, 1000, 1 << 20):
        monkeypatch.setattr(image, "PNG_PIECE", piece)
        data = image.encode_png(img)
        Image.open(io.BytesIO(data)).verify()
        assert (np.asarray(Image.open(io.BytesIO(data))) == img).all()


def test_save_image_writes_png_atomically(tmp_path):
    img = np.zeros((5, 7, 3), dtype=np.uint8)
    img[2, 3] = (10, 200, 30)
    path = save_image(img, tmp_path / "out.png")
    back = np.asarray(Image.open(path))
    assert (back == img).all()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.png"]
    with pytest.raises(ValueError, match="path"):
        save_image(img, tmp_path / "out.xyz")
    with pytest.raises(ValueError, match="img"):
        save_image(np.zeros((5, 7)), tmp_path / "bad.png")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.png"]
