"""The shell of Section 3, as small functions named after the paper's parts, each driven by a
:class:`~blobtree.models.spec.ShellSpec` (``spec``, the Murex cabritii's by default).

Frames.  Every local part (generating surface, varix, bump, canal spine) is built in the frame
of the generating curve, in units of D(theta): x points away from the shell axis, z along the
spiral.  Eq. 8 as written grows the shell toward +y (H increases with theta), so the apex lies
at -y.  The paper's parts are described with +y toward the apex (Table 1's positive angles put
the spines of the upper whorls on their shoulders; the canal lies "below" the body whorl), so
they are drawn with that convention and turned by r(X, 180 deg) (:func:`to_shell_frame`) before
Eq. 8 places them.  Render with up = (0, -1, 0) to see the apex at the top, as in Figures 13-14.

The Murex's numbers live in ``species/murex.toml`` (the paper's data, Eqs. 7-15, Tables 1-2,
348/116 deg, 6 instances, 30 deg bends, n = 400, ..., and the values it leaves unstated, ours,
each documented there); the constants below are read from it.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from types import MappingProxyType

import numpy as np

from ..checks import Integer, frozen
from ..helico import place
from ..nodes import (
    Cone,
    Node,
    Point,
    Torus,
    blend,
    controlled_blend,
    difference,
    gradient_blend,
    super_blend,
    union,
)
from ..texture import pigment
from ..texture.mapping import HelicoSurface
from ..texture.shell import SHELL_TEXTURES, VARIX_PALE, shell_textures
from .age import Growth, grown, varix_position
from .growth import grown_varices
from .parts import FRESH, Parts
from .spec import SHELLS, ShellSpec, load_spec

# ---------------------------------------------------------------------------------------------
# The paper's data (species/murex.toml)
# ---------------------------------------------------------------------------------------------

#: The Murex cabritii's spec: the default of every function here.
DEFAULT = SHELLS["murex"]

#: Table 1: whorl -> [(angle alpha_i in degrees, relative size delta_i)] of the curving spines of
#: each of its three varices (Eqs. 11-12).  Whorl 1 has none.
TABLE_1: dict[int, list[tuple[float, float]]] = {
    w: list(row) for w, row in enumerate(DEFAULT.table_1, 1)}
#: Table 2: varix (1-3: the last three, 3 at the opening) -> relative sizes of its axial canal
#: spines, from the body whorl toward the tip of the canal.
TABLE_2: dict[int, list[float]] = {v: list(row) for v, row in enumerate(DEFAULT.table_2, 1)}
WHORLS = DEFAULT.whorls  #: Section 3: seven whorls ...
WHORL_DEG = DEFAULT.whorl_deg  #: ... of 348 deg each (estimated from Figure 13),
SECTION_DEG = DEFAULT.section_deg  #: three sections between successive varices,
THETA_S = DEFAULT.theta_s  #: six instances per section, 116/6 deg apart (Eq. 9),
SECTIONS = DEFAULT.sections  #: 21 sections (Eq. 10),
INSTANCES = DEFAULT.instances  #: 126 instances, 0..125,
VARICES = SECTIONS  #: one varix at the end of every section, over the join with the next.
CANAL_SECTIONS = DEFAULT.canal_sections  #: the canal only in the last 1 1/3 whorls (Sec. 3.1).
BUMP_BLEND_N = DEFAULT.bump_blend_n  #: super-elliptic blend of the bumps (Figure 8).
#: The gradient-based join of the bumps (ours) blends only where both fields exceed this.
GRADIENT_CONTACT = 0.4
PREVIOUS_WHORL = DEFAULT.previous_whorl  #: B_w 94..108, kept intact by Eq. 14.
#: Albedo of the parts (Figure 13's cream shell, brownish spines, pink inside).
COLOURS = dict(zip(("body", "varix", "bump", "inside"), DEFAULT.colours, strict=True))
#: The shell is seen with the apex up (the shell grows toward +y, so the apex is at -y) ...
SHELL_UP = DEFAULT.up
#: ... from the side of the aperture (aperture on the right, as in Figure 14).
APERTURE_VIEW = DEFAULT.view
#: x of the shell axis in the local frame: -R / D (a constant, since D = 0.341 R by Eq. 7).
AXIS_X = DEFAULT.axis_x


def body_mapping(spec: ShellSpec = DEFAULT, period: float | None = None) -> HelicoSurface:
    """Section 3.4: the bounding surface of texture (a), a tube around the spiral with one
    texture copy per section (``period`` degrees; the whole spiral for a grown pattern), each
    copy starting at a join between sections (half an instance step before the section's first
    instance), so that its seams lie under the varices.  The body's tube has radius 1.04-1.16 D
    (six points of radius 1.8 D per section, blended with the neighbours), so S at 1.25 D bounds
    it with a short walk to S (steps of 0.1 D: the walk runs nearly along the tube's normal, so
    the (u, v) found hardly depend on the step; a larger S or finer steps cost more for no
    visible change).  theta_max: the model's extent along the spiral, which limits the whorls S
    looks through.  An oval generating point (``point_scale``) keeps the round tube: the short
    walks from its flanks still find (u, v) that vary smoothly over the surface."""
    extent = spec.instances * spec.theta_s
    return HelicoSurface(spiral=spec.spiral, u_period=period or spec.section_deg,
                         u_start=-spec.theta_s / 2, radius_factor=1.25, step=0.1,
                         theta_max=extent)


# ---------------------------------------------------------------------------------------------
# Helpers
# ---------------------------------------------------------------------------------------------


def _sum(nodes: list[Node]) -> Node:
    """The blend (sum) of Eq. 9; a single node stands alone."""
    if not nodes:
        raise ValueError("nothing to blend")
    return nodes[0] if len(nodes) == 1 else blend(*nodes)


def _check_int(name: str, value: int, lo: int, hi: int) -> int:
    return Integer(lo, hi).check(name, value)


def _rng(seed: int | np.random.Generator) -> np.random.Generator:
    if isinstance(seed, np.random.Generator):
        return seed
    _check_int("seed", seed, 0, 2**63 - 1)
    return np.random.default_rng(seed)


def to_shell_frame(node: Node) -> Node:
    """r(X, 180): from the paper's local frame (+y toward the apex) to the one Eq. 8 expects."""
    return node.rotate("x", 180.0)


def about_axis(node: Node, degrees: float, spec: ShellSpec = DEFAULT) -> Node:
    """Rotate a local part about the shell axis (x = -R / D): P(about_axis(B, a), t) is
    P(B, t + a) up to the growth of the spiral over a."""
    x = spec.axis_x
    return node.translate(-x, 0.0, 0.0).rotate("y", degrees).translate(x, 0.0, 0.0)


