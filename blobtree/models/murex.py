"""The Murex cabritii shell of Section 3, as small functions named after the paper's parts.

Frames.  Every local part (generating surface, varix, bump, canal spine) is built in the frame
of the generating curve, in units of D(theta): x points away from the shell axis, z along the
spiral.  Eq. 8 as written grows the shell toward +y (H increases with theta), so the apex lies
at -y.  The paper's parts are described with +y toward the apex (Table 1's positive angles put
the spines of the upper whorls on their shoulders; the canal lies "below" the body whorl), so
they are drawn with that convention and turned by r(X, 180 deg) (:func:`to_shell_frame`) before
Eq. 8 places them.  Render with up = (0, -1, 0) to see the apex at the top, as in Figures 13-14.

Numbers the paper leaves unstated are gathered in :class:`Choices` (ours, each documented);
everything else (Eqs. 7-15, Tables 1-2, 348/116 deg, 6 instances, 30 deg bends, n = 400, ...)
is the paper's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..nodes import (
    Cone,
    Node,
    Point,
    Torus,
    blend,
    controlled_blend,
    difference,
    super_blend,
    union,
)
from ..texture import HelicoSurface
from .helico import MUREX_SPIRAL, place
from .shell_textures import SHELL_TEXTURES, VARIX_PALE, shell_textures
from .whorl import THETA_S

# ---------------------------------------------------------------------------------------------
# The paper's data
# ---------------------------------------------------------------------------------------------

#: Table 1: whorl -> [(angle alpha_i in degrees, relative size delta_i)] of the curving spines of
#: each of its three varices (Eqs. 11-12).  Whorl 1 has none.
TABLE_1: dict[int, list[tuple[float, float]]] = {
    1: [],
    2: [(50, 0.8)],
    3: [(50, 0.9)],
    4: [(40, 0.8), (50, 1.5), (60, 0.7)],
    5: [(20, 0.9), (30, 0.7), (40, 1.5), (50, 0.64), (60, 1.06)],
    6: [(-10, 0.55), (0, 0.8), (10, 1.55), (20, 0.64), (30, 0.7), (40, 0.55), (50, 0.96),
        (60, 0.6)],
    7: [(-90, 0.55), (-80, 0.64), (-70, 0.55), (-60, 1.14), (-50, 0.55), (-40, 1.92),
        (-30, 0.55), (-20, 0.82), (-10, 0.55), (0, 1.44), (10, 0.64), (20, 0.64), (30, 0.55),
        (40, 1.62), (50, 0.72), (60, 0.64), (70, 0.55), (80, 0.5)],
}

#: Table 2: varix (1-3: the last three, 3 at the opening) -> relative sizes of its axial canal
#: spines, from the body whorl toward the tip of the canal.
TABLE_2: dict[int, list[float]] = {
    1: [0.96, 0.92, 0.84, 0.68, 0.45, 0.25],
    2: [0.95, 0.99, 0.76, 0.51, 0.35, 0.28],
    3: [1.00, 0.90, 0.92, 0.70, 0.60],
}

WHORLS = 7  #: Section 3: seven whorls ...
WHORL_DEG = 348.0  #: ... of 348 deg each (estimated from Figure 13),
SECTION_DEG = 116.0  #: three sections between successive varices,
INSTANCES_PER_SECTION = 6  #: six instances of the generating surface per section,
# theta_s = 116/6 deg (Eq. 9) is THETA_S, shared with the whorl126 yardstick.
SECTIONS = 3 * WHORLS  #: 21 sections (Eq. 10),
INSTANCES = SECTIONS * INSTANCES_PER_SECTION  #: 126 instances, 0..125.
VARICES = SECTIONS  #: one varix at the end of every section, over the join with the next.
CANAL_SECTIONS = 4  #: the canal only in the last 1 1/3 whorls (Section 3.1).
SPINE_BEND = 30.0  #: curving spines: cones bent by 30 deg (Section 3.2).
DELTA_MAX = max(d for rows in TABLE_1.values() for _, d in rows)  #: delta_max of Eq. 12.
BUMP_SETS = 5  #: five sets of bumps between each pair of varices (Section 3.2).
BUMP_Z_EXTRA = 0.8  #: bumps scaled by (zeta_x, zeta_y, zeta_z + 0.8).
BUMP_BLEND_N = 400  #: super-elliptic blend of the bumps with the shell (Figure 8).
CANAL_SPINE_BENDS = (1, 3)  #: each canal spine bent one to three times ...
CANAL_SPINE_BEND_DEG = (3.0, 9.0)  #: ... by 3 to 9 deg (Figure 9).
PREVIOUS_WHORL = (94, 108)  #: B_w 94..108, kept intact by Eq. 14.
INNER_CANAL_CONES = 4  #: the inner canal: four slender cones (Section 3.3) ...
EXTENSION_CONES = 4  #: ... and four more reaching the previous whorl.

#: Albedo of the parts (Figure 13's cream shell, brownish spines, pink inside).
COLOURS = {
    "body": (0.93, 0.86, 0.74),
    "varix": (0.80, 0.66, 0.52),
    "bump": (0.62, 0.45, 0.34),
    "inside": (0.95, 0.78, 0.72),
}

#: Section 3.4: the bounding surface of texture (a), a tube around the spiral with one texture
#: copy per 116 deg section, each copy starting at a join between sections (half an instance
#: step before the section's first instance), so that its seams lie under the varices.  The
#: body's tube has radius 1.04-1.16 D (six points of radius 1.8 D per section, blended with the
#: neighbours), so S at 1.25 D bounds it with a short walk to S (steps of 0.1 D: the walk runs
#: nearly along the tube's normal, so the (u, v) found hardly depend on the step; a larger S or
#: finer steps cost more for no visible change).  theta_max: the model's extent along the spiral
#: (126 instances), which limits the whorls S looks through.
BODY_MAPPING = HelicoSurface(spiral=MUREX_SPIRAL, u_period=SECTION_DEG, u_start=-THETA_S / 2,
                             radius_factor=1.25, step=0.1, theta_max=INSTANCES * THETA_S)

#: The shell is seen with the apex up (the shell grows toward +y, so the apex is at -y) ...
SHELL_UP = (0.0, -1.0, 0.0)
#: ... from the side of the aperture (aperture on the right, as in Figure 14).
APERTURE_VIEW = (-0.86, 0.0, -0.72)

#: x of the shell axis in the local frame: -R / D (a constant, since D = 0.341 R by Eq. 7).
AXIS_X = -MUREX_SPIRAL.radius(0.0) / MUREX_SPIRAL.size(0.0)


@dataclass(frozen=True)
class Choices:
    """Values the paper leaves unstated: our choices, in local units (D(theta) = 1).

    Chosen to look like the shell of Figures 13-14; override any through ``murex(**kw)``.
    """

    #: Field radius of the generating point; six per section 116/6 deg apart then give a tube of
    #: radius about 1.08, so consecutive whorls (tangent at radius 1 by Eq. 3) just overlap.
    point_radius: float = 1.8
    #: Start of the canal cone (x, y) in the paper's frame (y toward the apex): under the point.
    canal_base: tuple[float, float] = (-0.35, -0.55)
    #: The canal leaves the generating surface tilted this far from "down" toward the axis and is
    #: bent back by the same angle to run parallel to the axis.
    canal_tilt: float = 55.0
    #: Distance between the straight end of the canal and the shell axis.
    canal_gap: float = 0.35
    #: Length of the straight end of the canal, after the bend.
    canal_straight: float = 2.0
    #: Field radii of the canal cone at its base and its tip.
    canal_radii: tuple[float, float] = (1.2, 0.5)
    #: x_k of Eq. 11 ("the distance to the edge of the shell") for a curving spine: from the
    #: centre of the generating surface to the spine's base, a little inside the body's surface
    #: (at about 1.08) so that the spine's thick base blends into the varix ridge.
    spine_offset: float = 0.85
    #: Length of a curving spine B_k before the scale by delta_i.
    spine_length: float = 1.2
    #: Field radii of a spine at base and tip (the tip grows as delta_max / delta_i: thick tops).
    spine_radii: tuple[float, float] = (0.5, 0.12)
    #: The two concentric tori of a varix: (major radius, field radius) each.
    tori: tuple[tuple[float, float], ...] = ((0.95, 0.35), (1.2, 0.25))
    #: s: the default size of a bump (field radius of its point before the zeta scale).
    bump_size: float = 0.35
    #: x_k of Eq. 11 for a bump: the paper places the bumps "using the same method" as the
    #: spines, with x_k "the distance to the edge of the shell"; what lies at that distance
    #: differs: a spine's base (spine_offset) but a bump's centre, put just inside the surface
    #: so that about half of each bump shows (at spine_offset, 0.85, most of a bump is buried).
    bump_offset: float = 0.95
    #: Length and field radii (base, tip) of an axial canal spine of relative size 1.
    canal_spine_length: float = 1.6
    canal_spine_radii: tuple[float, float] = (0.45, 0.1)
    #: Canal spines are spread evenly over this part of the canal's length (fractions).
    canal_spine_span: tuple[float, float] = (0.22, 0.8)
    #: Canal spines point away from the axis, tilted this many degrees toward the apex.
    canal_spine_tilt: float = 20.0
    #: Base of a canal spine: this fraction of the canal's field radius off its centre line.
    canal_spine_base: float = 0.42
    #: The inside generating surface (Section 3.3): point radius and canal radii as fractions.
    inside_scale: float = 0.8
    inner_canal_scale: float = 0.45
    #: Extension cones toward the previous whorl: field radii (base, tip) and reach past its
    #: surface.
    extension_radii: tuple[float, float] = (0.9, 0.5)
    extension_reach: float = 0.1
    #: Instances of the inside whorl: the hollow reaches this far back, and past the last
    #: instance (125) so that the aperture is open.
    inside_instances: tuple[int, int] = (112, 127)
    #: The inside wall (Eq. 15): a whorl of points of this fraction of point_radius, minus the
    #: hollow: it makes the opening round where the extension cones cut toward the previous whorl.
    wall_scale: float = 0.95
    #: Eq. 10 blends each section with its neighbours only; the canal spans 1 1/3 whorls
    #: (Section 3.1), so the new canal runs over the old one a whorl earlier, and every canal
    #: section's straight end runs near the axis.  True also blends every two canal sections,
    #: as a shell's canal is one piece; False keeps the neighbours-only list, where canal
    #: sheets that only touch leave closed tunnels whose ends break into small bubbles inside
    #: the solid (11 at 256 cells).
    canal_fuse: bool = True
    #: Whorl 1's three varices: Table 1 lists no spines for whorl 1 (the apex, where Figure 13
    #: shows low ridges), so they are the two tori of Eq. 12 alone; False leaves them out.
    first_whorl_varices: bool = True


DEFAULT = Choices()


# ---------------------------------------------------------------------------------------------
# Helpers
# ---------------------------------------------------------------------------------------------


def _sum(nodes: list[Node]) -> Node:
    """The blend (sum) of Eq. 9; a single node stands alone."""
    if not nodes:
        raise ValueError("nothing to blend")
    return nodes[0] if len(nodes) == 1 else blend(*nodes)


def _check_int(name: str, value: int, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not lo <= value <= hi:
        raise ValueError(f"{name} must be an integer in [{lo}, {hi}], got {value!r}")
    return int(value)


def _rng(seed: int | np.random.Generator) -> np.random.Generator:
    if isinstance(seed, np.random.Generator):
        return seed
    _check_int("seed", seed, 0, 2**63 - 1)
    return np.random.default_rng(seed)


def to_shell_frame(node: Node) -> Node:
    """r(X, 180): from the paper's local frame (+y toward the apex) to the one Eq. 8 expects."""
    return node.rotate("x", 180.0)


