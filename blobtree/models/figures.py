"""The models of the paper's figures (3-11 and 14), each a function returning one BlobTree, and
:data:`FIGURES`: for each figure its builder, a suggested camera and the paper's caption.
Figure 12 shows textures, not a model: :func:`figure_12` returns an image, listed in
:data:`TEXTURE_FIGURES`."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..nodes import Node, Point, blend, controlled_blend, super_blend, union
from ..texture.shell import SHELL_TEXTURES
from .murex import (
    APERTURE_VIEW,
    BUMP_BLEND_N,
    CANAL_SECTIONS,
    DEFAULT,
    SHELL_UP,
    body_whorl,
    bumps,
    canal_ridge,
    canal_spines,
    generating_surface,
    gradient_join,
    inside_generating_surface,
    inside_whorl,
    instance_angle,
    murex,
    opening,
    placed_varix,
    sections,
    shell,
    varix,
    whorl,
)
from .raup import raup
from .spec import SHELLS, ShellSpec

#: Local parts (generating surfaces, varices) are seen face on, the apex side up.
LOCAL_VIEW = (0.0, 0.0, -1.0)


def _row(nodes: Sequence[Node], view: Sequence[float], up: Sequence[float],
         gap: float = 0.4, column: bool = False) -> Node:
    """Place nodes side by side, left to right on screen for this view (top to bottom when
    ``column``), each centred on the others' line."""
    d = np.asarray(view, float) / np.linalg.norm(view)
    u = np.asarray(up, float) - d * (d @ np.asarray(up, float))
    u /= np.linalg.norm(u)
    step = -u if column else np.cross(d, u)
    boxes = [n.bounds() for n in nodes]
    widths = [float(np.abs(step) @ (hi - lo)) for lo, hi in boxes]
    x = -0.5 * (sum(widths) + gap * (len(nodes) - 1))
    out = []
    for node, (lo, hi), w in zip(nodes, boxes, widths, strict=True):
        shift = step * (x + 0.5 * w) - 0.5 * (lo + hi)
        out.append(node.translate(*shift))
        x += w + gap
    return union(*out)


def _outward_view(instance: int) -> tuple[float, float, float]:
    """Looking at the outside of the whorl at this instance, toward the shell axis."""
    t = math.radians(instance_angle(instance))
    return (-math.cos(t), 0.0, math.sin(t))


#: Figure 8 shows the bumps between varix 19 and 20 (on the last whorl).
BUMP_INTERVAL = 19


def figure_3(n_values: Sequence[float] = tuple(range(1, 11))) -> Node:
    """Figure 3 / Eq. 4: two points joined by the super-elliptic blend, n = 1..10, in two rows
    of five (n grows left to right, then top to bottom)."""
    pairs = [
        super_blend(Point(radius=1.0, center=(-0.42, 0, 0)), Point(radius=1.0, center=(0.42, 0, 0)),
                    n=n)
        for n in n_values
    ]
    half = (len(pairs) + 1) // 2
    rows = [_row(pairs[:half], LOCAL_VIEW, (0, 1, 0), gap=0.3),
            _row(pairs[half:], LOCAL_VIEW, (0, 1, 0), gap=0.3)]
    return _row(rows, LOCAL_VIEW, (0, 1, 0), gap=0.3, column=True)


def figure_4(radii: Sequence[float] = (1.0, 1.4, DEFAULT.point_radius)) -> Node:
    """Figure 4: the six points of a section on the helico-spiral (Eq. 9), their field radius
    growing from left to right until they form part of a whorl."""
    return _row([whorl(120, 125, Point(radius=r)) for r in radii], (0.0, 1.0, 0.0),
                (0.0, 0.0, -1.0))


def figure_5() -> Node:
    """Figure 5: the 21 sections of a point whorl, all blended (left) and with the controlled
    blending of Eq. 10 (right)."""
    secs = sections(canal_sections=0)
    pairs = [(j, j + 1) for j in range(len(secs) - 1)]
    return _row([blend(*secs), controlled_blend(secs, pairs=pairs)], APERTURE_VIEW, SHELL_UP)


def figure_6() -> Node:
    """Figure 6: the generating surface with its canal cone (left, enlarged) and the whorl it
    defines (right, canal in the last 1 1/3 whorls)."""
    return _row([generating_surface(canal=True).scale(0.5), body_whorl()], LOCAL_VIEW,
                SHELL_UP)