def instance_angle(i: float, spec: ShellSpec = DEFAULT) -> float:
    """theta_s * i of Eq. 9, in degrees (i need not be whole: i + 0.5 lies between instances)."""
    return spec.theta_s * i


def varix_angle(k: int, spec: ShellSpec = DEFAULT) -> float:
    """Angle of varix k (1..21 for the Murex), every 116 deg (Eq. 13): over the join where
    section k-1 ends and section k begins, half an instance step after the last instance of
    section k-1 (Section 3.1: each section lies between two successive varices; Section 3.4: the
    joins are covered by a varix).  The last varix closes the last section at the opening, where
    there is no join: it sits on the last instance, as past it the body's tube ends (half a step
    further, its spines would hang off the lip)."""
    return instance_angle(varix_position(_check_int("k", k, 1, spec.sections), spec), spec)


def whorl_of_varix(k: int, spec: ShellSpec = DEFAULT) -> int:
    """The whorl (1..7 for the Murex) that varix k ends a section of."""
    return (_check_int("k", k, 1, spec.sections) - 1) // spec.sections_per_whorl + 1


def _check_whorl(whorl_index: int, spec: ShellSpec) -> int:
    return _check_int("whorl_index", whorl_index, 1, spec.whorls)


# ---------------------------------------------------------------------------------------------
# Section 3.1: generating surface, whorls, main body whorl
# ---------------------------------------------------------------------------------------------


def _canal_geometry(spec: ShellSpec) -> tuple[float, float, float]:
    """(arc radius, arc length, total length) of the canal's centre line."""
    tilt = math.radians(spec.canal_tilt)
    radius = (spec.canal_base[0] - spec.axis_x - spec.canal_gap) / (1.0 - math.cos(tilt))
    if radius <= 0.0:
        raise ValueError(f"canal.base x ({spec.canal_base[0]}) must lie farther than canal.gap "
                         f"({spec.canal_gap}) from the shell axis (x = {spec.axis_x:.4g})")
    arc = radius * tilt
    return radius, arc, arc + spec.canal_straight


def canal_centreline(t: float, spec: ShellSpec = DEFAULT) -> tuple[np.ndarray, np.ndarray]:
    """Point and unit tangent (x, y) at arc length t along the canal, in the paper's frame."""
    radius, arc, _ = _canal_geometry(spec)
    phi = min(t, arc) / radius
    p = np.array([radius * math.sin(phi), radius * (1.0 - math.cos(phi))])
    d = np.array([math.cos(phi), math.sin(phi)])
    p = p + max(t - arc, 0.0) * d
    # the cone frame (x along the canal, bending toward +y) turned by -(90 + tilt) about z
    psi = math.radians(-90.0 - spec.canal_tilt)
    rot = np.array([[math.cos(psi), -math.sin(psi)], [math.sin(psi), math.cos(psi)]])
    return rot @ p + np.asarray(spec.canal_base), rot @ d


def along_canal(node: Node, spec: ShellSpec = DEFAULT) -> Node:
    """A part built along +x from the origin (x: arc length down the canal, +y: its outer side,
    away from the shell axis) bent and placed as the canal is (Figure 6), in the paper's
    frame: the canal's centre line is the x axis bent by the warp."""
    _, arc, _ = _canal_geometry(spec)
    return (
        node.bend(spec.canal_tilt, arc, axis="x", toward="y")
        .rotate("z", -90.0 - spec.canal_tilt)
        .translate(spec.canal_base[0], spec.canal_base[1], 0.0)
    )


def canal_cone(radius_a: float, radius_b: float, spec: ShellSpec = DEFAULT) -> Node:
    """Figure 6: the warp-bent cone of the canal, in the paper's frame (from under the point,
    toward the axis, then straight down along it)."""
    _, _, length = _canal_geometry(spec)
    return along_canal(Cone((0.0, 0.0, 0.0), (length, 0.0, 0.0), radius_a=radius_a,
                            radius_b=radius_b), spec)


def generating_point(radius: float, spec: ShellSpec = DEFAULT) -> Node:
    """A point of this field radius, scaled by the spec's ``point_scale`` (an oval section)."""
    point = Point(radius=radius)
    return point if spec.point_scale == (1.0, 1.0, 1.0) else point.scale(*spec.point_scale)


def generating_surface(canal: bool = False, spec: ShellSpec = DEFAULT) -> Node:
    """B_g of Section 3.1 (Figure 6, left): a point primitive, with the bent canal cone below it
    when ``canal``; local frame, ready for Eq. 8."""
    point = generating_point(spec.point_radius, spec)
    if not canal:
        return point
    return point + to_shell_frame(canal_cone(*spec.canal_radii, spec=spec))


def whorl(a: int, b: int, generating: Node | None = None, spec: ShellSpec = DEFAULT,
          shift: float = 0.0) -> Node:
    """Eq. 9: B_w a..b = sum_{i=a..b} P(B_g, theta_s (i + shift)); B_g defaults to the plain
    point; ``shift`` (instance steps, any real) moves the whole whorl along the spiral."""
    a = _check_int("a", a, 0, 10 * spec.instances)
    b = _check_int("b", b, a, 10 * spec.instances)
    g = generating_surface(spec=spec) if generating is None else generating
    return _sum([place(g, instance_angle(i + shift, spec), spec.spiral)
                 for i in range(a, b + 1)])


def placed(part: Node, x: float, size: float, spec: ShellSpec = DEFAULT) -> Node:
    """Eq. 8 at instance position x (theta_s x) of a local part grown to ``size`` of itself
    (:attr:`Growth.size <blobtree.models.age.Growth.size>`; 1: the part as it is)."""
    return place(grown(part, size), instance_angle(x, spec), spec.spiral)


def sections(canal_sections: int | None = None, spec: ShellSpec = DEFAULT) -> list[Node]:
    """L_Blobtrees of Eq. 10: the sections B_w i..i+5, i = 0, 6, ..., 120 for the Murex; the
    last ``canal_sections`` (default the spec's: the last 1 1/3 whorls) with the canal."""
    n = spec.sections
    canal_sections = spec.canal_sections if canal_sections is None else \
        _check_int("canal_sections", canal_sections, 0, n)
    plain = generating_surface(False, spec)
    with_canal = generating_surface(True, spec) if canal_sections else plain
    per = spec.instances_per_section
    return [whorl(per * j, per * j + per - 1, with_canal if j >= n - canal_sections else plain,
                  spec) for j in range(n)]


def canal_whorl(a: int, b: int, spec: ShellSpec = DEFAULT) -> Node:
    """The canal of instances a..b: Eq. 9's sum of the bent canal cone of Figure 6 alone, the
    part of the generating surface below its point."""
    return whorl(a, b, to_shell_frame(canal_cone(*spec.canal_radii, spec=spec)), spec)