def about_axis(node: Node, degrees: float) -> Node:
    """Rotate a local part about the shell axis (x = AXIS_X): P(about_axis(B, a), t) is
    P(B, t + a) up to the growth of the spiral over a."""
    return node.translate(-AXIS_X, 0.0, 0.0).rotate("y", degrees).translate(AXIS_X, 0.0, 0.0)


def instance_angle(i: float) -> float:
    """theta_s * i of Eq. 9, in degrees (i need not be whole: i + 0.5 lies between instances)."""
    return THETA_S * i


def varix_angle(k: int) -> float:
    """Angle of varix k (1..21), every 116 deg (Eq. 13): over the join where section k-1 ends
    and section k begins, half an instance step after the last instance of section k-1
    (Section 3.1: each section lies between two successive varices; Section 3.4: the joins are
    covered by a varix).  Varix 21 closes the last section at the opening, where there is no
    join: it sits on the last instance, as past it the body's tube ends (half a step further,
    its spines would hang off the lip)."""
    k = _check_int("k", k, 1, VARICES)
    return instance_angle(min(INSTANCES_PER_SECTION * k - 0.5, INSTANCES - 1))


def whorl_of_varix(k: int) -> int:
    """The whorl (1..7) that varix k (1..21) ends a third of."""
    return (_check_int("k", k, 1, VARICES) - 1) // 3 + 1