def figure_7(whorl_index: int = 7) -> Node:
    """Figure 7: the four stages of a varix (Eq. 12): bent cones; plus the two tori; shorter
    spines with thicker tops; all spines scaled by delta_max across the varix."""
    stages = [
        varix(whorl_index, tori=False, thick_tops=False, widen=False),
        varix(whorl_index, tori=True, thick_tops=False, widen=False),
        varix(whorl_index, tori=True, thick_tops=True, widen=False),
        varix(whorl_index),
    ]
    rows = [_row(stages[i:i + 2], LOCAL_VIEW, SHELL_UP) for i in (0, 2)]
    return _row(rows, LOCAL_VIEW, SHELL_UP, column=True)


def figure_8(seed: int = 0) -> Node:
    """Figure 8: two whorl sections with five sets of bumps: equal bumps blended by + (left),
    randomly scaled bumps joined by the super-elliptic blend n = 400 (right)."""
    k = BUMP_INTERVAL
    secs = sections(canal_sections=0)[k:k + 2]
    base = controlled_blend(secs, pairs=[(0, 1)])
    plain = blend(base, *bumps(None, intervals=[k]))
    rough = super_blend(base, *bumps(seed, intervals=[k]), n=BUMP_BLEND_N)
    return _row([plain, rough], _outward_view(6 * k + 2), SHELL_UP)


def _canal_part(seed: int | None) -> Node:
    canal = sections()[-CANAL_SECTIONS:]
    pairs = [(j, j + 1) for j in range(len(canal) - 1)]
    return blend(controlled_blend(canal, pairs=pairs), *canal_spines(seed))


def figure_9(seed: int = 0) -> Node:
    """Figure 9: the axial rows of canal spines (Table 2) straight (left) and each bent 3-9 deg
    one to three times (right), on the last 1 1/3 whorls."""
    return _row([_canal_part(None), _canal_part(seed)], APERTURE_VIEW, SHELL_UP)


def figure_10() -> Node:
    """Figure 10: the inside generating surface (left, enlarged), the inside whorl (centre) and
    the opening cut from the shell, B_inside - B_w 94..108 (right, Eq. 14)."""
    return _row([inside_generating_surface().scale(0.5), inside_whorl(), opening()],
                APERTURE_VIEW, SHELL_UP)


def figure_11(seed: int = 0) -> Node:
    """Figure 11: the opening carved by Eq. 14 (left) and after adding the inside wall, Eq. 15
    (right)."""
    return _row([murex(seed, inside=False), murex(seed)], APERTURE_VIEW, SHELL_UP)


def figure_12(seed: int = 0, height: int = 256, gap: int = 16, label_height: int = 24,
              background: tuple[int, int, int] = (255, 255, 255)) -> np.ndarray:
    """Figure 12: the four textures of the shell (Section 3.4) side by side, as the model of
    ``seed`` uses them, each scaled to ``height`` rows (the narrow spine textures to at least
    height / 2 columns) and labelled by its use; an (H, W, 3) uint8 image."""
    from PIL import Image, ImageDraw

    if isinstance(height, bool) or not isinstance(height, int) or not 16 <= height <= 4096:
        raise ValueError(f"height must be an integer in [16, 4096], got {height!r}")
    panels = []
    for t in SHELL_TEXTURES.values():
        img = t.make(seed)
        h, w = img.shape[:2]
        width = max(round(height * w / h), height // 2)
        panels.append((t.label, Image.fromarray(img).resize((width, height), Image.BICUBIC)))
    total = sum(p.width for _, p in panels) + gap * (len(panels) + 1)
    canvas = Image.new("RGB", (total, height + label_height + 2 * gap), background)
    draw = ImageDraw.Draw(canvas)
    x = gap
    for label, panel in panels:
        canvas.paste(panel, (x, gap))
        draw.text((x, height + gap + 4), label, fill=(0, 0, 0))
        x += panel.width + gap
    return np.asarray(canvas)


def figure_14(seed: int = 0) -> Node:
    """Figure 14: the model of Murex cabritii, textured (Section 3.4)."""
    return murex(seed, textured=True)


@dataclass(frozen=True)
class Figure:
    """A figure of the paper: how to build its model, how to look at it, what the paper says."""

    build: Callable[[], Node]
    caption: str
    view: tuple[float, float, float] = APERTURE_VIEW
    up: tuple[float, float, float] = SHELL_UP
    fov: float = 30.0

    def aspect(self, tree: Node | None = None) -> float:
        """Width / height that fits the tree's box seen along ``view`` (between 1 and 3)."""
        tree = self.build() if tree is None else tree
        lo, hi = tree.bounds()
        d = np.asarray(self.view, float) / np.linalg.norm(self.view)
        u = np.asarray(self.up, float) - d * (d @ self.up)
        u /= np.linalg.norm(u)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])]) - 0.5 * (lo + hi)
        half_w, half_h = np.abs(corners @ np.cross(d, u)).max(), np.abs(corners @ u).max()
        return float(np.clip(half_w / half_h, 1.0, 3.0))


