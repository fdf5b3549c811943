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
        for name, kind in KINDS.items():
            value = getattr(self, name)
            if not (name == "d_ratio" and value is None):
                object.__setattr__(self, name, kind.check(name, value))

    def radius(self, theta: float) -> float:
        """Eq. 1: R(theta) = R0 rho^(theta / 360), theta in degrees."""
        return self.r0 * self.rho ** (theta / 360.0)

    def height(self, theta: float) -> float:
        """Eq. 2: H(theta) = R(theta) cot(beta) (0 at beta = 90 deg: a planispiral)."""
        if self.beta == 90.0:
            return 0.0
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

    @classmethod
    def from_raup(cls, W: float, D: float, T: float, r0: float = 0.2) -> HelicoSpiral:
        """The spiral of Raup's coiling parameters (D. M. Raup, "Geometric analysis of shell
        coiling: general problems", J. Paleontology 40, 1966), for a circular generating curve.

        Raup's shell is a generating curve of radius r whose centre, at distance R from the
        coiling axis and Y along it, turns about the axis; per turn R, r and Y all grow by the
        factor W.  Eqs. 1-3 describe the same curve: Eq. 1 grows R by rho per 360 deg, Eq. 3
        makes the size D(theta) = k R (k = D / R) grow with it, and Eq. 2 puts the centre at
        H = R cot(beta) along the axis.  Hence

        * W = rho (the whorl expansion rate);
        * T = Y / R = H / R = cot(beta), so beta = atan(1 / T): T = 0 is beta = 90 deg, no
          displacement along the axis (a planispiral);
        * D = (R - r) / (R + r), the inner edge's distance from the axis over the outer edge's,
          with r = D(theta) = k R: D = (1 - k) / (1 + k), so k = (1 - D) / (1 + D).  D = 0
          puts the inner edge on the axis (k = 1).

        Raup's fourth parameter, the shape S of the generating curve, is not the spiral's: see
        :func:`blobtree.models.raup`."""
        checks = {"W": Number(1.000001, 1e3), "D": Number(0.0, 0.999999),
                  "T": Number(0.0, 500.0)}
        W, D, T = (kind.check(name, v) for (name, kind), v in zip(checks.items(), (W, D, T),
                                                                  strict=True))
        beta = 90.0 if T == 0.0 else math.degrees(math.atan(1.0 / T))
        return cls(beta=beta, rho=W, r0=r0, d_ratio=(1.0 - D) / (1.0 + D))

    @property
    def raup(self) -> tuple[float, float, float]:
        """(W, D, T): Raup's coiling parameters of this spiral (see :meth:`from_raup`)."""
        k = self.d_over_r
        return self.rho, (1.0 - k) / (1.0 + k), self.height(0.0) / self.radius(0.0)

    def centre(self, theta: float) -> tuple[float, float, float]:
        """The spiral point at theta: (R, H, 0) turned by theta about y (Eq. 8's placement)."""
        r, t = self.radius(theta), math.radians(theta)
        return r * math.cos(t), self.height(theta), -r * math.sin(t)



#: What each parameter may be (d_ratio may also be None).
KINDS = {"beta": Number(0.1, 90.0), "rho": Number(1.000001, 1e3), "r0": positive(),
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