def body_whorl(canal_sections: int | None = None, spec: ShellSpec = DEFAULT,
               texture: np.ndarray | None = None, period: float | None = None,
               colour: tuple | None = None, lumps: Sequence[Sequence[Node]] | None = None,
               age: float = 1.0) -> Node:
    """Eq. 10: B_m = c(L_blendpairs)(L_Blobtrees): each section blends with its two neighbours
    along the spiral only, so adjacent whorls do not blend.  A canal section is two children,
    its points and its canal (``canal_whorl``), and each pair of Eq. 10 blends its two
    sections whole (one group, the sum of both parts of each: the field of Eq. 10 over the
    sections of Eq. 9), so that ``canal.fuse`` (``canal_pairs``) can blend the canal of a
    section with the later section a whorl on without blending their points, which would fill
    the suture between the two whorls.

    With ``texture`` (Figure 12(a)), each part is textured separately by the bounding surface
    ``body_mapping`` (Section 3.4, one copy per ``period`` degrees, default a section); the
    joins lie under the varices.  ``colour``: each part painted this plain colour instead.
    ``lumps``: per section, bumps joined to its points by ``gradient_join`` (after its texture
    or colour, so they keep their own).  ``age``: the whorl as it was at that fraction of its
    life (:mod:`blobtree.models.age`): the sections the lip has reached, the newest instance
    growing, the canal under the last ``canal_sections`` sections before the lip."""
    n, per = spec.sections, spec.instances_per_section
    if canal_sections is not None:
        spec = replace(spec, canal_sections=_check_int("canal_sections", canal_sections, 0, n))
    growth = Growth(spec, age)
    plain = generating_surface(False, spec)
    cone = to_shell_frame(canal_cone(*spec.canal_radii, spec=spec)) if spec.canal_sections \
        else None
    points: list[Node] = []
    canals: dict[int, Node] = {}  # section -> its canal, the canal sections in order
    for j in range(n):
        ids = range(per * j, per * j + per)
        grown_ids = [i for i in ids if growth.size(i)]
        if not grown_ids:
            break
        points.append(_sum([placed(plain, i, growth.size(i), spec) for i in grown_ids]))
        under = [placed(cone, i, growth.canal(i), spec) for i in ids if growth.canal(i)]
        if under:
            canals[j] = _sum(under)
    m = len(points)
    slot = {j: m + r for r, j in enumerate(canals)}  # the canal parts follow the points
    parts = points + list(canals.values())
    if texture is not None:
        wrap = SHELL_TEXTURES["body"].wrap
        mapping = body_mapping(spec, period)
        parts = [s.texture(texture, mapping=mapping, wrap=wrap) for s in parts]
    elif colour is not None:
        parts = [s.color(colour) for s in parts]
    if lumps is not None:
        parts[:m] = [gradient_join(s, list(b)) if b else s
                     for s, b in zip(parts[:m], lumps[:m], strict=True)]
    if len(parts) == 1:
        return parts[0]

    def members(j: int) -> tuple[int, ...]:
        return (j,) if j not in slot else (j, slot[j])

    groups = [members(i) + members(j) for i, j in blend_pairs(spec) if j < m]
    groups += [(slot[i], k) for i, j in _fused(spec, list(canals)) for k in (slot[j], j)]
    return controlled_blend(parts, pairs=[g for g in groups if len(g) == 2],
                            groups=[g for g in groups if len(g) > 2])


def blend_pairs(spec: ShellSpec = DEFAULT) -> list[tuple[int, int]]:
    """L_blendpairs of Eq. 10: each section with the next along the spiral."""
    return [(j, j + 1) for j in range(spec.sections - 1)]


def canal_pairs(spec: ShellSpec = DEFAULT, canal_sections: int | None = None
                ) -> list[tuple[int, int]]:
    """With the spec's ``canal.fuse`` (ours), the canal sections i < j that are not neighbours:
    the canal of i blends with the canal and with the points of j.  The later whorl wraps round
    the earlier canal, and without these blends their surfaces seal tunnels between them
    (bubbles in a mesh: 4-9 at 128-320 cells with the canals alone blended, 8-11 with none).
    The points of i and j do not blend: the canal's field is 0 at the outer suture, so the
    suture is Eq. 10's."""
    n = spec.sections
    return _fused(spec, range(n - (spec.canal_sections if canal_sections is None
                                   else canal_sections), n))


def _fused(spec: ShellSpec, canal: Sequence[int]) -> list[tuple[int, int]]:
    """``canal_pairs`` among the sections ``canal`` (those with a canal)."""
    if not spec.canal_fuse:
        return []
    return [(i, j) for i in canal for j in canal if j > i + 1]


# ---------------------------------------------------------------------------------------------
# Section 3.2: varices, bumps, canal spines
# ---------------------------------------------------------------------------------------------


def spine(delta: float, thick_top: bool = True, widen: bool = True,
          spec: ShellSpec = DEFAULT) -> Node:
    """T_k(B_ki) of Eq. 12 before r(Z, alpha_i): a cone on +x from the origin, bent 30 deg
    toward +y, its top thicker the shorter it is, scaled by (delta, delta, delta_max) (by delta
    alone unless ``widen``), moved out to x_k.  With ``branches`` in the spec, short side
    branches leave the spine, alternately to either side (Chicoreus' branched spines)."""
    if not (math.isfinite(delta) and delta > 0.0):
        raise ValueError(f"delta must be a finite number > 0, got {delta!r}")
    length, (base, tip), dmax = spec.spine_length, spec.spine_radii, spec.delta_max
    if thick_top:
        tip *= dmax / delta
    node: Node = Cone((0.0, 0.0, 0.0), (length, 0.0, 0.0), radius_a=base, radius_b=tip)
    if spec.spine_branches:
        node = blend(node, *spine_branches(spec))
    bent = node.bend(spec.spine_bend, length, axis="x", toward="y")
    return bent.scale(delta, delta, dmax if widen else delta).translate(
        spec.spine_offset, 0.0, 0.0)


def spine_branches(spec: ShellSpec = DEFAULT) -> list[Node]:
    """The side branches of a spine of relative size 1, before its bend: ``branches`` short
    cones spread over its outer two thirds, each leaving at 50 deg, alternately toward -z and
    +z (along the spiral), half the spine's base radius thick, a third of its length long."""
    length, (base, tip) = spec.spine_length, spec.spine_radii
    out = []
    for j in range(spec.spine_branches):
        t = length * (1.0 / 3.0 + (2.0 / 3.0) * (j + 0.5) / spec.spine_branches)
        side = -1.0 if j % 2 == 0 else 1.0
        reach = length / 3.0
        end = (t + reach * math.cos(math.radians(50.0)), 0.0,
               side * reach * math.sin(math.radians(50.0)))
        out.append(Cone((t, 0.0, 0.0), end, radius_a=0.5 * base, radius_b=tip))
    return out


