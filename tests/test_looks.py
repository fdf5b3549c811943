"""The looks of the ray tracer: framing, backdrop, ambient occlusion, soft shadows."""

import numpy as np
import pytest

import blobtree as bt
from blobtree.render import LOOKS, Camera, Light, RenderSettings, intersect, render
from blobtree.render.camera import FILL, default_camera, framed_camera

BLACK = (0.0, 0.0, 0.0)


def covered(img: np.ndarray) -> np.ndarray:
    return img.max(axis=2) > 0


def spans(img: np.ndarray) -> tuple[float, float]:
    """Share of the image's width and height the non-black pixels span."""
    m = covered(img)
    cols, rows = np.flatnonzero(m.any(axis=0)), np.flatnonzero(m.any(axis=1))
    return (cols[-1] - cols[0] + 1) / m.shape[1], (rows[-1] - rows[0] + 1) / m.shape[0]


@pytest.mark.parametrize("tree, size", [
    (bt.models.whorl126(), (96, 64)),
    (bt.blend(bt.Point(radius=1.0), bt.Cone((0, 0, 0), (3, 1, 0), radius_a=0.6, radius_b=0.2)),
     (64, 96)),
])
def test_default_framing_fills_85_percent_centred(tree, size):
    w, h = size
    cam = default_camera(tree.program(), w, h)
    img = render(tree, w, h, camera=cam, background=BLACK, look="paper", shadows=False)
    sw, sh = spans(img)
    assert max(sw, sh) == pytest.approx(FILL, abs=0.05)  # whichever side binds
    m = covered(img)
    cols, rows = np.flatnonzero(m.any(axis=0)), np.flatnonzero(m.any(axis=1))
    # centred: the margins on either side agree to a few pixels
    assert abs(cols[0] - (w - 1 - cols[-1])) <= 3 and abs(rows[0] - (h - 1 - rows[-1])) <= 3


def test_framed_camera_keeps_the_view_direction_and_up():
    prog = bt.models.whorl126().program()
    cam = framed_camera(prog, 64, 64, view=(1.0, -0.5, 0.2), up=(0.0, -1.0, 0.0))
    fwd, _, up = cam.basis()
    assert fwd == pytest.approx(np.array([1.0, -0.5, 0.2]) / np.linalg.norm([1.0, -0.5, 0.2]))
    assert up @ np.array([0.0, -1.0, 0.0]) > 0.8
    with pytest.raises(ValueError, match="up must not be parallel to view"):
        framed_camera(prog, 64, 64, view=(0.0, 1.0, 0.0), up=(0.0, 2.0, 0.0))


def test_backdrop_fades_from_top_to_bottom_and_background_makes_it_plain():
    empty = bt.Point(radius=0.1).translate(100.0, 0.0, 0.0)
    cam = Camera(eye=(0.0, 0.0, 10.0))  # looks away from the point: every ray misses
    img = render(empty, 8, 40, camera=cam, look="studio").astype(int)
    top, bottom = LOOKS["studio"]["background"], LOOKS["studio"]["background_bottom"]
    column = img[:, 3, 0]
    assert np.all(np.diff(column) <= 0)  # darker toward the bottom, never lighter
    assert column[0] == pytest.approx(255 * top[0], abs=2)
    assert column[-1] == pytest.approx(255 * bottom[0], abs=6)
    assert (img == img[:, :1]).all()  # the same across each row
    plain = render(empty, 8, 40, camera=cam, look="studio", background=(0.2, 0.4, 0.6))
    assert (plain == np.array([51, 102, 153], dtype=np.uint8)).all()


def _occlusion_at(tree, points: np.ndarray, radius: float) -> np.ndarray:
    """The shading kernel's ambient occlusion (``shade._occlusions``) at surface points of
    ``tree``, each the hit of a ray straight down onto it."""
    from blobtree.engine.batch import BATCH, point_rows, value_rows
    from blobtree.render import shade

    prog = tree.program()
    lo, hi = (np.asarray(b, dtype=float) for b in prog.bounds)
    n = len(points)
    g = prog.gradient(points)
    rays = np.full((10, n), -1.0)
    rays[shade.HIT] = 1.0
    D = np.tile([0.0, -1.0, 0.0], (n, 1))
    surf = np.zeros((n, shade.OCC + 1))
    surf[:, shade.SLOPE] = np.linalg.norm(g, axis=1)
    surf[:, [shade.NX, shade.NY, shade.NZ]] = -g / surf[:, shade.SLOPE, None]
    look = np.zeros(7)
    look[shade.OCCLUSION_RADIUS] = radius
    hits = (np.empty(BATCH, dtype=np.int64), np.empty((n, shade.OCCLUSION_SAMPLES)))
    rows = (point_rows(prog.depth), value_rows(prog.depth), np.empty((prog.depth, 7)))
    none = np.empty((0, 3))  # (what occlusion does not read)
    packet = (none, rays, points - D, D, none, none, surf, none, np.empty((0, 3), dtype=np.int64),
              rows, None, hits)
    shade._occlusions(prog.arrays, (prog.arrays, lo, hi), n, look, packet)
    return surf[:, shade.OCC]


