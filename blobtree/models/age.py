"""The shell at an age: where its lip stands, and how far each part has grown by then.

A shell grows at its lip: the generating curve moves along the spiral (Eq. 8) and leaves the
whorl behind it (Eq. 9).  A murex grows in spurts: its lip advances over a section, stops, and
builds a varix there (Section 3.1: a varix ends every section) before it advances again.  Time
here is that walk: the lip advances one instance step (theta_s of Eq. 9) per unit of time and
stops :data:`VARIX_TIME` units at each varix's angle (Eq. 13) while the varix grows (at the end
of every section, whether or not the spec gives it a varix).  An
``age`` in [0, 1] is a fraction of the whole walk: at 0 the lip stands on instance 0 (the
embryonic shell, a lone generating surface), at 1 on the last instance with every varix built:
the whole shell of the spec.

Growth is continuous.  The lip's position ``lip`` is in instance units (instance i lies at
theta_s i); a part standing at position x (an instance, a set of bumps) appears as the lip moves
from x - 1 to x, scaled up from nothing about its own centre on the spiral (:meth:`Growth.size`),
so that a film of the growth has no step larger than a small step of the spiral.  A varix grows
the same way while the lip stands at its angle.  The parts the paper places relative to the
lip (the opening of Eqs. 14-15, the canal of the last sections with Table 2's spines) move with
it (:attr:`Growth.shift`); the canal leaves the oldest of its instances as gradually as it
reaches a new one, and a varix keeps its Table 2 row of canal spines (the rows repeat along the
spiral) until the lip reaches the ``len(table)``-th varix after it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..checks import Number
from ..nodes import Node
from .spec import ShellSpec

#: Time a varix takes to form, with the lip standing at its angle, in units of the time the
#: lip takes to advance one instance step (ours: the paper models the finished shell only).
VARIX_TIME = 1.0
#: A part grown to less than this share of its size is left out (a thousandth of it: below a
#: pixel of any picture of the shell, and kept out of scale factors near 0).
MIN_SIZE = 1e-3
_AGE = Number(0.0, 1.0)


def varix_position(k: int, spec: ShellSpec) -> float:
    """Position of varix k (1..sections) in instance units: over the join where section k - 1
    ends and section k begins, half an instance step after its last instance, except the last,
    which sits on the last instance, at the lip (see ``murex.varix_angle``)."""
    return min(spec.instances_per_section * k - 0.5, spec.instances - 1.0)


@dataclass(frozen=True)
class Growth:
    """The growth of a shell at ``age`` (a fraction of its life in [0, 1], see the module's
    docstring): where its lip stands and how far each part has grown."""

    spec: ShellSpec
    age: float = 1.0
    #: The lip's position along the spiral in instance units (0 .. instances - 1).
    lip: float = field(init=False)
    #: How far each varix has grown, varix k at index k - 1, each in [0, 1].
    varices: tuple[float, ...] = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "age", _AGE.check("age", self.age))
        spec = self.spec
        n = spec.sections
        stops = [varix_position(k, spec) for k in range(1, n + 1)]
        if self.age == 1.0:  # exactly the whole shell, without rounding in the walk below
            object.__setattr__(self, "lip", stops[-1])
            object.__setattr__(self, "varices", (1.0,) * n)
            return
        t = self.age * (stops[-1] + n * VARIX_TIME)  # the whole walk's time, in instance steps
        lip, formed, at = 0.0, [], 0.0
        for stop in stops:
            walk = stop - at
            if t <= walk:
                lip = at + t
                break
            t -= walk
            lip = at = stop
            formed.append(min(t / VARIX_TIME, 1.0))
            t -= VARIX_TIME
            if t <= 0.0:
                break
        object.__setattr__(self, "lip", lip)
        object.__setattr__(self, "varices", tuple(formed) + (0.0,) * (n - len(formed)))

    @property
    def full(self) -> bool:
        """Whether this is the whole shell (age 1)."""
        return self.age == 1.0

    @property
    def shift(self) -> float:
        """How far (in instance steps, <= 0) the lip stands behind the whole shell's lip: the
        parts placed relative to the lip (the opening, the canal) move by this."""
        return self.lip - (self.spec.instances - 1.0)

    def size(self, x: float) -> float:
        """How far a part at position x (instance units) has grown: 0 until the lip reaches
        x - 1, then linearly to 1 as it reaches x (instance 0 is there from the start)."""
        return _clip(self.lip - x + 1.0)

    def canal(self, i: int) -> float:
        """How far the canal under instance i has grown: with the instance, and leaving it
        over one step when the lip has moved on past the last ``canal.sections`` sections."""
        spec = self.spec
        reach = spec.canal_sections * spec.instances_per_section  # the canal's instances
        return min(self.size(i), _clip(i - (self.lip - reach))) if reach else 0.0

    def varix(self, k: int) -> float:
        """How far varix k (1..sections) has grown."""
        return self.varices[k - 1]

    def canal_spines(self, k: int) -> float:
        """How far the canal spines under varix k have grown: with the varix, and gone as the
        lip advances to the ``len(table)``-th varix after it (each row of Table 2 stays on its
        varix; the last ``len(table)`` varices carry them).  They go while the lip advances,
        not while a varix forms, so that the shell gains more than it loses at every step."""
        spec = self.spec
        later = k + len(spec.table_2)
        if later > spec.sections:
            return self.varix(k)
        start, stop = varix_position(later - 1, spec), varix_position(later, spec)
        return min(self.varix(k), 1.0 - _clip((self.lip - start) / (stop - start)))


def _clip(x: float) -> float:
    """x clipped to [0, 1], and 0 below :data:`MIN_SIZE`."""
    x = min(max(x, 0.0), 1.0)
    return 0.0 if x < MIN_SIZE else x


def grown(node: Node, size: float) -> Node:
    """A part grown to ``size`` of itself about its local origin (itself when whole)."""
    return node if size >= 1.0 else node.scale(size)
