"""The logarithmic helico-spiral of shells (paper Section 2.1, Eqs. 1-3), the Murex's spiral
(Eq. 7) and the placement P(B, theta) of a generating surface along it (Eq. 8)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, Self, TypeVar

from .checks import Number, positive


@dataclass(frozen=True)
class HelicoSpiral:
    """Eqs. 1-3 with the parameters of Eq. 7 as defaults (beta 22.5 deg, rho 1.3, R0 0.2)."""

    beta: float = 22.5
    rho: float = 1.3
    r0: float = 0.2
    #: D / R; None computes it from Eq. 3.  Eq. 7 rounds it to 0.341 for the Murex model.
    d_ratio: float | None = None

    def __post_init__(self) -> None:
        for name, kind in _KINDS.items():
            value = getattr(self, name)
            if not (name == "d_ratio" and value is None):
                object.__setattr__(self, name, kind.check(name, value))

    def radius(self, theta: float) -> float:
        """Eq. 1: R(theta) = R0 rho^(theta / 360), theta in degrees."""
        return self.r0 * self.rho ** (theta / 360.0)

    def height(self, theta: float) -> float:
        """Eq. 2: H(theta) = R(theta) cot(beta)."""
        return self.radius(theta) / math.tan(math.radians(self.beta))

    def size(self, theta: float) -> float:
        """Eq. 3: D(theta) = R(theta) / sin(beta) * (rho - 1) / (rho + 1) (= 0.341 R for Eq. 7)."""
        return self.d_over_r * self.radius(theta)

    @property
    def d_over_r(self) -> float:
        """D / R (Eq. 3, or the rounded value of Eq. 7)."""
        if self.d_ratio is not None:
            return self.d_ratio
        b = math.radians(self.beta)
        return (self.rho - 1.0) / (self.rho + 1.0) / math.sin(b)

    def centre(self, theta: float) -> tuple[float, float, float]:
        """The spiral point at theta: (R, H, 0) turned by theta about y (Eq. 8's placement)."""
        r, t = self.radius(theta), math.radians(theta)
        return r * math.cos(t), self.height(theta), -r * math.sin(t)



#: What each parameter may be (d_ratio may also be None).
_KINDS = {"beta": Number(0.1, 89.9), "rho": Number(1.000001, 1e3), "r0": positive(),
          "d_ratio": Number(1e-6, 1e3)}


#: The helico-spiral of the Murex cabritii model (Eq. 7).
MUREX_SPIRAL = HelicoSpiral(d_ratio=0.341)


def helico_spiral(theta: float) -> tuple[float, float, float]:
    """(R, H, D) of the Murex spiral (Eq. 7) at angle theta in degrees."""
    s = MUREX_SPIRAL
    return s.radius(theta), s.height(theta), s.size(theta)


class Placeable(Protocol):
    """What :func:`place` needs of a BlobTree node: the affine transforms of Eq. 8."""

    def scale(self, *factors: float) -> Self: ...
    def translate(self, x: float, y: float, z: float) -> Self: ...
    def rotate(self, axis: str, degrees: float) -> Self: ...


N = TypeVar("N", bound=Placeable)


def place(node: N, theta: float, spiral: HelicoSpiral = MUREX_SPIRAL) -> N:
    """Eq. 8: P(B, theta) = r(Y, theta)(t(R, H, 0)(s(D, D, D)(B)))."""
    d = spiral.size(theta)
    return node.scale(d).translate(spiral.radius(theta), spiral.height(theta), 0.0).rotate(
        "y", theta)
