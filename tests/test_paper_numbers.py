"""The paper's numbers, pinned by expectations computed here from the paper itself (its equations,
both tables, the figures' captions), not through the package's spiral or model code."""

from __future__ import annotations

import importlib
import math
from dataclasses import replace

import numpy as np
import pytest

import blobtree as bt
from blobtree.helico import helico_spiral
from tests.shell_geometry import (
    BETA,
    RHO,
    THETA_S,
    canal_length,
    canal_line,
    spiral,
    suture,
    varix_theta,
    world,
)

pytestmark = pytest.mark.slow  # builds whole parts of the shell

M = importlib.import_module("blobtree.models.murex")

# --- Tables 1-2, as printed -------------------------------------------------------------------
DELTA_MAX = 1.92  # the largest delta of Table 1 (whorl 7, -40 degrees)
TABLE_2 = {1: [0.96, 0.92, 0.84, 0.68, 0.45, 0.25], 2: [0.95, 0.99, 0.76, 0.51, 0.35, 0.28],
           3: [1.00, 0.90, 0.92, 0.70, 0.60]}


def mirror(points: np.ndarray, theta: float) -> np.ndarray:
    """Points reflected in the meridian plane at angle theta (the plane of a generating curve
    placed there by Eq. 8: the local z = 0 turned by theta about y)."""
    n = np.array([math.sin(math.radians(theta)), 0.0, math.cos(math.radians(theta))])
    return points - 2.0 * (points @ n)[:, None] * n


def crossing(tree: bt.Node, start, direction, reach: float) -> float:
    """Distance from ``start`` (inside) along ``direction`` to the 0.5 surface (bisection)."""
    start, direction = np.asarray(start, float), np.asarray(direction, float)
    lo, hi = 0.0, reach
    assert tree.field((start + hi * direction)[None])[0] < 0.5
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if tree.field((start + mid * direction)[None])[0] >= 0.5:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


# --- Section 2.1: Eqs. 1-3 and 7 -----------------------------------------------------------------


@pytest.mark.parametrize("theta", [0.0, 116.0, 360.0, 1000.0, 2436.0])
def test_eqs_1_to_3_with_eq_7(theta):
    r, h, d = spiral(theta)
    assert helico_spiral(theta) == pytest.approx((r, h, d), rel=1e-12)
    # Eq. 3 itself, rounded by Eq. 7 to 0.341 R
    eq3 = r / math.sin(math.radians(BETA)) * (RHO - 1) / (RHO + 1)
    assert eq3 / r == pytest.approx(0.3408, abs=5e-5) and abs(eq3 - d) < 0.0005 * r
    # Eq. 8 places a node's origin on the spiral at that angle, scaled by D
    lo, hi = M.place(bt.Point(radius=2.0), theta).bounds()
    np.testing.assert_allclose(0.5 * (lo + hi), world((0, 0, 0), theta)[0], atol=1e-12)
    np.testing.assert_allclose(0.5 * (hi - lo), 2.0 * d, rtol=1e-12)


def test_whorls_sections_and_instances():
    assert M.WHORLS == 7 and M.SECTION_DEG == 116 and M.WHORL_DEG == 348
    assert M.THETA_S == pytest.approx(THETA_S) and M.INSTANCES == 126


def test_every_varix_lies_in_the_plane_over_a_join_of_two_sections():
    """Sections 3.1-3.4: a varix covers the join of two sections, 116 degrees after the one
    before, and the 21st, the last, stands at the lip, on the last instance, 106 1/3 degrees
    after the 20th.  A varix is symmetric about the plane of the generating curve at its angle
    (Eq. 13): each varix's field is the same at points and at their mirror images in the
    meridian plane at that angle, and not when the plane is 0.1 degrees off."""
    thetas = [varix_theta(k) for k in range(1, 22)]
    assert np.diff(thetas) == pytest.approx([116.0] * 19 + [106.0 + 1.0 / 3.0])
    varices = M.varices()
    assert len(varices) == 21
    rng = np.random.default_rng(5)
    for k, (v, theta) in enumerate(zip(varices, thetas, strict=True), 1):
        lo, hi = v.bounds()
        P = rng.uniform(lo, hi, (4000, 3))
        f = v.field(P)
        P, f = P[f > 0.05], f[f > 0.05]
        assert len(P) > 50, k
        np.testing.assert_allclose(v.field(mirror(P, theta)), f, atol=1e-9, err_msg=str(k))
        assert np.abs(v.field(mirror(P, theta + 0.1)) - f).max() > 1e-3, k
    # the lip: the body's last instance is inside it, the next instance's place is not
    body = M.body_whorl()
    assert body.field(world((0, 0, 0), thetas[-1]))[0] >= 0.5
    assert body.field(world((0, 0, 0), thetas[-1] + THETA_S))[0] < 0.5