@dataclass(frozen=True)
class TextureFigure:
    """A figure of the paper that shows images, not a model: how to draw it, its caption."""

    draw: Callable[[], np.ndarray]
    caption: str


#: Figure number -> image-drawing function and the paper's caption (figures of textures).
TEXTURE_FIGURES: dict[str, TextureFigure] = {
    "12": TextureFigure(figure_12, "Textures and their corresponding uses in the model of "
                                   "Murex cabritii."),
}

#: Figure number -> model, camera and the paper's caption.
FIGURES: dict[str, Figure] = {
    "3": Figure(figure_3, "Super-elliptic blending", view=LOCAL_VIEW, up=(0.0, 1.0, 0.0)),
    "4": Figure(
        figure_4,
        "Six point primitives placed on a helico-spiral. As the size of the field produced by "
        "each primitive increases, the resulting surface forms part of the main body whorl of a "
        "shell.",
        view=(0.0, 1.0, 0.0), up=(0.0, 0.0, -1.0),
    ),
    "5": Figure(
        figure_5,
        "Each whorl of a shell is composed of three sections (shown in Figure 4). On the left all "
        "sections blend with all other sections, on the right controlled blending constrains "
        "each section to blend only with its two neighbours along the helico-spiral.",
    ),
    "6": Figure(
        figure_6,
        "On the left is the generating surface used for the model of Murex cabritii, on the "
        "right is the whorl this surface defines.",
        view=LOCAL_VIEW,
    ),
    "7": Figure(
        figure_7,
        "Creation of a varix. Top left: bent cones are placed as curved spines. Top right: two "
        "concentric tori blend spines together. Bottom left: smaller spines are modeled with "
        "wider tips. Bottom right: All spines scaled by delta_max along helico-spiral "
        "(Equation 12).",
        view=LOCAL_VIEW,
    ),
    "8": Figure(
        figure_8,
        "Creation of bumps. Left: similar bumps blended to shell using + operator. Right: "
        "randomly scaled bumps blended to shell with the diamond_400 operator. The value 400 was "
        "required due the great disparity in strength and extend of field between the large "
        "whorl and small bumps.",
        view=_outward_view(6 * BUMP_INTERVAL + 2),
    ),
    "9": Figure(
        figure_9,
        "Axial rows of 5-6 spines. Left: spines are straight. Right: each spine randomly bent "
        "3 to 9 degrees 1-3 times.",
    ),
    "10": Figure(
        figure_10,
        "On the left is the generating surface used for the inside of Murex cabritii, in the "
        "center is the whorl this surface defines, and on the right is the final surface which "
        "will be cut out of the main shell to create the opening.",
    ),
    "11": Figure(
        figure_11,
        "On the left is the opening which is carved out by Equation 14, on the right is the "
        "final shape of the opening after adding in B_inside_wall as in Equation 15.",
    ),
    "14": Figure(figure_14, "Model of Murex cabritii."),
}


# ---------------------------------------------------------------------------------------------
# Beyond the paper
# ---------------------------------------------------------------------------------------------


def _facing(tree: Node, view: Sequence[float], to: Sequence[float]) -> Node:
    """The tree turned about y so that what ``view`` saw, ``to`` sees (both horizontal)."""
    a = math.degrees(math.atan2(-view[2], view[0]))
    b = math.degrees(math.atan2(-to[2], to[0]))
    return tree.rotate("y", b - a)