def _surface_below(tree, xz: np.ndarray) -> np.ndarray:
    """The first surface point straight below each (x, z), seen from y = 10."""
    o = np.column_stack([xz[:, 0], np.full(len(xz), 10.0), xz[:, 1]])
    t = intersect(tree, o, np.tile([0.0, -1.0, 0.0], (len(xz), 1)))
    return o + t[:, None] * np.array([0.0, -1.0, 0.0])


def test_occlusion_darkens_where_other_surface_is_near():
    floor = bt.Point(radius=6.0).scale(1.0, 0.1, 1.0).translate(0.0, -0.3, 0.0)
    ball = bt.Point(radius=1.0).translate(0.0, 0.55, 0.0)
    scene = bt.union(floor, ball)
    xs = np.array([0.62, 0.7, 0.9, 2.5])  # floor points ever farther from the ball's foot
    pts = _surface_below(scene, np.column_stack([xs, np.zeros(4)]))
    assert np.all(pts[:, 1] < 0.0)  # they are on the floor, beside the ball
    occ = _occlusion_at(scene, pts, radius=0.6)
    assert occ[0] > 0.2  # tucked under the ball
    assert np.all(np.diff(occ) <= 1e-12)  # less and less occluded...
    # ...and open surface hardly at all (a field is not exactly linear along the normal: a few
    # percent remain where nothing is near)
    assert occ[-1] < 0.05
    top = _surface_below(ball, np.array([[0.0, 0.0]]))
    assert _occlusion_at(ball, top, radius=0.6)[0] < 0.05


def _ball_over_ground(light_radius: float, height: float = 0.2) -> np.ndarray:
    ground = bt.Point(radius=4.0).scale(1.0, 0.15, 1.0).translate(0.0, -1.0, 0.0)
    ball = bt.Point(radius=0.6).translate(0.0, height, 0.0)
    cam = Camera(eye=(0.0, 3.0, 4.0), target=(0.0, -0.6, 0.0), fov=40.0)
    return render(bt.union(ground, ball), 64, 64, camera=cam, background=BLACK, look="paper",
                  lights=[Light(direction=(0.3, -1.0, 0.1))], ambient=0.0, specular=0.0,
                  light_radius=light_radius).astype(int)


def test_soft_shadows_only_widen_the_shadow_edge():
    hard = _ball_over_ground(0.0)
    soft = _ball_over_ground(6.0)
    assert np.all(soft <= hard)  # a penumbra only takes light away
    darker = (soft < hard - 8).any(axis=2)
    assert darker.sum() > 20  # a visible penumbra...
    assert darker.sum() < 0.5 * covered(hard).sum()  # ...around the shadow, not everywhere
    # a lone surface casts on nothing: soft and hard shadows give the same bytes
    lone = dict(camera=Camera(eye=(0.0, 0.0, 5.0)), background=BLACK, look="paper")
    ball = bt.Point(radius=0.6)
    assert (render(ball, 32, 32, light_radius=6.0, **lone) ==
            render(ball, 32, 32, light_radius=0.0, **lone)).all()


def test_penumbra_grows_with_the_light_and_the_occluders_height():
    """An area light's penumbra is about (distance occluder to receiver) x (its angular size)
    wide: a larger light, or the ball lifted higher above the ground, darkens more of it."""
    def penumbra_pixels(radius, height=0.2):
        hard = _ball_over_ground(0.0, height)
        return int(((_ball_over_ground(radius, height) < hard - 8).any(axis=2)).sum())

    assert penumbra_pixels(2.0) < penumbra_pixels(6.0) < penumbra_pixels(12.0)
    assert penumbra_pixels(6.0, height=0.0) < penumbra_pixels(6.0, height=0.6)


def test_paper_look_is_the_plain_default_settings():
    tree = bt.blend(bt.Point(radius=1.0).translate(-0.55, 0, 0),
                    bt.Point(radius=1.0).translate(0.55, 0, 0))
    cam = Camera(eye=(0.0, 0.0, 6.0), fov=30.0)
    a = render(tree, 24, 24, camera=cam, look="paper")
    from blobtree.render import render_tile
    from blobtree.render.shade import default_lights
    b = render_tile(tree.program(), cam, default_lights(cam), RenderSettings(24, 24), 0, 0, 24, 24)
    assert (a == b).all()
    assert a[0, 0].tolist() == [255, 255, 255]


@pytest.mark.parametrize("kw, words", [
    (dict(look="shiny"), "look must be one of"),
    (dict(occlusion=2.0), "occlusion"),
    (dict(light_radius=-0.1), "light_radius"),
    (dict(light_radius=45.0), "light_radius"),
    (dict(sky=1.5), "sky"),
    (dict(occlusion_radius=0.0), "occlusion_radius"),
    (dict(step=0.0), "step"),
    (dict(step=9.0), "step"),
])
def test_bad_look_values_are_refused_by_name(kw, words):
    with pytest.raises(ValueError, match=words):
        render(bt.Point(), 8, 8, **kw)