def _eq_10(points: np.ndarray, point_radius: float) -> np.ndarray:
    """Eqs. 8-10 computed here: the 126 points of field radius point_radius D (soft objects,
    DESIGN's falloff), summed per section of six (Eq. 9), each section blended with its
    neighbours only (the max over the pairs, Eq. 10)."""
    centres = np.concatenate([world((0, 0, 0), i * THETA_S) for i in range(126)])
    radii = point_radius * np.array([spiral(i * THETA_S)[2] for i in range(126)])
    q = ((points[:, None, :] - centres[None]) ** 2).sum(axis=-1) / radii**2
    f = np.where(q < 1.0, 1.0 + q * (-22.0 / 9.0 + q * (17.0 / 9.0 - 4.0 / 9.0 * q)), 0.0)
    per_section = f.reshape(len(points), 21, 6).sum(axis=-1)
    return (per_section[:, :-1] + per_section[:, 1:]).max(axis=1)


def test_the_suture_is_eq_10s():
    """Eq. 10: adjacent whorls do not blend, so the outer suture is the groove where two whorls
    of points meet.  Along the whole last whorl (every half instance step) the model's body,
    with its canal and its fused canals, puts the surface across the suture where Eqs. 8-10
    computed here put it, to the 0.0025 D sampling step: under half a D out of the point where
    Eq. 3's tangent circles touch."""
    body = M.body_whorl()
    radius = M.DEFAULT.point_radius  # ours: the paper gives no field radius
    for theta in 125 * THETA_S - np.arange(0.0, 348.0, THETA_S / 2):
        expected = suture(lambda P: _eq_10(P, radius), theta)
        assert suture(body.field, theta) == pytest.approx(expected, abs=0.003), theta
        assert 0.3 < expected < 0.5


# --- Eqs. 11-12, Figure 7 ------------------------------------------------------------------------


def test_curving_spines_are_bent_30_degrees_toward_positive_y():
    c = M.DEFAULT
    s = M.spine(1.0, thick_top=False, widen=False)
    k = math.radians(30.0) / c.spine_length  # the arc of Eq. 12's bend
    tip = np.array([c.spine_offset + math.sin(math.radians(30)) / k,
                    (1 - math.cos(math.radians(30))) / k, 0.0])
    assert s.field(tip[None])[0] > 0.9  # the skeleton ends there: bent 30 degrees ...
    assert s.field((tip * (1, -1, 1))[None])[0] == 0.0  # ... toward +y, not -y
    straight = np.array([c.spine_offset + c.spine_length, 0.0, 0.0])
    assert s.field(straight[None])[0] < 0.5  # and it is bent: the unbent tip is off it


def _half_width_z(delta: float, **flags) -> float:
    """Half width along z of a spine's surface at the middle of its base cone."""
    c = M.DEFAULT
    s = M.spine(delta, **flags)
    base = np.array([c.spine_offset + 0.02 * c.spine_length * delta, 0.0, 0.0])
    return crossing(s, base, (0, 0, 1), 3.0 * DELTA_MAX)


def test_delta_max_scales_every_spine_along_z():
    """Eq. 12: s(delta_i, delta_i, delta_max): across the varix every spine is delta_max wide."""
    for delta in (0.55, 1.0, 1.5):
        wide = _half_width_z(delta, thick_top=False, widen=True)
        narrow = _half_width_z(delta, thick_top=False, widen=False)
        assert wide / narrow == pytest.approx(DELTA_MAX / delta, rel=0.01)


