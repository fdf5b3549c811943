"""The distance-aware Lipschitz bound of point primitives that segment tracing steps by."""

from __future__ import annotations

import numpy as np
import pytest

import blobtree as bt
from blobtree.fields import falloff_ds


@pytest.mark.parametrize(
    "tree",
    [
        bt.models.whorl126(),
        (bt.Point(radius=1.5).scale(1.0, 2.0, 0.5).rotate("x", 30.0).translate(0.2, 0.0, 0.0)
         + bt.Point(radius=1.0, center=(0.7, 0.0, 0.0))) | bt.Point(radius=0.5, falloff="cubic"),
    ],
)
def test_small_box_bounds_hold(tree):
    prog = tree.program()
    lo, hi = prog.bounds
    rng = np.random.default_rng(1)
    for _ in range(150):
        c = rng.uniform(lo, hi)
        e = rng.uniform(0.0, 0.1, 3) * (hi - lo)
        bound = prog.lipschitz((c - e)[None], (c + e)[None])[0]
        P = c + rng.uniform(-1.0, 1.0, (1500, 3)) * e
        assert np.linalg.norm(prog.gradient(P), axis=1).max() <= bound * (1 + 1e-9) + 1e-12


def test_bound_follows_the_distance_to_the_centre():
    R = 2.0
    prog = bt.Point(radius=R).program()
    for rho in (0.1, 0.75, 0.95):  # a tiny box at distance rho R: the slope there, not the peak
        c = np.array([rho * R, 0.0, 0.0])
        bound = prog.lipschitz((c - 1e-9)[None], (c + 1e-9)[None])[0]
        exact = abs(falloff_ds(0, rho * rho)) * 2.0 * rho / R  # soft object
        # (exact up to the rounding up of the engine's peak slope constant)
        assert exact <= bound <= exact * (1 + 1e-4)
    c = np.array([1.1 * R, 0.0, 0.0])  # outside the support: no slope at all
    assert prog.lipschitz((c - 0.01)[None], (c + 0.01)[None])[0] == 0.0
