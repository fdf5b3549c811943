"""Field functions (falloffs): the field of a primitive as a function of distance to its skeleton.

Every falloff is written in terms of s = r^2 / R^2 (r: distance to the skeleton, R: the field
radius), is 1 at s = 0, 0 at s >= 1, and has zero slope at both ends.  The same plain Python
functions serve the numpy reference evaluator (on arrays) and the numba kernels (on scalars), so
the two cannot drift apart.
"""

from __future__ import annotations

import math

import numpy as np

#: Names accepted by the ``falloff=`` argument of primitives, with the id used by the kernels.
FALLOFFS = {"soft_object": 0, "cubic": 1}

#: max |df/dr| * R for each falloff (the Lipschitz constant of a primitive of radius 1).
#: Rounded up: soft object 1.583430 at r = 0.5035 R; cubic 96 / (25 sqrt 5) = 1.717300 at R/sqrt 5.
SLOPE = {"soft_object": 1.58345, "cubic": 1.71731}
SLOPE_BY_ID = np.array([SLOPE["soft_object"], SLOPE["cubic"]])


def falloff(fid, s):
    """Falloff number ``fid`` (see :data:`FALLOFFS`) at s = r^2/R^2 < 1.

    0, soft object (Wyvill): 1 - (4/9)s^3 + (17/9)s^2 - (22/9)s, iso 0.5 at r = R/2 exactly;
    1, cubic: (1 - s)^3, iso 0.5 at r = 0.454202 R.
    """
    if fid == 1:
        t = 1.0 - s
        return t * t * t
    return 1.0 - (4.0 / 9.0) * s * s * s + (17.0 / 9.0) * s * s - (22.0 / 9.0) * s


def falloff_ds(fid, s):
    """Derivative d/ds of :func:`falloff` at s < 1."""
    if fid == 1:
        t = 1.0 - s
        return -3.0 * t * t
    return -(12.0 / 9.0) * s * s + (34.0 / 9.0) * s - 22.0 / 9.0


def falloff_peak(fid, c):
    """The w = u^2 in [0, 1 - c] where u |f'(u^2 + c)| peaks: the steepest point, along a line
    at squared distance c (in units of R^2) from a point primitive's centre, of its field.

    The slope g(u) = u |f'(u^2 + c)| rises from 0 and falls to 0 at u^2 = 1 - c, with one peak
    where |f'| + 2 u^2 |f'|' = 0: for the cubic 1 - s = 4 u^2; for the soft object the smaller
    root of 30 w^2 + (36 c - 51) w + 6 c^2 - 17 c + 11 = 0.
    """
    if fid == 1:
        return (1.0 - c) / 5.0
    b = 51.0 - 36.0 * c
    return (b - math.sqrt(max(b * b - 120.0 * (6.0 * c * c - 17.0 * c + 11.0), 0.0))) / 60.0


def soft_object(s):
    """Wyvill's soft object as a function of s = r^2/R^2 (for s < 1)."""
    return falloff(0, s)


def cubic(s):
    """Wyvill's cubic (1 - s)^3 (for s < 1)."""
    return falloff(1, s)


def falloff_array(name: str, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Reference: (f, df/ds) of the named falloff on an array of s, zero for s >= 1."""
    fid = FALLOFFS[name]
    inside = s < 1.0
    sc = np.where(inside, s, 1.0)
    return np.where(inside, falloff(fid, sc), 0.0), np.where(inside, falloff_ds(fid, sc), 0.0)


def iso_radius(name: str, iso: float = 0.5) -> float:
    """Distance r/R at which a lone primitive with this falloff reaches ``iso`` (bisection)."""
    fid = FALLOFFS[name]
    lo, hi = 0.0, 1.0
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if falloff(fid, mid * mid) > iso:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)