def species_figure(seed: int = 0) -> Node:
    """The shipped species (``SHELLS``) side by side, each built from its spec, turned to show
    its aperture and scaled to the same height."""
    shells = []
    for spec in SHELLS.values():
        tree = _facing(shell(spec, seed), spec.view, APERTURE_VIEW)
        lo, hi = tree.bounds()
        shells.append(tree.scale(10.0 / float(hi[1] - lo[1])))
    return _row(shells, APERTURE_VIEW, SHELL_UP, gap=1.0)


def grown_spines_figure(seed: int = 0) -> Node:
    """The Murex with its varix spines as Table 1 places them (left) and grown per varix by
    two activator-inhibitors along the lip (right, ``varices.placement = "grown"``): the number
    of spines rises varix by varix (0 to 12) instead of jumping whorl by whorl (0, 1, 1, 3, 5,
    8, 18), and long and short spines alternate.  Plain colours, so the spines read."""
    grown = replace(DEFAULT, varix_placement="grown")
    return _row([shell(DEFAULT, seed, textured=False), shell(grown, seed, textured=False)],
                APERTURE_VIEW, SHELL_UP)


def walls_figure(seed: int = 0) -> Node:
    """Eq. 15 two ways, on the Murex in plain colours: the inside wall clipped to the shell
    (left, ``opening.wall_join = "clipped"``, the shipped spec's) and the paper's union (right,
    ``"union"``), where the wall, larger than the body (``opening.wall_scale``), shows outside
    the last whorl and round the lip."""
    return _row([shell(replace(DEFAULT, wall_join=join), seed, textured=False)
                 for join in ("clipped", "union")], APERTURE_VIEW, SHELL_UP)


#: How far down the canal the varices run in :func:`canal_figure` (``varices.down_canal``).
CANAL_REACH = 0.9
#: The canal is seen from behind the lip, where the last varices' ridges face the camera.
CANAL_VIEW = (0.86, 0.0, 0.72)


def _canal_with_varices(spec: ShellSpec, seed: int) -> Node:
    """The canal sections (Eq. 10's neighbours), their varices (Eq. 13) with the ridges down
    the canal when the spec has them, and Table 2's spines, in the spec's plain colours."""
    n = spec.canal_sections
    body_c, varix_c = spec.colours[:2]
    canal = sections(spec=spec)[-n:]
    ks = range(spec.sections - n + 1, spec.sections + 1)
    ridges = [canal_ridge(k, spec) for k in ks] if spec.varices_down_canal else []
    spiny = [*(placed_varix(k, spec) for k in ks), *ridges, *canal_spines(seed, spec)]
    return blend(controlled_blend(canal, pairs=[(j, j + 1) for j in range(n - 1)]).color(body_c),
                 *(part.color(varix_c) for part in spiny))


def canal_figure(seed: int = 0) -> Node:
    """The last 1 1/3 whorls with their varices and Table 2's canal spines: the paper's, whose
    varices stop short of the canal (left, its Section 4), and ours, each varix continued down
    the canal as a ridge that carries the spines below it (right, ``varices.down_canal``
    0.9, :func:`~blobtree.models.murex.canal_ridge`)."""
    ours = replace(DEFAULT, varices_down_canal=CANAL_REACH)
    return _row([_canal_with_varices(DEFAULT, seed), _canal_with_varices(ours, seed)],
                CANAL_VIEW, SHELL_UP)


def patterns_figure(seed: int = 0) -> np.ndarray:
    """The pigment patterns of ``bt.texture.PATTERNS`` side by side, named."""
    from ..texture.pigment import pattern_sheet  # noqa: PLC0415  (images only for this figure)

    return pattern_sheet(seed=seed)


def joins_figure(seed: int = 0) -> Node:
    """Figure 8's two sections and randomly scaled bumps joined three ways: the sum (the
    whorl's far-reaching field blows the bumps up into ridges), the paper's super-elliptic
    blend n = 400 (a sharp crease round each bump) and the gradient-based blend (ours,
    :func:`~blobtree.models.murex.gradient_join`: each bump as it is, a fillet round its
    base)."""
    k = BUMP_INTERVAL
    secs = sections(canal_sections=0)[k:k + 2]
    lumps = bumps(seed, intervals=[k])
    base = controlled_blend(secs, pairs=[(0, 1)])
    joined = controlled_blend([gradient_join(secs[0], lumps), secs[1]], pairs=[(0, 1)])
    return _row([blend(base, *lumps), super_blend(base, *lumps, n=BUMP_BLEND_N), joined],
                _outward_view(6 * k + 2), SHELL_UP)