def _tip_width(delta: float, thick_top: bool) -> float:
    """Half width along z of a spine's surface at its tip (Eq. 11's 30-degree bend of a cone of
    length spine_length, moved out to x_k and scaled by delta), not widened by delta_max."""
    c = M.DEFAULT
    k = math.radians(30.0) / c.spine_length
    tip = np.array([c.spine_offset + delta * math.sin(math.radians(30)) / k,
                    delta * (1 - math.cos(math.radians(30))) / k, 0.0])
    return crossing(M.spine(delta, thick_top=thick_top, widen=False), tip, (0, 0, 1), 1.0)


def test_shorter_spines_have_thicker_tops():
    """Figure 7, bottom left: "smaller spines are modeled with wider tips", so that they stand
    out of the ridge.  Eq. 11's scale by delta alone makes the tip of Table 1's shortest spine
    (0.55) 0.55 / 1.92 as wide as the longest's (1.92); with the thicker tops it is at least as
    wide."""
    plain = _tip_width(0.55, False) / _tip_width(1.92, False)
    assert plain == pytest.approx(0.55 / 1.92, rel=0.03)
    assert _tip_width(0.55, True) >= 0.98 * _tip_width(1.92, True)


def test_tori_join_the_spines_near_the_shell_surface():
    """Eq. 12, Figure 7 top right: two concentric tori in the plane of the generating curve join
    a varix's spines "near the shell surface".  In the varix's plane, wherever a ray from the
    centre of the generating curve toward the outer side, where Table 1's spines stand (-90 to
    90 degrees, every 5), leaves the body whorl (those into the next whorl do not), the point
    where it leaves lies inside the varix.  Whorl 4's three spines alone leave gaps between
    them there; whorl 7's 18 touch each other."""
    body, varices = M.body_whorl(), M.varices()
    for k in (11, 20):  # whorls 4 and 7
        theta, whorl = varix_theta(k), (k - 1) // 3 + 1
        alone = M.place(M.varix(whorl, tori=False), theta)
        centre = world((0, 0, 0), theta)[0]
        t = np.linspace(0.0, 3.0 * spiral(theta)[2], 3001)
        exits = []
        for deg in range(-90, 91, 5):
            a = math.radians(deg)
            d = world((math.cos(a), math.sin(a), 0.0), theta)[0] - centre
            outside = body.field(centre + t[:, None] * d / np.linalg.norm(d)) < 0.5
            if outside.any():
                exits.append(centre + t[np.argmax(outside)] * d / np.linalg.norm(d))
        assert len(exits) >= 25, k
        assert np.all(varices[k - 1].field(np.array(exits)) >= 0.5), k
        if whorl == 4:
            assert np.sum(alone.field(np.array(exits)) < 0.5) >= 10


# --- bumps (Section 3.2, Figure 8) ---------------------------------------------------------------


def _bump_scales(parts) -> np.ndarray:
    out = []
    for part in parts:
        scale = next(n for n in part.walk() if isinstance(n, bt.Scale)
                     and isinstance(n.child, bt.Point))
        out.append(scale.factors)
    return np.array(out)


def test_bump_sizes_are_normal_about_s_with_s_over_10_and_z_plus_0_8():
    s = M.DEFAULT.bump_size
    zeta = _bump_scales(M.bumps(seed=11)) - (0.0, 0.0, 0.8)
    n = len(zeta)
    assert n == 300
    for d in range(3):  # mean within 4 standard errors, spread within 20 %
        assert abs(zeta[:, d].mean() - s) < 4 * (s / 10) / math.sqrt(n)
        assert zeta[:, d].std() == pytest.approx(s / 10, rel=0.2)
    np.testing.assert_allclose(_bump_scales(M.bumps(seed=None)), [[s, s, s + 0.8]] * n)


def test_five_bump_sets_evenly_between_successive_varices():
    for k in (4, 10, 19):
        parts = M.bumps(None, intervals=[k])
        per_set = len(parts) // 5
        thetas = []
        for j in range(5):
            lo, hi = parts[j * per_set].bounds()
            c = 0.5 * (lo + hi)
            thetas.append(math.degrees(math.atan2(-c[2], c[0])) % 360.0)
        step = np.diff(np.unwrap(np.radians([varix_theta(k), *thetas, varix_theta(k + 1)])))
        np.testing.assert_allclose(np.degrees(step), 116.0 / 6, atol=0.6)