def _check_whorl(whorl_index: int) -> int:
    return _check_int("whorl_index", whorl_index, 1, WHORLS)


# ---------------------------------------------------------------------------------------------
# Section 3.1: generating surface, whorls, main body whorl
# ---------------------------------------------------------------------------------------------


def _canal_geometry(c: Choices) -> tuple[float, float, float]:
    """(arc radius, arc length, total length) of the canal's centre line."""
    tilt = math.radians(c.canal_tilt)
    radius = (c.canal_base[0] - AXIS_X - c.canal_gap) / (1.0 - math.cos(tilt))
    arc = radius * tilt
    return radius, arc, arc + c.canal_straight


def canal_centreline(t: float, choices: Choices = DEFAULT) -> tuple[np.ndarray, np.ndarray]:
    """Point and unit tangent (x, y) at arc length t along the canal, in the paper's frame."""
    radius, arc, _ = _canal_geometry(choices)
    phi = min(t, arc) / radius
    p = np.array([radius * math.sin(phi), radius * (1.0 - math.cos(phi))])
    d = np.array([math.cos(phi), math.sin(phi)])
    p = p + max(t - arc, 0.0) * d
    # the cone frame (x along the canal, bending toward +y) turned by -(90 + tilt) about z
    psi = math.radians(-90.0 - choices.canal_tilt)
    rot = np.array([[math.cos(psi), -math.sin(psi)], [math.sin(psi), math.cos(psi)]])
    return rot @ p + np.asarray(choices.canal_base), rot @ d