def varix_row(k: int, spec: ShellSpec = DEFAULT) -> tuple[tuple[float, float], ...]:
    """(alpha_i, delta_i) of the curving spines of varix k (Eqs. 11-12): Table 1's row for its
    whorl (``varices.placement = "table"``), or grown for this varix (:mod:`.growth`)."""
    if spec.varix_placement == "table":
        return spec.table_1[whorl_of_varix(k, spec) - 1]
    return grown_varices(spec)[_check_int("k", k, 1, spec.sections) - 1]


def varix_spines(row: Sequence[tuple[float, float]], thick_tops: bool = True,
                 widen: bool = True, spec: ShellSpec = DEFAULT) -> list[Node]:
    """B_s of Eqs. 11-12: the spines r(Z, alpha_i)(T_k(B_ki)) of a row of (alpha_i, delta_i),
    in the paper's frame."""
    return [spine(d, thick_tops, widen, spec).rotate("z", a) for a, d in row]


def varix_tori(spec: ShellSpec = DEFAULT) -> list[Node]:
    """B_r of Eq. 12: concentric tori in the plane of the generating curve (two for Murex)."""
    return [Torus(major_radius=m, radius=r).rotate("x", 90.0) for m, r in spec.tori]


def varix(whorl_index: int, tori: bool = True, thick_tops: bool = True, widen: bool = True,
          spec: ShellSpec = DEFAULT, tori_rgb: np.ndarray | None = None,
          row: Sequence[tuple[float, float]] | None = None) -> Node:
    """Eq. 12: B_v = B_s + B_r for a varix of this whorl (Table 1, Figure 7), local frame, ready
    for Eq. 13; ``row``: its spines' (alpha_i, delta_i) instead of Table 1's for the whorl (a
    grown varix, ``varix_row``).  The flags switch off the stages of Figure 7;
    ``tori_rgb`` paints the tori (so that a texture of the whole varix paints only its
    spines)."""
    whorl_index = _check_whorl(whorl_index, spec)
    parts = varix_spines(spec.table_1[whorl_index - 1] if row is None else row, thick_tops,
                         widen, spec)
    if tori:
        parts += [t if tori_rgb is None else t.color(tori_rgb) for t in varix_tori(spec)]
    if not parts:
        raise ValueError(f"whorl_index {whorl_index} has no spines in Table 1: its varix needs "
                         "tori=True and tori in the spec")
    return to_shell_frame(_sum(parts))


def _shell_varices(spec: ShellSpec) -> list[int]:
    """The numbers k of the varices the shell has: none where a varix has neither spines nor
    tori, and whorl 1's only with ``first_whorl``."""
    return [k for k in range(1, spec.sections + 1)
            if (whorl_of_varix(k, spec) > 1 or spec.first_whorl_varices)
            and (varix_row(k, spec) or spec.tori)]


def varices(spec: ShellSpec = DEFAULT, texture: np.ndarray | None = None,
            age: float = 1.0) -> list[Node]:
    """Eq. 13: B_v placed by Eq. 8 at every 116 deg over the joins of the sections, three per
    whorl (21 in all for the Murex; whorl 1's without spines, see the spec), and, with
    ``down_canal``, those of the canal sections continued down the canal
    (``canal_ridge``).  With ``texture`` (Figure 12(b)), field-interpolated on the spines'
    cones (Section 3.4), the tori and ridges painted in the texture's pale ground colour.
    ``age``: the varices formed by that fraction of the shell's life, the one forming grown
    part way (:mod:`blobtree.models.age`), and ridges only where the canal is then."""
    return placed_varices(local_varices(spec, texture, age), spec, age, texture is not None)


def local_varices(spec: ShellSpec = DEFAULT, texture: np.ndarray | None = None,
                  age: float = 1.0) -> list[tuple[int, float, Node]]:
    """:func:`varices` before Eq. 8, without the ridges: (k, size, varix k in its local frame,
    painted) for each varix formed by ``age``, size how far it has grown."""
    growth = Growth(spec, age)
    return [(k, growth.varix(k), _local_varix(k, spec, texture))
            for k in _shell_varices(spec) if growth.varix(k)]


def placed_varices(local: list[tuple[int, float, Node]], spec: ShellSpec = DEFAULT,
                   age: float = 1.0, pale: bool = False) -> list[Node]:
    """The varices of :func:`local_varices` placed by Eq. 8, and their ridges down the canal
    (``down_canal``; ``pale``: painted in the texture's pale ground colour)."""
    growth = Growth(spec, age)
    ridged = [(k, _ridge_size(k, growth)) for k, _, _ in local] if spec.varices_down_canal \
        else []
    ridges = [canal_ridge(k, spec, size) for k, size in ridged if size]
    if pale:
        ridges = [r.color(VARIX_PALE) for r in ridges]
    return [placed(v, varix_position(k, spec), size, spec) for k, size, v in local] + ridges


def placed_varix(k: int, spec: ShellSpec = DEFAULT, texture: np.ndarray | None = None,
                 size: float = 1.0) -> Node:
    """Eq. 13: varix k (:func:`varix` with ``varix_row``'s spines) placed by Eq. 8 at its
    angle; with ``texture`` (Figure 12(b)), field-interpolated on the spines' cones, the tori
    painted in the texture's pale ground colour; grown to ``size`` of itself (while it forms,
    :mod:`blobtree.models.age`)."""
    return placed(_local_varix(k, spec, texture), varix_position(k, spec), size, spec)


def _local_varix(k: int, spec: ShellSpec, texture: np.ndarray | None) -> Node:
    """Varix k of :func:`placed_varix` in its local frame."""
    w, row = whorl_of_varix(k, spec), varix_row(k, spec)
    if texture is None:
        return varix(w, spec=spec, row=row)
    wrap = SHELL_TEXTURES["varix_spine"].wrap
    return varix(w, spec=spec, tori_rgb=VARIX_PALE, row=row).texture(texture, wrap=wrap)


def _ridge_size(k: int, growth: Growth) -> float:
    """How far varix k's ridge down the canal has grown: with the varix, where the section it
    ends has its canal (the whole shell's last ``canal.sections`` sections)."""
    return min(growth.varix(k), growth.canal(growth.spec.instances_per_section * k - 1))


