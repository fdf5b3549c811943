"""The logarithmic helico-spiral of Section 2.1 and the placement P(B, theta) of Equation 8."""

from __future__ import annotations

from ..nodes import Node
from ..spiral import HelicoSpiral

__all__ = ["MUREX_SPIRAL", "HelicoSpiral", "helico_spiral", "place"]

#: The helico-spiral of the Murex cabritii model (Eq. 7).
MUREX_SPIRAL = HelicoSpiral(d_ratio=0.341)


def helico_spiral(theta: float) -> tuple[float, float, float]:
    """(R, H, D) of the Murex spiral (Eq. 7) at angle theta in degrees."""
    s = MUREX_SPIRAL
    return s.radius(theta), s.height(theta), s.size(theta)


def place(node: Node, theta: float, spiral: HelicoSpiral = MUREX_SPIRAL) -> Node:
    """Eq. 8: P(B, theta) = r(Y, theta)(t(R, H, 0)(s(D, D, D)(B)))."""
    d = spiral.size(theta)
    return node.scale(d).translate(spiral.radius(theta), spiral.height(theta), 0.0).rotate(
        "y", theta)