def canal_cone(radius_a: float, radius_b: float, choices: Choices = DEFAULT) -> Node:
    """Figure 6: the warp-bent cone of the canal, in the paper's frame (from under the point,
    toward the axis, then straight down along it)."""
    c = choices
    radius, arc, length = _canal_geometry(c)
    cone = Cone((0.0, 0.0, 0.0), (length, 0.0, 0.0), radius_a=radius_a, radius_b=radius_b)
    return (
        cone.bend(c.canal_tilt, arc, axis="x", toward="y")
        .rotate("z", -90.0 - c.canal_tilt)
        .translate(c.canal_base[0], c.canal_base[1], 0.0)
    )


def generating_surface(canal: bool = False, choices: Choices = DEFAULT) -> Node:
    """B_g of Section 3.1 (Figure 6, left): a point primitive, with the bent canal cone below it
    when ``canal``; local frame, ready for Eq. 8."""
    point = Point(radius=choices.point_radius)
    if not canal:
        return point
    return point + to_shell_frame(canal_cone(*choices.canal_radii, choices=choices))


def whorl(a: int, b: int, generating: Node | None = None, choices: Choices = DEFAULT) -> Node:
    """Eq. 9: B_w a..b = sum_{i=a..b} P(B_g, theta_s i); B_g defaults to the plain point."""
    a = _check_int("a", a, 0, 10 * INSTANCES)
    b = _check_int("b", b, a, 10 * INSTANCES)
    g = generating_surface(choices=choices) if generating is None else generating
    return _sum([place(g, instance_angle(i)) for i in range(a, b + 1)])