def canal_ridge(k: int, spec: ShellSpec = DEFAULT, size: float = 1.0) -> Node:
    """Beyond the paper (Section 4: its varices stop short of the canal): varix k continued
    down the canal's outer side as a ridge, the tori of Eq. 12 extended along it.  Each torus
    (major radius m, field radius r about the generating point of field radius point_radius)
    becomes a cone bent with the canal (:func:`along_canal`) over ``varices.down_canal`` of its
    length, m c / point_radius off the canal's centre line and of field radius r c /
    point_radius, with c the canal's field radius there: the varix scaled from the body to the
    canal.  Table 2's spines below the varix stand on it.  In the paper's frame, placed by Eq.
    13 at the varix."""
    _, _, length = _canal_geometry(spec)
    reach = spec.varices_down_canal * length
    start, tip = (c / spec.point_radius for c in spec.canal_radii)
    end = start + (tip - start) * reach / length  # the canal's scale where the ridge ends
    ridge = [Cone((0.0, m * start, 0.0), (reach, m * end, 0.0), radius_a=r * start,
                  radius_b=r * end) for m, r in spec.tori]
    return placed(to_shell_frame(along_canal(_sum(ridge), spec)), varix_position(k, spec),
                  size, spec)


def bump_set(row: Sequence[tuple[float, float]], rng: np.random.Generator | None = None,
             spec: ShellSpec = DEFAULT, size: float = 1.0) -> list[Node]:
    """One set of bumps (Figure 8) in the local frame, ready for Eq. 8: a point per second
    curving spine of a varix row (alpha_i, delta_i), scaled by (zeta_x, zeta_y, zeta_z + 0.8),
    zeta ~ N(s, s/10) (all s without ``rng``), placed like the spines (Eq. 11); grown to
    ``size`` of itself (none at 0, their zeta still drawn: :mod:`blobtree.models.age`)."""
    s = spec.bump_size
    out = []
    for alpha, _ in row[::2]:
        zeta = rng.normal(s, s / 10.0, 3) if rng is not None else np.full(3, s)
        bump = (
            Point(radius=1.0)
            .scale(zeta[0], zeta[1], zeta[2] + spec.bump_z_extra)
            .translate(spec.bump_offset, 0.0, 0.0)
            .rotate("z", alpha)
        )
        if size:
            out.append(grown(to_shell_frame(bump), size))
    return out


def gradient_join(section: Node, lumps: list[Node]) -> Node:
    """A section and its bumps joined by the gradient-based blend (``bumps.join = "gradient"``,
    ours): the union of the bumps (they do not swell into one another, as with n = 400) stands
    on the whorl where their gradients face the same way as its, and blends into it only in the
    crease around each base, where both fields are above ``GRADIENT_CONTACT``; so no bump is
    blown up by the whorl's far-reaching field (the paper's reason for n = 400) and none meets
    it in a sharp crease.  The step of the gradients is a fifth of the steepest bump's
    1 / Lipschitz bound (the bumps' scale), the floor a twentieth of the gentlest slope of a
    bump or a primitive of the section."""
    slopes = [b.lipschitz() for b in lumps]
    floor = 0.05 * min(*slopes, *(c.lipschitz() for c in section.walk()
                                  if c.KIND == "primitive"))
    return gradient_blend(section, union(*lumps) if len(lumps) > 1 else lumps[0],
                          step=0.2 / max(slopes), floor=floor, contact=GRADIENT_CONTACT)


def bumps(seed: int | np.random.Generator | None = 0, intervals: range | list[int] | None = None,
          spec: ShellSpec = DEFAULT, age: float = 1.0) -> list[Node]:
    """Section 3.2: five sets of bumps between varix k and k + 1 (k in ``intervals``, default
    all), evenly spaced over section k: the varices lie 6 instance steps apart, and the sets
    one step apart between them (half-way between the section's instances), a bump per second
    spine of varix k + 1, which ends the section (its whorl's, Table 1); random sizes unless
    ``seed`` is None.  ``age``: those the lip has passed by that fraction of the shell's life,
    the newest growing (:mod:`blobtree.models.age`; the sizes drawn are the same at any age)."""
    return placed_bumps(local_bumps(seed, intervals, spec, age), spec)


def local_bumps(seed: int | np.random.Generator | None = 0,
                intervals: range | list[int] | None = None, spec: ShellSpec = DEFAULT,
                age: float = 1.0) -> list[tuple[int, float, Node]]:
    """:func:`bumps` before Eq. 8: (k, x, bump) per bump, k its section, x its instance
    position (theta_s x), the bump in its local frame, grown (nothing here reads the spiral)."""
    rng = None if seed is None else _rng(seed)
    growth = Growth(spec, age)
    ks = range(1, spec.sections) if intervals is None else intervals
    per, sets = spec.instances_per_section, spec.bump_sets
    out = []
    for k in ks:
        k = _check_int("intervals", k, 1, spec.sections - 1)
        row = varix_row(k + 1, spec)
        for m in range(sets):
            at = per * k - 0.5 + (m + 1) * per / (sets + 1)
            out += [(k, at, b) for b in bump_set(row, rng, spec, growth.size(at))]
    return out


def placed_bumps(local: list[tuple[int, float, Node]], spec: ShellSpec = DEFAULT) -> list[Node]:
    """The bumps of :func:`local_bumps` placed by Eq. 8 at their instance positions."""
    return [place(b, instance_angle(at, spec), spec.spiral) for _, at, b in local]


def canal_spine(size: float, rng: np.random.Generator | None = None,
                spec: ShellSpec = DEFAULT) -> Node:
    """An axial canal spine of relative ``size`` (Table 2): a cone on +x from the origin, bent
    1-3 times by 3-9 deg toward random directions at random places when ``rng`` is given.  A
    spine smaller than ``canal_spines.min_size`` keeps that size's thickness: scaled down with
    its length, the smallest spines' tips (0.01-0.04 units) would be thinner than a mesh cell
    and break off as islands, and a printed shell must be one solid."""
    if not (math.isfinite(size) and size > 0.0):
        raise ValueError(f"size must be a finite number > 0, got {size!r}")
    length = spec.canal_spine_length
    k = max(size, spec.canal_spine_min_size) / size
    node: Node = Cone((0.0, 0.0, 0.0), (length, 0.0, 0.0),
                      radius_a=spec.canal_spine_radii[0] * k,
                      radius_b=spec.canal_spine_radii[1] * k)
    if rng is not None:
        lo, hi = spec.canal_spine_bends
        for _ in range(int(rng.integers(lo, hi + 1))):
            degrees = rng.uniform(*spec.canal_spine_bend_deg)
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