#: The sections blended together in :func:`groups_figure`: each with the next two.
GROUP_SIZE = 3
#: ... by the super-elliptic blend of this exponent.
GROUP_N = 3.0


def groups_figure() -> Node:
    """Figure 5's point whorl with Eq. 10's controlled blend (left: each section with its
    neighbour, f_i + f_j) and with group controlled blends (right: every three consecutive
    sections as one group, by the super-elliptic blend n = 3), which the paper's controlled
    blend, two objects at a time by the sum, could not express: each section meets both its
    neighbours at once, the whorls still stay apart, and n = 3 pinches the joins, so each
    section swells between them like a stage of growth."""
    secs = sections(canal_sections=0)
    pairs = [(j, j + 1) for j in range(len(secs) - 1)]
    groups = [tuple(range(j, j + GROUP_SIZE)) for j in range(len(secs) - GROUP_SIZE + 1)]
    return _row([controlled_blend(secs, pairs=pairs),
                 controlled_blend(secs, groups=groups, n=GROUP_N)], APERTURE_VIEW, SHELL_UP)


@dataclass(frozen=True)
class GridFigure:
    """A figure of several models in a labelled grid, each ray traced on its own and framed
    along ``view``: ``cells()`` gives the rows of (label, model)."""

    cells: Callable[[], list[list[tuple[str, Node]]]]
    caption: str
    view: tuple[float, float, float] = LOCAL_VIEW
    up: tuple[float, float, float] = SHELL_UP
    fov: float = 30.0


#: The corner of Raup's cube the ``raup`` figure samples: W down the rows; D, then T across.
RAUP_W, RAUP_D, RAUP_T = (1.5, 3.0, 10.0), (0.0, 0.3), (0.0, 1.0, 3.0)


def raup_cells() -> list[list[tuple[str, Node]]]:
    """Raup's cube of coiled forms (his 1966 figure): W against T at a few D, each shell of
    :func:`~blobtree.models.raup` with three whorls, apex up, seen from 40 deg above its side
    (so a planispiral shows its coil)."""
    return [[(f"W {w:g}  D {d:g}  T {t:g}", raup(w, d, t, whorls=3)) for d in RAUP_D
             for t in RAUP_T] for w in RAUP_W]


#: Figures beyond the paper (its Section 4's open problems, solved): models and images.
BEYOND: dict[str, Figure | TextureFigure | GridFigure] = {
    "species": Figure(species_figure, "Shells from data: Murex cabritii, Chicoreus ramosus and "
                                      "Oliva porphyria, each built from its spec."),
    "grown": Figure(grown_spines_figure, "Spines placed by Table 1 (left) and grown per varix "
                                         "by two activator-inhibitors along the lip (right)."),
    "walls": Figure(walls_figure, "Eq. 15 with the inside wall clipped to the shell (left) "
                                  "and as the paper's union (right)."),
    "canal": Figure(canal_figure, "Varices that stop short of the canal (left, the paper) and "
                                  "that run down it as ridges carrying Table 2's spines "
                                  "(right).", view=CANAL_VIEW, fov=15.0),
    "joins": Figure(joins_figure, "Bumps joined to the whorl by the sum (left), the "
                                  "super-elliptic blend n = 400 (centre, the paper) and the "
                                  "gradient-based blend (right).",
                    view=_outward_view(6 * BUMP_INTERVAL + 2)),
    "groups": Figure(groups_figure, "Sections blended in pairs by the sum (left, Eq. 10) and "
                                    "in groups of three by the super-elliptic blend n = 3 "
                                    "(right)."),
    "raup": GridFigure(raup_cells, "Raup's coiling parameters: the whorl expansion rate W "
                                   "down the rows; the distance from the axis D and the "
                                   "translation rate T across.",
                       view=(0.0, 0.64, -0.77)),
    "patterns": TextureFigure(patterns_figure, "Pigment grown by Meinhardt's models: stripes, "
                                               "waves, the triangles of Oliva porphyria, bands."),
}