def sections(canal_sections: int = CANAL_SECTIONS, choices: Choices = DEFAULT) -> list[Node]:
    """L_Blobtrees of Eq. 10: the 21 sections B_w i..i+5, i = 0, 6, ..., 120; the last
    ``canal_sections`` with the canal (4 = the last 1 1/3 whorls)."""
    canal_sections = _check_int("canal_sections", canal_sections, 0, SECTIONS)
    plain = generating_surface(False, choices)
    with_canal = generating_surface(True, choices)
    out = []
    for j in range(SECTIONS):
        g = with_canal if j >= SECTIONS - canal_sections else plain
        i = INSTANCES_PER_SECTION * j
        out.append(whorl(i, i + INSTANCES_PER_SECTION - 1, g))
    return out


def body_whorl(canal_sections: int = CANAL_SECTIONS, choices: Choices = DEFAULT,
               texture: np.ndarray | None = None) -> Node:
    """Eq. 10: B_m = c(L_blendpairs)(L_Blobtrees): each section blends with its two neighbours
    along the spiral only, so adjacent whorls do not blend.  With ``texture`` (Figure 12(a)),
    each section is textured separately by the bounding surface :data:`BODY_MAPPING`
    (Section 3.4); the joins lie under the varices."""
    secs = sections(canal_sections, choices)
    if texture is not None:
        wrap = SHELL_TEXTURES["body"].wrap
        secs = [s.texture(texture, mapping=BODY_MAPPING, wrap=wrap) for s in secs]
    return controlled_blend(secs, pairs=blend_pairs(canal_sections, choices.canal_fuse))


def blend_pairs(canal_sections: int = CANAL_SECTIONS, canal_fuse: bool = True
                ) -> list[tuple[int, int]]:
    """L_blendpairs of Eq. 10: each section with the next along the spiral; with
    ``canal_fuse`` (see :class:`Choices`), also every two canal sections."""
    neighbours = [(j, j + 1) for j in range(SECTIONS - 1)]
    if not canal_fuse:
        return neighbours
    canal = range(SECTIONS - canal_sections, SECTIONS)
    return neighbours + [(i, j) for i in canal for j in canal if j > i + 1]


# ---------------------------------------------------------------------------------------------
# Section 3.2: varices, bumps, canal spines
# ---------------------------------------------------------------------------------------------


def spine(delta: float, thick_top: bool = True, widen: bool = True,
          choices: Choices = DEFAULT) -> Node:
    """T_k(B_ki) of Eq. 12 before r(Z, alpha_i): a cone on +x from the origin, bent 30 deg
    toward +y, its top thicker the shorter it is, scaled by (delta, delta, delta_max) (by delta
    alone unless ``widen``), moved out to x_k."""
    if not (math.isfinite(delta) and delta > 0.0):
        raise ValueError(f"delta must be a finite number > 0, got {delta!r}")
    c = choices
    base, tip = c.spine_radii
    if thick_top:
        tip *= DELTA_MAX / delta
    cone = Cone((0.0, 0.0, 0.0), (c.spine_length, 0.0, 0.0), radius_a=base, radius_b=tip)
    bent = cone.bend(SPINE_BEND, c.spine_length, axis="x", toward="y")
    return bent.scale(delta, delta, DELTA_MAX if widen else delta).translate(
        c.spine_offset, 0.0, 0.0
    )


def varix_spines(whorl_index: int, thick_tops: bool = True, widen: bool = True,
                 choices: Choices = DEFAULT) -> list[Node]:
    """B_s of Eqs. 11-12: the spines r(Z, alpha_i)(T_k(B_ki)) of Table 1 for this whorl, in the
    paper's frame."""
    rows = TABLE_1[_check_whorl(whorl_index)]
    return [spine(d, thick_tops, widen, choices).rotate("z", a) for a, d in rows]


def varix_tori(choices: Choices = DEFAULT) -> list[Node]:
    """B_r of Eq. 12: two concentric tori in the plane of the generating curve."""
    return [Torus(major_radius=m, radius=r).rotate("x", 90.0) for m, r in choices.tori]