def _canal_frame(t: float, offset: float, tilt: float, spec: ShellSpec
                 ) -> tuple[np.ndarray, float]:
    """(base (x, y), direction in degrees) of a part on the canal's outer side at arc length t,
    ``offset`` canal radii off its centre line, pointing away from the axis tilted ``tilt``
    degrees toward the apex."""
    _, _, length = _canal_geometry(spec)
    p, d = canal_centreline(t, spec)
    normal = np.array([-d[1], d[0]]) if d[1] < 0 else np.array([d[1], -d[0]])
    r = spec.canal_radii[0] + (spec.canal_radii[1] - spec.canal_radii[0]) * t / length
    base = p + offset * r * normal
    return base, math.degrees(math.atan2(normal[1], normal[0])) + tilt


def canal_spine_frames(row: int, spec: ShellSpec = DEFAULT) -> list[tuple[np.ndarray, float]]:
    """(base (x, y), direction in degrees) in the paper's frame of each spine of a Table 2 row,
    evenly spaced along the canal."""
    row = _check_int("row", row, 1, len(spec.table_2))
    _, _, length = _canal_geometry(spec)
    lo, hi = spec.canal_spine_span
    n = len(spec.table_2[row - 1])
    return [_canal_frame(length * (lo + (hi - lo) * j / max(n - 1, 1)), spec.canal_spine_base,
                         spec.canal_spine_tilt, spec) for j in range(n)]


def canal_spines(seed: int | np.random.Generator | None = 0,
                 spec: ShellSpec = DEFAULT, age: float = 1.0) -> list[Node]:
    """Section 3.2, Table 2, Figure 9: axial rows of spines on the canal, below the last
    varices (three for the Murex), placed by Eq. 8 at their angles; straight when ``seed`` is
    None.  ``age``: under the last varices formed by that fraction of the shell's life
    (:mod:`blobtree.models.age`): Table 2's rows repeat along the spiral, so each varix keeps
    the row it formed with (the whole shell's last varices have rows 1, 2, 3 in order)."""
    return placed_canal_spines(local_canal_spines(seed, spec, age), spec)


def local_canal_spines(seed: int | np.random.Generator | None = 0, spec: ShellSpec = DEFAULT,
                       age: float = 1.0) -> list[tuple[int, float, Node]]:
    """:func:`canal_spines` before Eq. 8: (k, size, spine in its local frame) for each spine
    under varix k, size how far it has grown (the varices that share a row of Table 2 share
    its spines' nodes)."""
    if not spec.canal_sections or not spec.table_2:
        return []
    rng = None if seed is None else _rng(seed)
    growth = Growth(spec, age)
    n, rows = spec.sections, len(spec.table_2)
    spines = [[to_shell_frame(canal_spine(size, rng, spec).rotate("z", direction).translate(
        base[0], base[1], 0.0))
        for size, (base, direction) in zip(sizes, canal_spine_frames(row, spec), strict=True)]
        for row, sizes in enumerate(spec.table_2, 1)]
    return [(k, growth.canal_spines(k), local)
            for k in range(1, n + 1) if growth.canal_spines(k)
            for local in spines[(k - (n - rows) - 1) % rows]]


def placed_canal_spines(local: list[tuple[int, float, Node]], spec: ShellSpec = DEFAULT
                        ) -> list[Node]:
    """The spines of :func:`local_canal_spines` placed by Eq. 8 under their varices."""
    return [placed(s, varix_position(k, spec), size, spec) for k, size, s in local]


# ---------------------------------------------------------------------------------------------
# Section 3.3: the opening
# ---------------------------------------------------------------------------------------------


def previous_whorl_offset(spec: ShellSpec = DEFAULT) -> np.ndarray:
    """Centre of the generating curve one turn (360 deg) earlier, in the local frame: constant,
    as the spiral is self-similar."""
    s = spec.spiral
    d = s.size(360.0)
    return np.array([s.radius(0.0) - s.radius(360.0), s.height(0.0) - s.height(360.0), 0.0]) / d


def inside_generating_surface(spec: ShellSpec = DEFAULT) -> Node:
    """Section 3.3, Figure 10 left: a slightly smaller point, four slender inner-canal cones
    bent like the canal (when the shell has a canal) and four cones reaching the previous
    whorl, each four spread over the interval theta_s between instances."""
    offset = previous_whorl_offset(spec)
    distance = float(np.linalg.norm(offset))
    reach = distance - 1.0 / spec.spiral.rho + spec.extension_reach
    extension = Cone((0.0, 0.0, 0.0), tuple(offset * reach / distance),
                     radius_a=spec.extension_radii[0], radius_b=spec.extension_radii[1])
    fans = [(extension, spec.extension_cones)]
    if spec.canal_sections:
        inner = to_shell_frame(canal_cone(*(spec.inner_canal_scale * r for r in spec.canal_radii),
                                          spec))
        fans.insert(0, (inner, spec.inner_canal_cones))
    parts = [about_axis(cone, spec.theta_s * j / count, spec)
             for cone, count in fans for j in range(count)]
    return _sum([generating_point(spec.inside_scale * spec.point_radius, spec), *parts])


def inside_whorl(spec: ShellSpec = DEFAULT, age: float = 1.0) -> Node:
    """B_inside of Eq. 14 (Figure 10 centre): the whorl of the inside generating surface;
    ``age``: behind the lip at that fraction of the shell's life (moved along the spiral with
    it, :attr:`Growth.shift <blobtree.models.age.Growth.shift>`), as are the other parts of
    the opening."""
    a, b = spec.inside_instances
    return whorl(a, b, inside_generating_surface(spec), spec, Growth(spec, age).shift)


def previous_whorl(spec: ShellSpec = DEFAULT, age: float = 1.0) -> Node:
    """B_w 94..108 of Eq. 14 as the body builds it: Eq. 9's sum of those instances of the
    body's generating surface, with the canal on the instances of the sections that have one
    (from instance 102 for the Murex), so that the opening cuts nothing of it; ``age`` as for
    :func:`inside_whorl`."""
    a, b = spec.previous_whorl
    shift = Growth(spec, age).shift
    canal_from = spec.instances_per_section * (spec.sections - spec.canal_sections)
    plain = generating_surface(False, spec)
    with_canal = generating_surface(True, spec) if spec.canal_sections else plain
    return _sum([place(with_canal if i >= canal_from else plain, instance_angle(i + shift, spec),
                       spec.spiral) for i in range(a, b + 1)])


def opening(spec: ShellSpec = DEFAULT, age: float = 1.0) -> Node:
    """Eq. 14: B_opening = B_inside - B_w 94..108 (Figure 10 right): the previous whorl is kept
    (the difference rounded by ``opening.cut_smooth``, see :func:`shell`); ``age``: at the lip
    of that fraction of the shell's life (:func:`inside_whorl`)."""
    return difference(inside_whorl(spec, age), previous_whorl(spec, age),
                      smooth=spec.cut_smooth)


