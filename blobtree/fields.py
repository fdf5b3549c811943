"""Field functions (falloffs): the field of a primitive as a function of distance to its skeleton.

Every falloff is written in terms of s = r^2 / R^2 (r: distance to the skeleton, R: the field
radius), is 1 at s = 0, 0 at s >= 1, and has zero slope at both ends.  The same plain Python
functions serve the numpy reference evaluator (on arrays) and the numba kernels (on scalars), so
the two cannot drift apart.
"""

from __future__ import annotations

import numpy as np

#: Names accepted by the ``falloff=`` argument of primitives, with the id used by the kernels.
FALLOFFS = {"soft_object": 0, "cubic": 1}

#: max |df/dr| * R for each falloff (the Lipschitz constant of a primitive of radius 1).
#: soft object: max over r of |dg/dr|, reached at r = 0.5035 R; cubic: 96 / (25 sqrt 5) at r = R/sqrt 5.
SLOPE = {"soft_object": 1.5834, "cubic": 96.0 / (25.0 * np.sqrt(5.0))}
SLOPE_BY_ID = np.array([SLOPE["soft_object"], SLOPE["cubic"]])


def soft_object(s):
    """Wyvill's soft object: 1 - (4/9)s^3 + (17/9)s^2 - (22/9)s; its 0.5 iso lies at r = R/2."""
    return 1.0 - (4.0 / 9.0) * s * s * s + (17.0 / 9.0) * s * s - (22.0 / 9.0) * s


def soft_object_ds(s):
    """d/ds of :func:`soft_object`."""
    return -(12.0 / 9.0) * s * s + (34.0 / 9.0) * s - 22.0 / 9.0


def cubic(s):
    """Wyvill's cubic in r^2: (1 - s)^3; its 0.5 iso lies at r = 0.454202 R."""
    t = 1.0 - s
    return t * t * t


def cubic_ds(s):
    """d/ds of :func:`cubic`."""
    t = 1.0 - s
    return -3.0 * t * t


def falloff(fid, s):
    """Falloff number ``fid`` (see :data:`FALLOFFS`) at s, for s < 1."""
    if fid == 1:
        return cubic(s)
    return soft_object(s)


def falloff_ds(fid, s):
    """Derivative d/ds of falloff ``fid`` at s, for s < 1."""
    if fid == 1:
        return cubic_ds(s)
    return soft_object_ds(s)


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
