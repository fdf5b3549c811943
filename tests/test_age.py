"""The shell at an age (``bt.models.shell(..., age=...)``, blobtree.models.age): the whole age is
the whole shell, the volume never falls as the shell grows, a varix only once the lip has passed
it, and no jump between close ages."""

from __future__ import annotations

import importlib
import math

import numpy as np
import pytest

import blobtree as bt
from blobtree.models.age import Growth

M = bt.models
varix_angle = importlib.import_module("blobtree.models.murex").varix_angle


def grid(tree: bt.Node, n: int) -> np.ndarray:
    """An n^3 grid of points over the tree's bounds."""
    lo, hi = (np.asarray(b, dtype=float) for b in tree.program().bounds)
    axes = [np.linspace(lo[k], hi[k], n) for k in range(3)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


@pytest.mark.parametrize("name", sorted(M.SHELLS))
def test_the_whole_age_is_the_shell(name):
    whole = M.shell(name, 4)
    assert M.shell(name, 4, age=1.0).key == whole.key
    assert M.shell(name, 4, age=None).key == whole.key
    assert M.shell(name, 4, age=0.9).key != whole.key


@pytest.mark.parametrize("age", [-0.1, 1.5, math.nan, "old", True])
def test_a_bad_age_is_refused_by_name(age):
    with pytest.raises(ValueError, match=r"age must be .*>= 0 and <= 1.*got"):
        M.shell("murex", 0, age=age)


@pytest.mark.slow
@pytest.mark.parametrize("name, seed", [("murex", 0), ("chicoreus", 1), ("oliva", 2)])
def test_the_volume_never_falls_as_the_shell_grows(name, seed):
    """Inside points (f >= 0.5) counted on one 36^3 grid over the whole shell, at ages a
    twentieth of the life apart, from the age the shell spans a few cells."""
    P = grid(M.shell(name, seed, textured=False), 36)
    counts = [int((M.shell(name, seed, textured=False, age=a).program().field(P) >= 0.5).sum())
              for a in np.linspace(0.4, 1.0, 13)]
    assert counts[0] > 0
    assert all(b >= a for a, b in zip(counts, counts[1:], strict=False)), counts
    assert counts[-1] > 2 * counts[0]


@pytest.mark.slow
def test_a_varix_exists_only_once_the_lip_has_passed_it():
    """Varices found in the tree by where they stand (nearest varix angle to the centre of
    their bounds) against the lip's angle; the body reaches the lip and ends within the two
    steps past it where the newest instance grows."""
    spec = M.SHELLS["murex"]
    spiral = spec.spiral
    positions = {k: spiral.centre(varix_angle(k, spec))
                 for k in range(1, spec.sections + 1)}
    for age in np.linspace(0.05, 1.0, 23):
        growth = Growth(spec, float(age))
        lip = growth.lip * spec.theta_s
        found = set()
        for v in M.varices(spec, age=float(age)):
            lo, hi = v.bounds()
            centre = 0.5 * (np.asarray(lo) + np.asarray(hi))
            found.add(min(positions, key=lambda k: np.linalg.norm(centre - positions[k])))
        angles = {k: varix_angle(k, spec) for k in positions}
        assert all(angles[k] <= lip + 1e-9 for k in found), (age, sorted(found), lip)
        assert {k for k in angles if angles[k] < lip - 1e-9} <= found, (age, lip)
        body = M.body_whorl(spec=spec, age=float(age)).program()
        at = np.array([spiral.centre(lip), spiral.centre(lip + 2.5 * spec.theta_s)])
        inside, beyond = body.field(at)
        assert inside >= 0.5 and beyond < 0.5, (age, inside, beyond)


@pytest.mark.slow
def test_growth_has_no_jumps():
    """Between ages 1e-4 apart (a fiftieth of an instance step of the Murex's walk of 146
    steps), mid-step and while a varix forms, the field moves by little anywhere."""
    whole = M.shell("murex", 0, textured=False)
    P = grid(whole, 28)
    for age in (0.5, 0.8765):
        a = M.shell("murex", 0, textured=False, age=age).program().field(P)
        b = M.shell("murex", 0, textured=False, age=age + 1e-4).program().field(P)
        assert np.abs(np.minimum(a, 1.0) - np.minimum(b, 1.0)).max() < 0.05
