"""The shell's geometry computed from the paper's equations and the spec's documented numbers,
not through the package's spiral or model code: the expectations of the shell tests."""

from __future__ import annotations

import math

import numpy as np

# Eq. 7
BETA, RHO, R0, D_RATIO = 22.5, 1.3, 0.2, 0.341
#: Section 3.1: six instances per 116-degree section.
THETA_S = 116.0 / 6.0


def spiral(theta: float) -> tuple[float, float, float]:
    """Eqs. 1-3 with the parameters of Eq. 7: R, H and D at theta (degrees)."""
    r = R0 * RHO ** (theta / 360.0)
    return r, r / math.tan(math.radians(BETA)), D_RATIO * r


def world(local, theta: float) -> np.ndarray:
    """Eq. 8 after the paper-frame turn r(X, 180): local (x, y, z) in units of D -> world."""
    p = np.atleast_2d(np.asarray(local, float)) * (1.0, -1.0, -1.0)
    r, h, d = spiral(theta)
    p = p * d + (r, h, 0.0)
    c, s = math.cos(math.radians(theta)), math.sin(math.radians(theta))
    return np.stack([c * p[:, 0] + s * p[:, 2], p[:, 1], -s * p[:, 0] + c * p[:, 2]], axis=1)


def varix_theta(k: int) -> float:
    """Where varix k lies (Sections 3.1 and 3.4): over the join of sections k - 1 and k, which
    end and start with instances 6k - 1 and 6k (Eq. 10), so at (6k - 0.5) theta_s; the 21st,
    the last, at the lip: the last instance, 125 theta_s (106 1/3 degrees after the 20th)."""
    return 125 * THETA_S if k == 21 else (6 * k - 0.5) * THETA_S


def _canal_arc(spec) -> tuple[float, float]:
    """(radius, angle in radians) of the canal's bend: it turns by ``canal.tilt`` and moves
    toward the axis (x = -1 / 0.341, Eq. 7) from ``canal.base`` to ``canal.gap`` from it."""
    tau = math.radians(spec.canal_tilt)
    return (spec.canal_base[0] + 1.0 / D_RATIO - spec.canal_gap) / (1.0 - math.cos(tau)), tau


def canal_line(spec, t: float) -> tuple[np.ndarray, np.ndarray]:
    """Point and outward unit normal (x, y) in the paper's local frame at arc length t along the
    canal of a Murex spec as its keys describe it: from ``canal.base``, leaving tilted
    ``canal.tilt`` degrees from the shell axis toward it (and away from the apex, -y), bent along
    a circular arc back parallel to the axis at ``canal.gap`` from it, then straight for
    ``canal.straight``.  The normal points away from the axis."""
    rho, tau = _canal_arc(spec)
    bx, by = spec.canal_base
    centre = np.array([bx + rho * math.cos(tau), by - rho * math.sin(tau)])
    a = tau - min(t, rho * tau) / rho
    normal = np.array([math.cos(a), -math.sin(a)])
    return centre - rho * normal + max(t - rho * tau, 0.0) * np.array([0.0, -1.0]), normal


def canal_length(spec) -> float:
    """The canal's length along its centre line: the arc of :func:`canal_line`, then straight."""
    rho, tau = _canal_arc(spec)
    return rho * tau + spec.canal_straight


def suture(field, theta: float, reach: float = 2.5, samples: int = 1001) -> float:
    """How far out the surface lies across the outer suture at theta, in units of D(theta): from
    the point where the whorls at theta and theta - 360 touch (Eq. 3: their circles are
    tangent, the contact D0 / (D0 + D1) along the line of centres, which runs at beta to the
    axis, Figure 1) outward, perpendicular to that line, to where ``field`` (points (N, 3) ->
    (N,)) falls below 0.5; sampled every reach / (samples - 1)."""
    r1, h1, d1 = spiral(theta)
    r0, h0, d0 = spiral(theta - 360.0)
    contact = np.array([r0, h0]) + d0 / (d0 + d1) * np.array([r1 - r0, h1 - h0])
    beta = math.radians(BETA)
    t = np.linspace(0.0, reach * d1, samples)
    q = contact + t[:, None] * (math.cos(beta), -math.sin(beta))
    c, s = math.cos(math.radians(theta)), math.sin(math.radians(theta))
    inside = field(np.stack([q[:, 0] * c, q[:, 1], -q[:, 0] * s], axis=1)) >= 0.5
    assert inside[0]  # the whorls touch
    return float(t[np.argmax(~inside)] / d1)