def test_the_shell_joins_its_bumps_by_the_super_blend_n_400():
    """Section 3.2, Figure 8: the bumps join the rest of the shell by Eq. 4 with n = 400.
    Around the bumps of the last section the shell's field (before the opening) is
    (f_rest^400 + sum f_bump^400)^(1/400) of its parts' fields (Eq. 4 is associative, so the
    bumps' sum is their own super-elliptic blend), within 1 % of the largest of them: where
    neither the rest nor a bump reaches 0.5, nothing is filled; the sum (+, Figure 8 left)
    fills some of it."""
    shell = M.outer_shell(0, textured=False)
    assert isinstance(shell, bt.SuperBlend) and shell.n == 400
    rest, *lumps = shell.children
    assert len(lumps) == 300
    boxes = np.array([b.bounds() for b in lumps[-45:]])  # the last section's five sets of nine
    lo, hi = boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)
    P = np.random.default_rng(2).uniform(lo - 0.2 * (hi - lo), hi + 0.2 * (hi - lo), (20000, 3))
    f_rest = rest.field(P)
    f_lumps = bt.super_blend(*lumps, n=400).field(P)
    top = np.maximum(f_rest, f_lumps)
    safe = np.where(top > 0.0, top, 1.0)
    eq4 = top * ((f_rest / safe) ** 400 + (f_lumps / safe) ** 400) ** (1.0 / 400.0)
    np.testing.assert_allclose(shell.field(P), eq4, rtol=1e-9, atol=1e-12)
    gap = (f_rest < 0.5) & (bt.union(*lumps).field(P) < 0.5)
    assert gap.sum() > 1000
    assert np.all(eq4[gap] <= 1.01 * top[gap])
    assert np.mean(shell.field(P[gap]) >= 0.5) < 0.001
    assert np.mean(bt.blend(rest, *lumps).field(P[gap]) >= 0.5) > 0.01


# --- Table 2, Figure 9 ---------------------------------------------------------------------------


def _spine_base(spine: bt.Node, theta: float, length: float) -> float:
    """Arc length along the canal's centre line (:func:`canal_line`) of a straight canal spine's
    base, measured on its field in the plane of the generating curve at theta: the spine leans
    back up the canal toward the apex, so the lines normal to the canal meet its skeleton (field
    1) up to its base and no further; the base is the largest t whose normal line does, found on
    a grid of 0.01 and then of 0.0005."""
    u = np.linspace(0.0, 1.0, 401)

    def touches(ts: np.ndarray) -> np.ndarray:
        local = [canal_line(M.DEFAULT, t) for t in ts]
        pts = np.concatenate([p + u[:, None] * n for p, n in local])
        f = spine.field(world(np.c_[pts, np.zeros(len(pts))], theta)).reshape(len(ts), -1)
        return f.max(axis=1) >= 0.9999

    coarse = np.arange(0.0, length, 0.01)
    last = coarse[np.flatnonzero(touches(coarse))[-1]]
    fine = np.arange(last - 0.01, last + 0.02, 0.0005)
    return float(fine[np.flatnonzero(touches(fine))[-1]])


def test_canal_spines_follow_table_2_and_are_evenly_spaced():
    """Table 2's sizes, row by row, and Section 3.2's "placed at even intervals from each other
    along the canal": the bases of each row's spines, measured on their fields, lie at equal
    steps of arc length along the canal's centre line as the spec's keys describe it, to
    1 %."""
    spines = M.canal_spines(None)
    # the innermost scale of each spine (the outer one is Eq. 8's scale by D)
    sizes = [[n for n in s.walk() if isinstance(n, bt.Scale)][-1].factors for s in spines]
    assert all(f[0] == f[1] == f[2] for f in sizes)
    assert [f[0] for f in sizes] == [v for row in (1, 2, 3) for v in TABLE_2[row]]
    length, start = canal_length(M.DEFAULT), 0
    for row in (1, 2, 3):
        n = len(TABLE_2[row])
        at = [_spine_base(s, varix_theta(18 + row), length) for s in spines[start:start + n]]
        gaps = np.diff(at)
        assert np.all(gaps > 0) and np.ptp(gaps) < 0.01 * gaps.mean(), (row, at)
        start += n


