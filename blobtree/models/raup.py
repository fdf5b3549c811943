"""Raup's form space: a smooth coiled shell from his four coiling parameters (D. M. Raup,
"Geometric analysis of shell coiling: general problems", J. Paleontology 40, 1966).

W (whorl expansion rate), D (distance of the generating curve from the axis) and T (translation
rate) map onto the helico-spiral of Eqs. 1-3 (:meth:`blobtree.models.HelicoSpiral.from_raup`
derives the mapping); S, the shape of the generating curve, is the shell spec's ``point_scale``.
The shell is then built exactly as the specs build their body whorl (Eqs. 9-10), from a spec that
keeps only the whorls: no canal, varices, bumps or opening.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..checks import Integer, Number
from ..fields import falloff_array
from ..helico import HelicoSpiral
from ..nodes import Node
from .murex import body_whorl
from .spec import SHELLS, ShellSpec

#: A Raup shell's sections: three per turn of six instances each (the Murex's, Eq. 9), over
#: whole turns of 360 deg, so that W is the growth over one turn.
SECTIONS_PER_TURN, INSTANCES_PER_SECTION = 3, 6
#: What S and the number of whorls may be.
_S, _WHORLS = Number(0.05, 20.0), Integer(1, 12)


def tube_point_radius(spiral: HelicoSpiral, theta_s: float) -> float:
    """The generating point's field radius (in units of the size D(theta) of Eq. 3, by which
    Eq. 8 scales it) that makes the blended instances a tube of radius D(theta): the radius r of
    Raup's generating circle.  A lone point's surface lies at half its field radius, but the
    instances of Eq. 9 overlap and their sum reaches further; the radius is solved (bisection)
    for a straight row of points at the instances' spacing, its surface one unit from the row a
    quarter of the way between two points (the surface ripples by a few percent between
    points and the spiral's growth and turn bend it slightly)."""
    c0, c1 = (np.array(spiral.centre(a)) for a in (0.0, theta_s))
    gap = float(np.linalg.norm(c1 - c0)) / spiral.size(0.5 * theta_s)
    lo, hi = 1.0, 2.0  # a lone point's surface at 1 needs field radius 2; a row needs less
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        reach = math.ceil(mid / gap) + 1
        along = (np.arange(-reach, reach + 1) - 0.25) * gap
        field = falloff_array("soft_object", (along ** 2 + 1.0) / mid ** 2)[0].sum()
        lo, hi = (lo, mid) if field > 0.5 else (mid, hi)
    return 0.5 * (lo + hi)


def raup_spec(W: float, D: float, T: float, S: float = 1.0, whorls: int = 4,
              base: ShellSpec | None = None) -> ShellSpec:
    """The shell spec of Raup's (W, D, T, S): the spiral of
    :meth:`~blobtree.models.HelicoSpiral.from_raup` (R0 = 0.2), ``whorls`` turns of 360 deg,
    the generating point scaled by (1, S, 1) (S: the generating curve's height along the axis
    over its width across it) with the field radius of ``tube_point_radius``, and nothing
    but the whorls (``base``: the Murex's spec otherwise)."""
    spiral = HelicoSpiral.from_raup(W, D, T)
    S, whorls = _S.check("S", S), _WHORLS.check("whorls", whorls)
    theta_s = 360.0 / (SECTIONS_PER_TURN * INSTANCES_PER_SECTION)
    w, d, t = spiral.raup
    return replace(
        SHELLS["murex"] if base is None else base,
        name=f"Raup W={w:g} D={d:g} T={t:g} S={S:g}", spiral=spiral, whorls=whorls,
        whorl_deg=360.0, sections_per_whorl=SECTIONS_PER_TURN,
        instances_per_section=INSTANCES_PER_SECTION,
        point_radius=tube_point_radius(spiral, theta_s), point_scale=(1.0, S, 1.0),
        canal_sections=0, table_1=[[] for _ in range(whorls)], table_2=[])


def raup(W: float, D: float, T: float, S: float = 1.0, whorls: int = 4) -> Node:
    """A smooth coiled shell of Raup's coiling parameters: W the whorl expansion rate per turn
    (> 1), D the generating curve's inner edge's distance from the axis over its outer edge's
    (0 <= D < 1; 0: the whorls reach the axis), T the translation along the axis per distance
    from it (0: a planispiral) and S the generating curve's height over its width.

    The spiral is Eqs. 1-3 with rho = W, beta = atan(1 / T) and D / R = (1 - D) / (1 + D)
    (:meth:`~blobtree.models.HelicoSpiral.from_raup` derives it); the shell is Eq. 10's body
    whorl of :func:`raup_spec`: sections of a third of a turn, each blended with its neighbours
    along the spiral only, so whorls that touch do not swell into each other.  Shown apex up.

    The tube's outer edge lies where Raup's generating circle puts it; where r nears R (D near 0)
    the blended instances crowd on the inside of each turn and the tube swells toward the axis
    (at D = 0.1 its inner edge lies at 0.04 R instead of 0.18 R; within 0.06 R of Raup's from
    D = 0.3 on: tests/test_raup.py)."""
    spec = raup_spec(W, D, T, S, whorls)
    return body_whorl(canal_sections=0, spec=spec).shown(up=spec.up, view=spec.view)
