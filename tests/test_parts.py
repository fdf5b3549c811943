"""A shell's parts kept between builds (blobtree/models/parts.py): a build that takes kept
parts is the tree built afresh, for a change of every spec value the explorer has a control
for, the tables it has none for, the seed, the look and the age."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from blobtree.checks import Choice, Integer
from blobtree.live import _controls_of, slider_range, with_control
from blobtree.models import parts
from blobtree.models.murex import local_varices, shell
from blobtree.models.spec import SHELLS, Flag, Numbers

MUREX = SHELLS["murex"]


def _other(kind, value):
    """Another value a control of ``kind`` may take."""
    if isinstance(kind, Flag):
        return not value
    if isinstance(kind, Choice):
        return next(o for o in kind.options if o != value)
    if isinstance(kind, Numbers):  # a colour
        return (0.3, 0.6, 0.9)
    lo, hi = slider_range(kind, value)
    step = 0.1 * (hi - lo)
    new = value + step if value + step <= hi else value - step
    return max(int(round(new)), int(lo)) if isinstance(kind, Integer) else new


def _changes():
    """(label, spec, seed, textured, age) of each change built."""
    for name, (_, kind, value) in _controls_of(MUREX).items():
        try:
            yield name, with_control(MUREX, name, _other(kind, value)), 0, True, 1.0
        except ValueError:  # (a value the spec refuses: nothing to build)
            continue
    rows = MUREX.table_2
    yield "table_2", replace(MUREX, table_2=rows[:-1] + ((rows[-1][0], rows[-1][1] * 1.1),)), \
        0, True, 1.0
    yield "table_1", replace(MUREX, table_1=MUREX.table_1[:-1] + (
        tuple((a * 1.05, d) for a, d in MUREX.table_1[-1]),)), 0, True, 1.0
    yield "seed", MUREX, 7, True, 1.0
    yield "plain", MUREX, 0, False, 1.0
    yield "age", MUREX, 0, True, 0.6


@pytest.mark.slow
def test_a_build_from_kept_parts_is_the_one_built_afresh():

    def key(spec, seed, textured, age, kept=parts.FRESH) -> str:
        try:
            return shell(spec, seed, textured=textured, age=age, parts=kept).key
        except ValueError as e:  # (a bend too tight for its spine: refused either way)
            return f"refused: {e}"

    built = 0
    for label, *change in _changes():
        kept = parts.Parts(8)
        shell(MUREX, 0, parts=kept)  # the base's parts at hand
        assert key(*change, kept=kept) == key(*change), label
        built += 1
    assert built > 60  # nearly every control (the spec refuses a few of the values)


def test_a_spiral_change_keeps_the_pieces_in_their_local_frames():
    """The bumps, varices and canal spines are built in their local frames apart from their
    placing by Eq. 8, which alone reads the spiral: a change of the spiral places the very
    nodes of the build before again (their keys and boxes known), as it did the whole part."""
    def local_pieces(tree) -> set[int]:  # what lies below each Eq. 8 placing (r(Y) t s)
        out = set()
        for node in tree.walk():
            if node.TYPE == "rotate" and node.axis == "y" and node.child.TYPE == "translate" \
                    and node.child.child.TYPE == "scale":  # the placing's scale by D ...
                out.add(id(node.child.child.child))  # ... and the piece it scales
        return out

    kept = parts.Parts(2)
    before = shell(MUREX, 0, parts=kept)
    after = shell(with_control(MUREX, "spiral.beta", MUREX.spiral.beta + 1.0), 0, parts=kept)
    assert after.key != before.key and after.key == shell(with_control(
        MUREX, "spiral.beta", MUREX.spiral.beta + 1.0), 0).key
    shared = local_pieces(before) & local_pieces(after)
    # every bump, varix and canal spine (the body's instances read the spiral themselves)
    pieces = sum(1 for n in after.walk() if n.TYPE in ("texture", "color")
                 and n.child.TYPE == "rotate" and n.child.axis == "y")
    assert len(shared) >= pieces > 300


def test_a_change_of_the_canal_keeps_the_varices():
    """The varices and the canal spines are parts apart: tilting the canal builds its spines
    again, not the varices (their spines are the very nodes of the build before)."""
    kept = parts.Parts(2)
    before = shell(MUREX, 0, parts=kept)
    tilted = with_control(MUREX, "canal.tilt", MUREX.canal_tilt + 5.0)
    after = shell(tilted, 0, parts=kept)
    assert after.key == shell(tilted, 0).key
    bends = {id(n) for n in before.walk() if n.TYPE == "bend"}
    kept_bends = {n.key for n in after.walk() if id(n) in bends}
    varix_bends = {n.key for _, _, v in local_varices(MUREX) for n in v.walk()
                   if n.TYPE == "bend"}
    assert kept_bends == varix_bends and len(varix_bends) > 10


def test_a_part_is_kept_until_a_value_it_read_changes():
    calls = []

    def build(spec, k):
        calls.append(k)
        return [spec.canal_tilt * k]

    kept = parts.Parts(2)
    first = kept.part("test", build, MUREX, 2)
    assert kept.part("test", build, replace(MUREX, bump_size=0.3), 2) is first  # not read
    assert calls == [2]
    assert kept.part("test", build, replace(MUREX, canal_tilt=40.0), 2) == [80.0]
    assert kept.part("test", build, MUREX, 3) == [MUREX.canal_tilt * 3]  # another argument
    assert calls == [2, 2, 3]
    assert kept.part("test", build, MUREX, 2) is not first  # the oldest of three, dropped
    assert calls == [2, 2, 3, 2]
    assert parts.FRESH.part("test", build, MUREX, 2) is not parts.FRESH.part(
        "test", build, MUREX, 2)  # keeps nothing


def test_same_tells_values_apart_to_the_bit():
    assert parts.same((1.0, (2.0, "a")), (1.0, (2.0, "a")))
    assert not parts.same(0.0, -0.0)
    assert not parts.same(1, 1.0)
    assert parts.same(np.arange(3.0), np.arange(3.0))
    assert not parts.same(np.arange(3.0), np.arange(3.0) + 1e-16 * 3)
    assert parts.same(MUREX.spiral, replace(MUREX.spiral))
    assert not parts.same(MUREX.spiral, replace(MUREX.spiral, beta=MUREX.spiral.beta + 1e-9))