def inside_wall(spec: ShellSpec = DEFAULT, age: float = 1.0) -> Node:
    """B_inside_wall of Eq. 15 (Figure 11 right): a wall around the round hollow of the inside
    point, up to the last instance, that refills what the extension cones cut; ``age``: up to
    the lip of that fraction of the shell's life (:func:`inside_whorl`)."""
    a, b = spec.inside_instances
    shift = Growth(spec, age).shift
    wall = whorl(a, spec.instances - 1, generating_point(spec.wall_scale * spec.point_radius,
                                                          spec), spec, shift)
    hollow = whorl(a, b, generating_point(spec.inside_scale * spec.point_radius, spec), spec,
                   shift)
    return difference(wall, hollow, smooth=spec.cut_smooth)


# ---------------------------------------------------------------------------------------------
# The whole shell
# ---------------------------------------------------------------------------------------------


def _pattern_texture(name: str, seed: int, spec: ShellSpec, cells: int = 512) -> np.ndarray:
    """A pigment pattern grown along the whole spiral (:mod:`blobtree.texture.pigment`): its
    rows are time, so they become the texture's columns (u, along the spiral), its ``cells``
    columns the lip (v).  As many rows per degree as keep a cell as long along the growth as
    across the lip (a wave moving a cell per row draws 45 deg lines on the shell, as on a real
    one): a degree of growth is R pi / 180 long, the lip about 2 pi 1.08 D sqrt((sx^2 + sy^2) / 2)
    (the tube of visible radius 1.08 D, scaled by point_scale); fewer cells when the rows would
    pass 4096.  The lip's ends meet, as v wraps around the tube."""
    sx, sy, _ = spec.point_scale
    lip = 2.0 * math.pi * 1.08 * spec.spiral.d_over_r * math.sqrt((sx * sx + sy * sy) / 2.0)
    per_cell = spec.instances * spec.theta_s * math.pi / 180.0 / lip  # rows per cell
    cells = max(16, min(cells, int(4096 / per_cell)))  # images have at most 4096 columns
    rows = max(64, min(4096, round(cells * per_cell)))
    return _grown_image(name, cells, rows, seed)


@functools.lru_cache(maxsize=8)
def _grown_image(name: str, cells: int, rows: int, seed: int) -> np.ndarray:
    """:func:`_pattern_texture`'s image (read-only; kept for the last specs: a change of any
    other number of the spec builds the shell again without growing its pattern again)."""
    image = pigment.meinhardt(name, cells, rows, seed=seed)
    for axis in (0, 1):  # lines a cell thin would alias away: widen the (darker) pigment to 3
        image = np.minimum.reduce([np.roll(image, k, axis=axis) for k in (-1, 0, 1)])
    return frozen(np.ascontiguousarray(
        np.round(np.clip(image.transpose(1, 0, 2), 0.0, 1.0) * 255.0).astype(np.uint8)))


@functools.lru_cache(maxsize=8)
def _paper_textures(seed: int) -> Mapping[str, np.ndarray]:
    """The four textures of Figure 12 for ``seed`` (read-only, kept for the last seeds)."""
    return MappingProxyType({k: frozen(v) for k, v in shell_textures(seed).items()})


def outer_shell(seed: int = 0, spec: ShellSpec = DEFAULT, textured: bool = True,
                age: float = 1.0, parts: Parts = FRESH) -> Node:
    """B_shell of Eq. 15: the main body whorl with its varices and canal spines blended in, and
    the bumps joined by the super-elliptic blend n = 400 (Section 3.2), or with ``bumps.join =
    "gradient"`` each section's bumps joined to it by the gradient-based blend (ours,
    ``gradient_join``).

    ``textured``: the spec's look: the four textures of Figure 12 (generated from ``seed``) by
    the paper's two methods (Section 3.4): (a) per section by a bounding surface, (b)-(d) on the
    varix spines, bumps and canal spines, field-interpolated; or a grown pigment pattern on the
    body; otherwise plain colours.  The geometry is the same either way.  ``age``: as it was at
    that fraction of its life (:mod:`blobtree.models.age`; the same draws from ``seed``).
    ``parts``: the bumps, body and spines of earlier builds, taken where they read the same
    spec values (:mod:`blobtree.models.parts`)."""
    _check_int("seed", seed, 0, 2**63 - 1)
    # each part in two steps: its pieces in their local frames (which read no spiral number,
    # so a change of the spiral keeps them and their keys), then placed by Eq. 8
    local = parts.part("local bumps", _local_bumps, spec, seed, age)
    per_section, lumps = parts.part("bumps", _bumps, spec, seed, textured, local)
    body = parts.part("body", _body, spec, seed, textured, age, per_section)
    local = (parts.part("local varices", _local_varices, spec, seed, textured, age),
             parts.part("local canal spines", _local_canal_spines, spec, seed, age))
    spiny = parts.part("spiny", _spiny, spec, seed, textured, age, local)
    main = blend(body, *spiny) if spiny else body
    return super_blend(main, *lumps, n=spec.bump_blend_n) if lumps else main


def _streams(seed: int) -> list[np.random.Generator]:
    """The random streams of the bumps and of the canal spines drawn from ``seed``."""
    return [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(2)]


def _look(spec: ShellSpec, seed: int, textured: bool) -> tuple[str, Mapping | None]:
    """The look painted (``look.texture``, or "plain") and Figure 12's textures if it is
    "paper"."""
    look = spec.texture if textured else "plain"
    return look, _paper_textures(seed) if look == "paper" else None


def _local_bumps(spec: ShellSpec, seed: int, age: float) -> list[tuple[int, float, Node]]:
    """:func:`outer_shell`'s bumps in their local frames (:func:`local_bumps`)."""
    return local_bumps(_streams(seed)[0], spec=spec, age=age)


def _bumps(spec: ShellSpec, seed: int, textured: bool, local: list[tuple[int, float, Node]]
           ) -> tuple[list[list[Node]] | None, list[Node]]:
    """:func:`outer_shell`'s bumps, placed and painted: (per section, for the gradient join;
    or None) and (the lumps the super-elliptic blend joins; or none)."""
    _, tex = _look(spec, seed, textured)
    bump_c = spec.colours[2]

    def paint(b: Node) -> Node:
        return b.texture(tex["bump"], wrap=SHELL_TEXTURES["bump"].wrap) if tex else \
            b.color(bump_c)

    if spec.bump_join == "gradient":  # per section: none on section 0 (bumps() starts at 1)
        return [[]] + [[paint(b) for b in placed_bumps([x for x in local if x[0] == k], spec)]
                       for k in range(1, spec.sections)], []
    return None, [paint(b) for b in placed_bumps(local, spec)]


