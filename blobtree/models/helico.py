"""The logarithmic helico-spiral of Section 2.1 and the placement P(B, theta) of Equation 8."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..nodes import Node


@dataclass(frozen=True)
class HelicoSpiral:
    """Eqs. 1-3 with the parameters of Eq. 7 as defaults (beta 22.5 deg, rho 1.3, R0 0.2)."""

    beta: float = 22.5
    rho: float = 1.3
    r0: float = 0.2
    #: D / R; None computes it from Eq. 3.  Eq. 7 rounds it to 0.341 for the Murex model.
    d_ratio: float | None = None

    def __post_init__(self) -> None:
        if not (0.0 < self.beta < 90.0):
            raise ValueError(f"beta must be in (0, 90) degrees, got {self.beta!r}")
        if not (self.rho > 1.0 and math.isfinite(self.rho)):
            raise ValueError(f"rho must be a finite number > 1, got {self.rho!r}")
        if not (self.r0 > 0.0 and math.isfinite(self.r0)):
            raise ValueError(f"r0 must be a finite number > 0, got {self.r0!r}")

    def radius(self, theta: float) -> float:
        """Eq. 1: R(theta) = R0 rho^(theta / 360), theta in degrees."""
        return self.r0 * self.rho ** (theta / 360.0)

    def height(self, theta: float) -> float:
        """Eq. 2: H(theta) = R(theta) cot(beta)."""
        return self.radius(theta) / math.tan(math.radians(self.beta))

    def size(self, theta: float) -> float:
        """Eq. 3: D(theta) = R(theta) / sin(beta) * (rho - 1) / (rho + 1) (= 0.341 R for Eq. 7)."""
        if self.d_ratio is not None:
            return self.d_ratio * self.radius(theta)
        b = math.radians(self.beta)
        return self.radius(theta) / math.sin(b) * (self.rho - 1.0) / (self.rho + 1.0)

    def place(self, node: Node, theta: float) -> Node:
        """Eq. 8: P(B, theta) = r(Y, theta)(t(R, H, 0)(s(D, D, D)(B)))."""
        d = self.size(theta)
        return node.scale(d).translate(self.radius(theta), self.height(theta), 0.0).rotate(
            "y", theta
        )


#: The helico-spiral of the Murex cabritii model (Eq. 7).
MUREX_SPIRAL = HelicoSpiral(d_ratio=0.341)


def helico_spiral(theta: float) -> tuple[float, float, float]:
    """(R, H, D) of the Murex spiral (Eq. 7) at angle theta in degrees."""
    s = MUREX_SPIRAL
    return s.radius(theta), s.height(theta), s.size(theta)


def place(node: Node, theta: float) -> Node:
    """Eq. 8 on the Murex spiral: scale by D, translate by (R, H, 0), rotate by theta about y."""
    return MUREX_SPIRAL.place(node, theta)
