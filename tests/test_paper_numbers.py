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

pytestmark = pytest.mark.slow  # builds whole parts of the shell

M = importlib.import_module("blobtree.models.murex")

# --- Eq. 7 and Tables 1-2, as printed ---------------------------------------------------------
BETA, RHO, R0 = 22.5, 1.3, 0.2
THETA_S = 116.0 / 6.0  # Section 3.1: six instances per 116-degree section
DELTA_MAX = 1.92  # the largest delta of Table 1 (whorl 7, -40 degrees)
TABLE_2 = {1: [0.96, 0.92, 0.84, 0.68, 0.45, 0.25], 2: [0.95, 0.99, 0.76, 0.51, 0.35, 0.28],
           3: [1.00, 0.90, 0.92, 0.70, 0.60]}


def spiral(theta: float) -> tuple[float, float, float]:
    """Eqs. 1-3 with the parameters of Eq. 7: R, H and D at theta (degrees)."""
    r = R0 * RHO ** (theta / 360.0)
    return r, r / math.tan(math.radians(BETA)), 0.341 * r


def world(local, theta: float) -> np.ndarray:
    """Eq. 8 after the paper-frame turn r(X, 180): local (x, y, z) in units of D -> world."""
    p = np.atleast_2d(np.asarray(local, float)) * (1.0, -1.0, -1.0)
    r, h, d = spiral(theta)
    p = p * d + (r, h, 0.0)
    c, s = math.cos(math.radians(theta)), math.sin(math.radians(theta))
    return np.stack([c * p[:, 0] + s * p[:, 2], p[:, 1], -s * p[:, 0] + c * p[:, 2]], axis=1)


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
    # every varix lies 116 degrees after the previous one (Section 3.2)
    angles = [M.varix_angle(k) for k in range(1, 21)]
    assert np.diff(angles) == pytest.approx([116.0] * 19)


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


def test_shorter_spines_have_thicker_tops():
    """Figure 7: the tip's field radius grows as delta_max / delta, so in the spine's own units
    (before the scale by delta) a short spine's tip is thicker by that ratio."""
    c = M.DEFAULT
    k = math.radians(30.0) / c.spine_length
    widths = {}
    for delta in (0.55, 1.92):
        s = M.spine(delta, thick_top=True, widen=False)
        tip = np.array([c.spine_offset + delta * math.sin(math.radians(30)) / k,
                        delta * (1 - math.cos(math.radians(30))) / k, 0.0])
        widths[delta] = crossing(s, tip, (0, 0, 1), 1.0) / delta
        # a lone cone end: the surface lies at half the tip's field radius (soft object)
        assert widths[delta] == pytest.approx(0.5 * c.spine_radii[1] * DELTA_MAX / delta,
                                              rel=0.02)
    assert widths[0.55] / widths[1.92] == pytest.approx(1.92 / 0.55, rel=0.03)


def test_tori_join_the_spines_in_a_ridge():
    """Figure 7, top right: the two concentric tori make a ring in the plane of the generating
    curve, through the spines near the shell surface; without them the varix is its spines."""
    for w in (4, 7):
        alone, ridge = M.varix(w, tori=False), M.varix(w, tori=True)
        spines = [a for a, _ in M.TABLE_1[w]]
        for r in (1.0, 1.2):
            for deg in range(0, 360, 15):
                a = math.radians(deg)
                # the paper's frame, turned by r(X, 180) as the varix is
                p = np.array([[r * math.cos(a), -r * math.sin(a), 0.0]])
                assert ridge.field(p)[0] >= 0.5, (w, r, deg)
                if min(abs((deg - b + 180) % 360 - 180) for b in spines) >= 30:
                    assert alone.field(p)[0] < 0.5, (w, r, deg)


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
        step = np.diff(np.unwrap(np.radians([M.varix_angle(k), *thetas,
                                             M.varix_angle(k + 1)])))
        np.testing.assert_allclose(np.degrees(step), 116.0 / 6, atol=0.6)