def _body(spec: ShellSpec, seed: int, textured: bool, age: float,
          per_section: list[list[Node]] | None) -> Node:
    """:func:`outer_shell`'s body whorl in its look, with the bumps ``per_section`` joined."""
    look, tex = _look(spec, seed, textured)
    if tex:
        return body_whorl(spec=spec, texture=tex["body"], lumps=per_section, age=age)
    if look == "plain":
        return body_whorl(spec=spec, colour=spec.colours[0], lumps=per_section, age=age)
    return body_whorl(spec=spec, texture=_pattern_texture(look, seed, spec),
                      period=spec.instances * spec.theta_s, lumps=per_section, age=age)


def _local_varices(spec: ShellSpec, seed: int, textured: bool, age: float) -> list:
    """:func:`outer_shell`'s varices (painted) in their local frames."""
    _, tex = _look(spec, seed, textured)
    return local_varices(spec, tex["varix_spine"] if tex else None, age)


def _local_canal_spines(spec: ShellSpec, seed: int, age: float) -> list:
    """:func:`outer_shell`'s canal spines in their local frames (apart from the varices: a
    change of the canal builds only these again)."""
    return local_canal_spines(_streams(seed)[1], spec, age)


def _spiny(spec: ShellSpec, seed: int, textured: bool, age: float, local: tuple[list, list]
           ) -> list[Node]:
    """:func:`outer_shell`'s varices and canal spines, placed and painted."""
    local_v, local_c = local
    spines = placed_canal_spines(local_c, spec)
    _, tex = _look(spec, seed, textured)
    if tex:
        wrap = SHELL_TEXTURES["canal_spine"].wrap
        return placed_varices(local_v, spec, age, True) + [
            s.texture(tex["canal_spine"], wrap=wrap) for s in spines]
    return [v.color(spec.colours[1]) for v in placed_varices(local_v, spec, age) + spines]


def shell(spec: ShellSpec | Mapping | str | Path = "murex", seed: int = 0, inside: bool = True,
          textured: bool = True, age: float | None = None, parts: Parts = FRESH) -> Node:
    """A whole shell from its spec (Eq. 15 for the Murex), by ``opening.wall_join``:
    'union', the paper's B = (B_shell - B_opening) U B_inside_wall, or 'clipped' (the shipped
    specs'), B = B_shell - (B_opening - B_inside_wall).

    The two forms are the same solid wherever the wall lies inside B_shell: min(S, max(1 - O,
    W)) = max(min(S, 1 - O), min(S, W)) by distributivity, and the clipped form clips the wall
    to the shell.  The paper's wall lies inside; ours is larger (``opening.wall_scale`` 1.2,
    ours) so that it fills the crease the extension cones carve where the wall meets the
    previous whorl.  Joined by the union, a wall that just touches would seal that crease inside
    the shell as 14-48 bubbles (pieces of the mesh); clipped, the larger wall closes it and
    cannot show outside the shell.  With the larger wall both forms mesh to one solid at every
    32 cells from 128 to 512 for every shipped shell, but the union shows the wall outside the
    last whorl and round the lip (figure ``walls``), so the shipped specs clip it.

    The differences are rounded (``Difference.smooth``): the carving of the lip by
    ``opening.lip_smooth``, Eq. 14's cut and the wall's by ``opening.cut_smooth``.  The sharp
    CSG difference leaves knife edges wherever a carved surface leaves another at a grazing
    angle: along the aperture's lip, the slit the inner canal cones open down the canal, the inside
    wall's rim.  There the field only just reaches 0.5 over a wall thinner than a mesh cell, and a
    mesher sampling it keeps fragments of it as separate slivers, different ones at each resolution
    (up to 4 extra solids per shell from 128 to 512 cells with sharp cuts:
    ``python bench/print_pieces.py --sharp``).  A rounded difference is within smooth / 4 of the
    sharp one and only removes the part of such an edge thinner than about smooth / (2
    ``|grad f|``): the lip is blunt, as a real shell's is.  The solid is still Eqs. 14 and 15, with
    its edges rounded rather than sharp; ``lip_smooth = cut_smooth = 0`` gives the sharp form.

    ``spec``: a :class:`ShellSpec`, the name of a shipped one (``SHELLS``), a path to a TOML
    spec file, or its parsed data.  ``seed`` drives the bump sizes, canal spine bends and
    textures; ``inside=False`` stops at Eq. 14 (no inside wall, Figure 11 left);
    ``textured=False`` paints the parts in the spec's plain colours (the inside stays plain
    either way).

    ``age``: the shell as it was at that fraction of its life, in [0, 1] (None or 1: the whole
    shell; :mod:`blobtree.models.age`): its lip where it stood then, the opening carved there
    (Eqs. 14-15), the canal under the last sections before it, the varices formed and the bumps
    passed by then, the newest part growing.  Its volume never falls as ``age`` rises.

    ``parts``: a :class:`~blobtree.models.parts.Parts` kept across the builds of a spec being
    changed, which hands back the parts a change leaves as they were (the same tree)."""
    spec = load_spec(spec)
    age = 1.0 if age is None else Growth(spec, age).age
    inside_c = spec.colours[3]
    carved = outer_shell(seed, spec, textured, age, parts)
    if spec.opening:
        hole = opening(spec, age).color(inside_c)
        wall = inside_wall(spec, age).color(inside_c) if inside else None
        if wall is not None and spec.wall_join == "clipped":
            hole = difference(hole, wall, smooth=spec.cut_smooth)
        carved = difference(carved, hole, smooth=spec.lip_smooth)
        if wall is not None and spec.wall_join == "union":
            carved = union(carved, wall)
    return carved.shown(up=spec.up, view=spec.view)


def murex(seed: int = 0, inside: bool = True, textured: bool = True, pattern: str | None = None,
          age: float | None = None, **choices: object) -> Node:
    """The whole Murex cabritii shell (Figure 14), Eq. 15, ``shell(SHELLS["murex"])``, or at an
    ``age`` (:func:`shell`).

    ``pattern``: a pigment pattern of ``bt.texture.PATTERNS`` grown on the body instead of the
    paper's texture (only colours change); keyword arguments override fields of the spec
    (:class:`ShellSpec`, e.g. ``canal_fuse=False``)."""
    allowed = sorted(f for f in ShellSpec.__dataclass_fields__ if f != "name")
    unknown = sorted(set(choices) - set(allowed))
    if unknown:
        raise ValueError(f"unknown choice(s) {unknown}; allowed: {allowed}")
    spec = replace(DEFAULT, **choices)
    if pattern is not None:
        spec = replace(spec, texture=pattern)
    return shell(spec, seed, inside=inside, textured=textured, age=age)