def varix(whorl_index: int, tori: bool = True, thick_tops: bool = True, widen: bool = True,
          choices: Choices = DEFAULT, tori_rgb: np.ndarray | None = None) -> Node:
    """Eq. 12: B_v = B_s + B_r for a varix of this whorl (Table 1, Figure 7), local frame, ready
    for Eq. 13.  The flags switch off the stages of Figure 7; ``tori_rgb`` paints the tori (so
    that a texture of the whole varix paints only its spines)."""
    parts = varix_spines(whorl_index, thick_tops, widen, choices)
    if tori:
        parts += [t if tori_rgb is None else t.color(tori_rgb) for t in varix_tori(choices)]
    if not parts:
        raise ValueError(
            f"whorl_index {whorl_index} has no spines in Table 1: its varix needs tori=True"
        )
    return to_shell_frame(_sum(parts))


def varices(choices: Choices = DEFAULT, texture: np.ndarray | None = None) -> list[Node]:
    """Eq. 13: B_v placed by Eq. 8 at every 116 deg over the joins of the sections, three per
    whorl (21 in all; whorl 1's without spines, see :class:`Choices`).  With ``texture``
    (Figure 12(b)), field-interpolated on the spines' cones (Section 3.4), the tori painted in
    the texture's pale ground colour."""
    first = 1 if choices.first_whorl_varices else 4
    if texture is None:
        return [place(varix(whorl_of_varix(k), choices=choices), varix_angle(k))
                for k in range(first, VARICES + 1)]
    wrap = SHELL_TEXTURES["varix_spine"].wrap
    return [
        place(varix(whorl_of_varix(k), choices=choices, tori_rgb=VARIX_PALE).texture(
            texture, wrap=wrap), varix_angle(k))
        for k in range(first, VARICES + 1)
    ]


def bump_set(whorl_index: int, theta: float, rng: np.random.Generator | None = None,
             choices: Choices = DEFAULT) -> list[Node]:
    """One set of bumps (Figure 8) at angle theta: a point per second curving spine of the whorl,
    scaled by (zeta_x, zeta_y, zeta_z + 0.8), zeta ~ N(s, s/10) (all s without ``rng``), placed
    like the spines (Eq. 11) and by Eq. 8."""
    s = choices.bump_size
    out = []
    for alpha, _ in TABLE_1[_check_whorl(whorl_index)][::2]:
        zeta = rng.normal(s, s / 10.0, 3) if rng is not None else np.full(3, s)
        bump = (
            Point(radius=1.0)
            .scale(zeta[0], zeta[1], zeta[2] + BUMP_Z_EXTRA)
            .translate(choices.bump_offset, 0.0, 0.0)
            .rotate("z", alpha)
        )
        out.append(place(to_shell_frame(bump), theta))
    return out


def bumps(seed: int | np.random.Generator | None = 0, intervals: range | list[int] | None = None,
          choices: Choices = DEFAULT) -> list[Node]:
    """Section 3.2: five sets of bumps between varix k and k + 1 (k in ``intervals``, default
    1..20), evenly spaced over section k: the varices lie 6 instance steps apart, and the sets
    one step apart between them (half-way between the section's instances); random sizes unless
    ``seed`` is None."""
    rng = None if seed is None else _rng(seed)
    ks = range(1, VARICES) if intervals is None else intervals
    out = []
    for k in ks:
        k = _check_int("intervals", k, 1, VARICES - 1)
        w = k // 3 + 1
        for m in range(BUMP_SETS):
            out += bump_set(w, instance_angle(INSTANCES_PER_SECTION * k + m + 0.5), rng, choices)
    return out


def canal_spine(size: float, rng: np.random.Generator | None = None,
                choices: Choices = DEFAULT) -> Node:
    """An axial canal spine of relative ``size`` (Table 2): a cone on +x from the origin, bent
    1-3 times by 3-9 deg toward random directions at random places when ``rng`` is given."""
    if not (math.isfinite(size) and size > 0.0):
        raise ValueError(f"size must be a finite number > 0, got {size!r}")
    length = choices.canal_spine_length
    node: Node = Cone((0.0, 0.0, 0.0), (length, 0.0, 0.0), radius_a=choices.canal_spine_radii[0],
                      radius_b=choices.canal_spine_radii[1])
    if rng is not None:
        lo, hi = CANAL_SPINE_BENDS
        for _ in range(int(rng.integers(lo, hi + 1))):
            degrees = rng.uniform(*CANAL_SPINE_BEND_DEG)
            towards = rng.uniform(0.0, 360.0)
            start = rng.uniform(0.0, 0.6) * length
            node = (
                node.translate(-start, 0.0, 0.0)
                .rotate("x", towards)
                .bend(degrees, length - start, axis="x", toward="y")
                .rotate("x", -towards)
                .translate(start, 0.0, 0.0)
            )
    return node.scale(size)