def test_the_super_blend_keeps_bumps_from_melting_into_the_whorl():
    """Figure 8: with +, the whorl's surface rises smoothly around each bump; with the
    super-elliptic blend n = 400 (nearly the union) nothing is filled where neither the whorl nor
    the bump alone reaches 0.5."""
    k = 19
    i = 6 * k
    base = M.whorl(i - 2, i + 8)
    lumps = M.bumps(None, intervals=[k])
    plus = bt.blend(base, *lumps)
    diamond = bt.super_blend(base, *lumps, n=400)
    lo, hi = lumps[0].bounds()
    P = np.random.default_rng(2).uniform(lo - 0.2 * (hi - lo), hi + 0.2 * (hi - lo), (20000, 3))
    fb, fl = base.field(P), bt.blend(*lumps).field(P)
    gap = (fb < 0.5) & (fl < 0.5)
    assert gap.sum() > 1000
    assert np.all(diamond.field(P[gap]) < 0.5)
    assert np.mean(plus.field(P[gap]) >= 0.5) > 0.02


# --- Table 2, Figure 9 ---------------------------------------------------------------------------


def test_canal_spines_follow_table_2_and_are_evenly_spaced():
    spines = M.canal_spines(None)
    # the innermost scale of each spine (the outer one is Eq. 8's scale by D)
    sizes = [[n for n in s.walk() if isinstance(n, bt.Scale)][-1].factors for s in spines]
    assert all(f[0] == f[1] == f[2] for f in sizes)
    sizes = [f[0] for f in sizes]
    assert sizes == [v for row in (1, 2, 3) for v in TABLE_2[row]]
    # along the canal's centre line, the spines of a row lie at even intervals
    ts = np.linspace(0.0, M._canal_geometry(M.DEFAULT)[2], 4001)
    line = np.array([M.canal_centreline(t)[0] for t in ts])
    for row in (1, 2, 3):
        bases = np.array([b for b, _ in M.canal_spine_frames(row)])
        at = [ts[np.argmin(np.linalg.norm(line - b, axis=1))] for b in bases]
        gaps = np.diff(at)
        assert np.ptp(gaps) < 0.01 * gaps.mean()


def test_canal_spines_sit_below_the_last_three_varices():
    spines = M.canal_spines(None)
    start = 0
    for row in (1, 2, 3):
        theta = M.varix_angle(18 + row)
        for s in spines[start:start + len(TABLE_2[row])]:
            lo, hi = s.bounds()
            c = 0.5 * (lo + hi)
            phi = math.degrees(math.atan2(-c[2], c[0])) % 360.0
            assert abs((phi - theta + 180.0) % 360.0 - 180.0) < 6.0
        start += len(TABLE_2[row])


# --- Sections 3.1 and 3.4: varices over the joins, texture seams under them ---------------------


def test_every_varix_lies_over_a_join_of_two_sections():
    for k in range(1, 21):
        # section k - 1 ends with instance 6k - 1, section k starts with 6k
        assert M.varix_angle(k) == pytest.approx((6 * k - 0.5) * THETA_S)
    assert M.varix_angle(21) == pytest.approx(125 * THETA_S)  # the lip, at the opening


def test_the_body_texture_seams_lie_under_the_varices():
    """A texture that does not tile (red = u): along the spiral its colour jumps once per
    section copy; every jump lies under a varix."""
    n = 64
    img = np.zeros((8, n, 3))
    img[:, :, 0] = (np.arange(n) + 0.5) / n
    body = M.body_whorl(texture=img)
    for k in (4, 10, 16):
        thetas = M.varix_angle(k) + np.linspace(-12.0, 12.0, 97)
        P = np.concatenate([world((1.0, 0.0, 0.0), t) for t in thetas])
        red = body.albedo(P)[:, 0]
        # u rises along the spiral except where it wraps: one run of falls, a texel or two wide
        # (the image is sampled bilinearly across the wrap)
        falls = np.flatnonzero(np.diff(red) < 0)
        assert np.all(np.diff(falls) == 1) and red[falls[0]] - red[falls[-1] + 1] > 0.8
        assert thetas[falls[-1] + 1] - thetas[falls[0]] < 2 * 116 / n + 0.5
        seam = 0.5 * (thetas[falls[0]] + thetas[falls[-1] + 1])
        assert abs(seam - M.varix_angle(k)) < 0.5
        # and the varix covers it: its own surface reaches past the body's there
        v = M.place(M.varix(M.whorl_of_varix(k)), M.varix_angle(k))
        assert v.field(world((1.05, 0.0, 0.0), seam))[0] >= 0.5


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
