"""Gradual features: spines placed and sized by activator-inhibitors along the growing lip.

The paper's Table 1 lists each whorl's spines by hand, and "the number and placement of spines
suddenly change from one whorl to another" (its Section 4); its authors name reaction-diffusion
as the way forward.  Here the lip (the generating curve's angles alpha, one cell per
``CELL_DEG``) carries two of Meinhardt's activator-inhibitor systems (ABoSS Eq. 2.1, the model
of ``bt.texture``), run through the shell's growth.

Where the spines are (:data:`MODEL`): a cell can make a spine only while it is competent.  The
competent arc grows from the first spined whorl's angles of the spec's Table 1 to the last
whorl's (linearly in time), as the Murex's spiny shoulder widens down its whorls; outside it the
source density is 0, so no activator forms.  A stable Turing pattern keeps its peaks where they
are, so as the arc widens, new peaks are inserted at its edge, one or two at a time: the spines'
number and spacing change gradually.  Each varix takes the activator's peaks at the time it
forms, ``STEPS_PER_VARIX`` steps after the one before.

How long they are (:data:`SIZE_MODEL`): a second, slower system whose activator can be made only
where the first is above its uniform level, that is at the spines.  Its inhibitor reaches about
one spine spacing, so neighbouring spines compete: one grows long and suppresses the next, and
long and short spines alternate, with the defects (two short ones side by side) of Table 1's
rows.  Its rates are a quarter of the first system's, so it is still settling as new spines
arrive, and the varices of one whorl differ.  A spine's delta is its size activator's level in
proportion to the highest on the shell, over Table 1's range of deltas.  Deterministic: the
source fluctuations come from fixed seeds.
"""

from __future__ import annotations

import functools

import numpy as np

from ..texture.pigment import ActivatorInhibitor
from .spec import ShellSpec

#: Degrees of lip per cell, and the lip's angles (the generating curve's outer half).
CELL_DEG = 1.0
LIP = (-90.0, 90.0)
#: Time steps between two varices (the spines' Turing pattern settles within a few hundred).
STEPS_PER_VARIX = 200
#: Peaks below this multiple of the activator's uniform steady state make no spine.
PEAK_LEVEL = 1.5
#: Where the spines are: a Turing pattern of wavelength about 15 cells (ABoSS Eq. 2.1).
#: A small basic production b_a lets newly competent cells (a = 0) start a peak.
MODEL = ActivatorInhibitor(d_a=0.005, d_b=0.45, r_a=0.03, r_b=0.04, b_a=0.002, fluctuation=0.05)
#: How long they are: the same diffusion with a quarter of the rates, so the inhibitor reaches
#: twice as far (sqrt(d_b / r_b): 13 cells against 7) and the pattern forms four times slower;
#: fluctuations of 20 % vary the long spines and leave defects in the alternation.
SIZE_MODEL = ActivatorInhibitor(d_a=0.005, d_b=0.45, r_a=0.0075, r_b=0.01, b_a=0.001,
                                fluctuation=0.2)


def _arcs(spec: ShellSpec) -> list[tuple[float, float] | None]:
    """Each whorl's competent arc (lo, hi) in degrees, or None before the first spines: from
    the first spined whorl's angles to the last whorl's, linearly."""
    rows = spec.table_1
    spined = [w for w, row in enumerate(rows) if row]
    if not spined:
        return [None] * len(rows)
    first, last = spined[0], len(rows) - 1
    lo0, hi0 = min(a for a, _ in rows[first]), max(a for a, _ in rows[first])
    lo1, hi1 = (min(a for a, _ in rows[spined[-1]]), max(a for a, _ in rows[spined[-1]]))
    out: list[tuple[float, float] | None] = []
    for w in range(len(rows)):
        if w < first:
            out.append(None)
            continue
        t = 1.0 if last == first else (w - first) / (last - first)
        out.append((lo0 + t * (lo1 - lo0) - CELL_DEG, hi0 + t * (hi1 - hi0) + CELL_DEG))
    return out


@functools.lru_cache(maxsize=8)
def grown_varices(spec: ShellSpec) -> tuple[tuple[tuple[float, float], ...], ...]:
    """Table 1 grown, one row per varix (1..sections): (alpha_i, delta_i) of each spine."""
    angles = np.arange(LIP[0], LIP[1] + CELL_DEG / 2, CELL_DEG)
    state = MODEL.start(len(angles), np.random.default_rng(0))
    sources = state[2].copy()
    size = SIZE_MODEL.start(len(angles), np.random.default_rng(1))
    size_sources = size[2].copy()
    a_star = MODEL.steady_state()[0]
    arcs = _arcs(spec)
    per = spec.sections_per_whorl
    peaks: list[list[tuple[float, float]]] = []
    for w, arc in enumerate(arcs):
        if arc is None:  # before the first spines: no competent cells, nothing grows
            peaks += [[] for _ in range(per)]
            continue
        prev = arcs[w - 1] if w > 0 and arcs[w - 1] is not None else arc
        for v in range(per):
            for k in range(STEPS_PER_VARIX):
                f = (v * STEPS_PER_VARIX + k + 1) / (per * STEPS_PER_VARIX)  # the arc widens
                lo = prev[0] + f * (arc[0] - prev[0])
                hi = prev[1] + f * (arc[1] - prev[1])
                state[2] = np.where((angles >= lo) & (angles <= hi), sources, 0.0)
                MODEL.step(state)
                size[2] = size_sources * np.maximum(state[0] / a_star - 1.0, 0.0)
                SIZE_MODEL.step(size)
            a = state[0]
            top = (a[1:-1] > a[:-2]) & (a[1:-1] >= a[2:]) & (a[1:-1] > PEAK_LEVEL * a_star)
            peaks.append([(float(angles[i]), float(size[0][i]))
                          for i in np.flatnonzero(top) + 1])
    top_size = max((c for row in peaks for _, c in row), default=1.0)
    deltas = [d for row in spec.table_1 for _, d in row] or [1.0]
    lo_d, hi_d = min(deltas), max(deltas)
    return tuple(tuple((alpha, round(lo_d + (hi_d - lo_d) * c / top_size, 3)) for alpha, c in row)
                 for row in peaks)