def canal_spine_frames(row: int, choices: Choices = DEFAULT) -> list[tuple[np.ndarray, float]]:
    """(base (x, y), direction in degrees) in the paper's frame of each spine of a Table 2 row,
    evenly spaced along the canal."""
    row = _check_int("row", row, 1, 3)
    c = choices
    _, _, length = _canal_geometry(c)
    n = len(TABLE_2[row])
    out = []
    for j in range(n):
        t = length * (c.canal_spine_span[0] + (c.canal_spine_span[1] - c.canal_spine_span[0])
                      * j / (n - 1))
        p, d = canal_centreline(t, c)
        normal = np.array([-d[1], d[0]]) if d[1] < 0 else np.array([d[1], -d[0]])
        r = c.canal_radii[0] + (c.canal_radii[1] - c.canal_radii[0]) * t / length
        base = p + c.canal_spine_base * r * normal
        out.append((base, math.degrees(math.atan2(normal[1], normal[0])) + c.canal_spine_tilt))
    return out


def canal_spines(seed: int | np.random.Generator | None = 0,
                 choices: Choices = DEFAULT) -> list[Node]:
    """Section 3.2, Table 2, Figure 9: three axial rows of spines on the canal, below the last
    three varices, placed by Eq. 8 at their angles; straight when ``seed`` is None."""
    rng = None if seed is None else _rng(seed)
    out = []
    for row, sizes in TABLE_2.items():
        theta = varix_angle(VARICES - 3 + row)
        for size, (base, direction) in zip(sizes, canal_spine_frames(row, choices), strict=True):
            local = canal_spine(size, rng, choices).rotate("z", direction).translate(
                base[0], base[1], 0.0
            )
            out.append(place(to_shell_frame(local), theta))
    return out


# ---------------------------------------------------------------------------------------------
# Section 3.3: the opening
# ---------------------------------------------------------------------------------------------


def previous_whorl_offset() -> np.ndarray:
    """Centre of the generating curve one turn (360 deg) earlier, in the local frame: constant,
    as the spiral is self-similar."""
    s = MUREX_SPIRAL
    d = s.size(360.0)
    return np.array([s.radius(0.0) - s.radius(360.0), s.height(0.0) - s.height(360.0), 0.0]) / d


def inside_generating_surface(choices: Choices = DEFAULT) -> Node:
    """Section 3.3, Figure 10 left: a slightly smaller point, four slender inner-canal cones
    bent like the canal and four cones reaching the previous whorl, each four spread over the
    interval theta_s between instances."""
    c = choices
    inner = to_shell_frame(canal_cone(*(c.inner_canal_scale * r for r in c.canal_radii), c))
    offset = previous_whorl_offset()
    distance = float(np.linalg.norm(offset))
    reach = distance - 1.0 / MUREX_SPIRAL.rho + c.extension_reach
    extension = Cone((0.0, 0.0, 0.0), tuple(offset * reach / distance),
                     radius_a=c.extension_radii[0], radius_b=c.extension_radii[1])
    fans = [
        about_axis(cone, THETA_S * j / count)
        for cone, count in ((inner, INNER_CANAL_CONES), (extension, EXTENSION_CONES))
        for j in range(count)
    ]
    return blend(Point(radius=c.inside_scale * c.point_radius), *fans)


def inside_whorl(choices: Choices = DEFAULT) -> Node:
    """B_inside of Eq. 14 (Figure 10 centre): the whorl of the inside generating surface."""
    a, b = choices.inside_instances
    return whorl(a, b, inside_generating_surface(choices))


def previous_whorl(choices: Choices = DEFAULT) -> Node:
    """B_w 94..108 of Eq. 14 as the body builds it: Eq. 9's sum of the instances 94 to 108 of
    the body's generating surface, with the canal on the instances of the sections that have
    one (from instance 102), so that the opening cuts nothing of it."""
    a, b = PREVIOUS_WHORL
    canal_from = INSTANCES_PER_SECTION * (SECTIONS - CANAL_SECTIONS)
    plain, with_canal = generating_surface(False, choices), generating_surface(True, choices)
    return _sum([place(with_canal if i >= canal_from else plain, instance_angle(i))
                 for i in range(a, b + 1)])


