"""Thin parts: how thick the solid is under its surface, measured on the field.

A printer cannot make what is thinner than its nozzle.  At points of the surface (a mesh's
vertices), :func:`measure` walks into the solid along the inward normal (-grad f / ``|grad f|``)
until the field falls below the iso-value again: that distance is the thickness *across*.  From
the middle of that chord it then walks both ways along ``DIRECTIONS`` directions of the tangent
plane; the shortest such chord is the feature's *width*.  A spine (a rod) is about as wide as
it is thick; a wall (a sheet) is much wider than thick.  Walks take steps of ``step`` and end
with a bisection, so a thickness is exact to ``step / 2**BISECTIONS`` where the field crosses
0.5 once per step (features thinner than a step can be stepped over: choose ``step`` below the
thinnest feature you care about); points thinner than a step are knife edges, counted apart.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..nodes.node import ISO

#: Tangent directions tried for a feature's width.
DIRECTIONS = 8
#: A feature narrower than this many times its thickness is a rod (a spine), else a sheet.
ROD = 2.5
#: Bisection steps that end each walk.
BISECTIONS = 8


@dataclass(frozen=True)
class Thickness:
    """Per surface point: where it is, its thickness across (along the inward normal; ``depth``
    where the walk found no other side) and its width (the shortest tangent chord through the
    feature's middle)."""

    points: np.ndarray
    across: np.ndarray
    width: np.ndarray
    depth: float
    step: float

    @property
    def edges(self) -> np.ndarray:
        """Points thinner than a step: knife edges (such as the rim a difference carves), which
        the walk cannot resolve; they are neither rods nor sheets."""
        return self.across < self.step

    @property
    def rods(self) -> np.ndarray:
        """Points on rod-like features (spines): narrower than ``ROD`` times their thickness."""
        return (self.width < ROD * self.across) & (self.across < self.depth) & ~self.edges

    @property
    def sheets(self) -> np.ndarray:
        """Points on sheet-like features (walls) whose other side was found."""
        return ~self.rods & (self.across < self.depth) & ~self.edges

    def thinnest(self, mask: np.ndarray) -> tuple[float, np.ndarray] | None:
        """(thickness, point) of the thinnest point in ``mask``, or None if it holds none."""
        if not mask.any():
            return None
        i = np.flatnonzero(mask)[np.argmin(self.across[mask])]
        return float(self.across[i]), self.points[i]


def _walk(field, start: np.ndarray, direction: np.ndarray, step: float, depth: float
          ) -> np.ndarray:
    """Distance from each start point (inside) along its direction to where the field first
    falls below ISO, or ``depth`` if it does not within ``depth``."""
    n = len(start)
    inside_t = np.zeros(n)
    out_t = np.full(n, np.inf)
    active = np.arange(n)
    t = 0.0
    while len(active) and t < depth:
        t = min(t + step, depth)
        f = field(start[active] + t * direction[active])
        left = f < ISO
        out_t[active[left]] = t
        inside_t[active[~left]] = t
        active = active[~left]
    found = np.isfinite(out_t)
    lo, hi = inside_t[found], out_t[found]
    s, d = start[found], direction[found]
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        f = field(s + mid[:, None] * d)
        lo, hi = np.where(f >= ISO, mid, lo), np.where(f >= ISO, hi, mid)
    out = np.full(n, float(depth))
    out[found] = 0.5 * (lo + hi)
    return out


def _enter(field, points: np.ndarray, direction: np.ndarray, step: float) -> np.ndarray:
    """Distance along ``direction`` from each point to the first inside point (field >= ISO),
    by steps of step / 8 (at most 16); 0 for points already inside."""
    entry = np.zeros(len(points))
    active = np.flatnonzero(field(points) < ISO)
    for k in range(1, 17):
        if not len(active):
            break
        t = k * step / 8.0
        inside = field(points[active] + t * direction[active]) >= ISO
        entry[active[inside]] = t
        active = active[~inside]
    return entry


def measure(prog, points: np.ndarray, step: float, depth: float) -> Thickness:
    """Thickness and width of the solid under surface ``points`` (N, 3) of ``prog`` (anything
    with ``field`` and ``gradient``), walking by ``step`` up to ``depth``."""
    points = np.asarray(points, float)
    g = prog.gradient(points)
    gn = np.linalg.norm(g, axis=1, keepdims=True)
    inward = g / np.where(gn > 0.0, gn, 1.0)  # the field rises inward
    # a mesh vertex lies within a cell of the surface: step in until inside, then walk across
    entry = _enter(prog.field, points, inward, step)
    start = points + entry[:, None] * inward
    across = _walk(prog.field, start, inward, step, depth)
    middle = start + 0.5 * across[:, None] * inward
    # an orthonormal tangent basis (u, v) per point
    helper = np.where(np.abs(inward[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u = np.cross(inward, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(inward, u)
    width = np.full(len(points), np.inf)
    for a in np.linspace(0.0, np.pi, DIRECTIONS, endpoint=False):
        d = np.cos(a) * u + np.sin(a) * v
        chord = _walk(prog.field, middle, d, step, depth) + _walk(prog.field, middle, -d, step,
                                                                    depth)
        width = np.minimum(width, chord)
    return Thickness(points, across, width, float(depth), float(step))
