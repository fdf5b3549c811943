"""whorl126: the common benchmark scene (docs/conventions.md)."""

from __future__ import annotations

from ..helico import place
from ..nodes import Blend, Node, Point

#: Angle between consecutive generating surfaces: 116/6 degrees (Section 3.1).
THETA_S = 116.0 / 6.0


def whorl126() -> Node:
    """126 instances of a point of visible radius 1 (field radius 2) placed by Eq. 8 at
    theta = i * 116/6 degrees, i = 0..125, all combined by plain blend (docs/conventions.md)."""
    return Blend(*(place(Point(radius=2.0), i * THETA_S) for i in range(126)))