def opening(choices: Choices = DEFAULT) -> Node:
    """Eq. 14: B_opening = B_inside - B_w 94..108 (Figure 10 right): the previous whorl is kept."""
    return difference(inside_whorl(choices), previous_whorl(choices))


def inside_wall(choices: Choices = DEFAULT) -> Node:
    """B_inside_wall of Eq. 15 (Figure 11 right): a wall around the round hollow of the inside
    point, up to the last instance, that refills what the extension cones cut."""
    c = choices
    a, b = c.inside_instances
    last = INSTANCES - 1
    wall = whorl(a, last, Point(radius=c.wall_scale * c.point_radius))
    hollow = whorl(a, b, Point(radius=c.inside_scale * c.point_radius))
    return difference(wall, hollow)


# ---------------------------------------------------------------------------------------------
# The whole shell
# ---------------------------------------------------------------------------------------------


def shell(seed: int = 0, choices: Choices = DEFAULT, textured: bool = True) -> Node:
    """B_shell: the main body whorl with its varices and canal spines blended in, and the bumps
    joined by the super-elliptic blend n = 400 (Section 3.2).

    ``textured``: the four textures of Figure 12 (generated from ``seed``) by the paper's two
    methods (Section 3.4): (a) per section by a bounding surface, (b)-(d) on the varix spines,
    bumps and canal spines, field-interpolated; otherwise plain :data:`COLOURS`.  The geometry
    is the same either way."""
    bump_seq, spine_seq = np.random.SeedSequence(_check_int("seed", seed, 0, 2**63 - 1)).spawn(2)
    bump_rng, spine_rng = np.random.default_rng(bump_seq), np.random.default_rng(spine_seq)
    if not textured:
        body = body_whorl(choices=choices).color(COLOURS["body"])
        spiny = [v.color(COLOURS["varix"]) for v in varices(choices) + canal_spines(spine_rng,
                                                                                     choices)]
        lumps = [b.color(COLOURS["bump"]) for b in bumps(bump_rng, choices=choices)]
        return super_blend(blend(body, *spiny), *lumps, n=BUMP_BLEND_N)
    tex = shell_textures(seed)
    body = body_whorl(choices=choices, texture=tex["body"])
    canal_wrap, bump_wrap = SHELL_TEXTURES["canal_spine"].wrap, SHELL_TEXTURES["bump"].wrap
    spiny = varices(choices, tex["varix_spine"]) + [
        s.texture(tex["canal_spine"], wrap=canal_wrap) for s in canal_spines(spine_rng, choices)]
    lumps = [b.texture(tex["bump"], wrap=bump_wrap) for b in bumps(bump_rng, choices=choices)]
    return super_blend(blend(body, *spiny), *lumps, n=BUMP_BLEND_N)


def murex(seed: int = 0, inside: bool = True, textured: bool = True,
          **choices: float) -> Node:
    """The whole Murex cabritii shell (Figure 14), Eq. 15:
    B_murex = (B_shell - B_opening) U B_inside_wall.

    ``seed`` drives the bump sizes, canal spine bends and textures; ``inside=False`` stops at
    Eq. 14 (no inside wall, Figure 11 left); ``textured=False`` paints the parts in plain
    :data:`COLOURS` instead of the textures of Section 3.4 (the inside stays plain either way);
    keyword arguments override fields of :class:`Choices`.
    """
    allowed = sorted(Choices.__dataclass_fields__)
    unknown = sorted(set(choices) - set(allowed))
    if unknown:
        raise ValueError(f"unknown choice(s) {unknown}; allowed: {allowed}")
    c = replace(DEFAULT, **choices)
    carved = difference(shell(seed, c, textured), opening(c).color(COLOURS["inside"]))
    if inside:
        carved = union(carved, inside_wall(c).color(COLOURS["inside"]))
    return carved.shown(up=SHELL_UP, view=APERTURE_VIEW)