def test_canal_spines_lie_in_the_planes_of_the_last_three_varices():
    """Section 3.2: the rows are placed by Eq. 8 "using the same angle at which the last three
    varices are formed": each straight spine is symmetric about the meridian plane of varix 19,
    20 or 21 (the lip), and not about one 0.1 degrees off."""
    spines = M.canal_spines(None)
    rng = np.random.default_rng(6)
    start = 0
    for row in (1, 2, 3):
        theta = varix_theta(18 + row)
        for s in spines[start:start + len(TABLE_2[row])]:
            lo, hi = s.bounds()
            P = rng.uniform(lo, hi, (3000, 3))
            f = s.field(P)
            P, f = P[f > 0.05], f[f > 0.05]
            assert len(P) > 20
            np.testing.assert_allclose(s.field(mirror(P, theta)), f, atol=1e-9)
            assert np.abs(s.field(mirror(P, theta + 0.1)) - f).max() > 1e-3
        start += len(TABLE_2[row])


# --- Sections 3.1 and 3.4: varices over the joins, texture seams under them ---------------------


def test_the_body_texture_seams_lie_under_the_varices():
    """A texture that does not tile (red = u): along the spiral its colour jumps once per
    section copy; every jump lies under a varix."""
    n = 64
    img = np.zeros((8, n, 3))
    img[:, :, 0] = (np.arange(n) + 0.5) / n
    body = M.body_whorl(texture=img)
    varices = M.varices()
    for k in (4, 10, 16):
        thetas = varix_theta(k) + np.linspace(-12.0, 12.0, 97)
        P = np.concatenate([world((1.0, 0.0, 0.0), t) for t in thetas])
        red = body.albedo(P)[:, 0]
        # u rises along the spiral except where it wraps: one run of falls, a texel or two wide
        # (the image is sampled bilinearly across the wrap)
        falls = np.flatnonzero(np.diff(red) < 0)
        assert np.all(np.diff(falls) == 1) and red[falls[0]] - red[falls[-1] + 1] > 0.8
        assert thetas[falls[-1] + 1] - thetas[falls[0]] < 2 * 116 / n + 0.5
        seam = 0.5 * (thetas[falls[0]] + thetas[falls[-1] + 1])
        assert abs(seam - varix_theta(k)) < 0.5
        # and the varix covers it: its own surface reaches past the body's there
        assert varices[k - 1].field(world((1.05, 0.0, 0.0), seam))[0] >= 0.5


# --- Section 3.3: Eq. 14 keeps the previous whorl ------------------------------------------------


def test_eq_14_previous_whorl_is_instances_94_to_108_as_the_body_builds_them():
    assert M.PREVIOUS_WHORL == (94, 108)
    prev = M.previous_whorl()
    assert sum(isinstance(n, bt.Point) for n in prev.walk()) == 15
    # the body's canal runs over its last four sections, instances 102..125: 102..108 here
    assert sum(isinstance(n, bt.Cone) for n in prev.walk()) == 7
    assert isinstance(M.opening(), bt.Difference) and M.opening().children[1] == prev


def test_the_opening_leaves_the_previous_whorl_solid():
    shell = M.murex(seed=0)
    for i in range(94, 109):
        theta = i * THETA_S
        ring = [(0.0, 0.0, 0.0)] + [(0.6 * math.cos(a), 0.6 * math.sin(a), 0.0)
                                    for a in np.radians(np.arange(0, 360, 45))]
        assert np.all(shell.field(world(ring, theta)) >= 0.5), i


def test_first_whorl_varices_are_a_flagged_choice():
    assert len(M.varices()) == 21
    no_first = M.varices(replace(M.DEFAULT, first_whorl_varices=False))
    assert len(no_first) == 18
    assert all(sum(isinstance(n, bt.Cone) for n in v.walk()) == 0 for v in M.varices()[:3])
