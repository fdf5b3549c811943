"""The layout of a compiled program and of the stacks that run it, named once for the engine and
the node kernels (docs/engine.md): an instruction's fields, where a node's parameters sit, the
value stack's and the point stack's columns, and the evaluation modes."""

from __future__ import annotations

from typing import Any

import numpy as np

#: params[o + MAP : o + MAP + 12]: the 3x4 map from the frame to the primitive's own coordinates
MAP = 0
#: params[o + RADIUS]: the field radius R; params[o + FALLOFF]: the falloff's id (fields.FALLOFFS)
RADIUS, FALLOFF = 12, 13
#: params[o + MAP_NORM]: the spectral norm of the map's linear part (a ball of radius r in the frame
#: lies in a ball of radius MAP_NORM r in the primitive's own coordinates)
MAP_NORM = 14
#: params[o + FRAME_NORM] of a PUSHPT (entering a warp's frame): its 3x4 map's norm
FRAME_NORM = 12
#: the primitive's own parameters start here (see :class:`Layout`)
GEOMETRY = 15


class Layout:
    """Named offsets of a node type's own parameters in the program, from ``start``.

    ``Layout(GEOMETRY, a=3, b=3, radius_a=1)`` places a at start, b at start + 3, radius_a at
    start + 6; ``.offsets`` gives those numbers for the kernels (module constants, so numba
    compiles them in) and ``.pack(a=..., b=..., radius_a=...)`` the values in that order.
    """

    def __init__(self, start: int = 0, **widths: int) -> None:
        self.start = start
        self.widths = widths
        offsets, at = [], start
        for w in widths.values():
            offsets.append(at)
            at += w
        self.offsets = tuple(offsets)
        self.size = at - start

    def pack(self, **values: Any) -> list[float]:
        """The values flattened in layout order; each must have its declared width."""
        if set(values) != set(self.widths):
            raise TypeError(f"layout needs {sorted(self.widths)}, got {sorted(values)}")
        out: list[float] = []
        for name, width in self.widths.items():
            flat = np.asarray(values[name], dtype=np.float64).reshape(-1)
            if flat.size != width:
                raise ValueError(f"layout field {name} has width {width}, got {flat.size}")
            out.extend(float(v) for v in flat)
        return out


# ----- instructions: code[i, field] ----------------------------------------------------------
#: code[i, OP]: the opcode (engine.dispatch); code[i, OFFSET]: where its parameters start in
#: params; code[i, SKIP]: the instruction after its subtree (a box that misses jumps there);
#: code[i, ARG]: an operator's child count, a primitive's texture image offset (-1: none).
OP, OFFSET, SKIP, ARG = 0, 1, 2, 3
#: Fields of an instruction.
FIELDS = 4

# ----- evaluation modes -----------------------------------------------------------------------
#: What a point's evaluation computes: the field only (tracing), also its gradient, or also its
#: colour (shading).  Work a mode does not need is skipped by ``mode >= GRADIENT`` tests.
VALUE, GRADIENT, SHADE = 0, 1, 2

# ----- the value stack: vs[row, column] -------------------------------------------------------
#: vs[row, FIELD]: a row's field; vs[row, GRAD:GRAD + 3] its gradient; vs[row, COLOR:COLOR + 3]
#: its colour (sRGB in [0, 1]).
FIELD, GRAD, COLOR = 0, 1, 4
#: The bound passes carry no colour; in the colour's columns a row holds its bound on
#: ``|grad f|`` over the region (BOUND) and the distances from the region's point over which its
#: field surely stays below / above ISO (BELOW, ABOVE), as an operator proved them (read by
#: operators' ``bound`` kernels).
BOUND, BELOW, ABOVE = 4, 5, 6
#: In the bound pass along rays: how fast a row's field can rise and fall along a cone of
#: directions.
RISES, FALLS = 7, 8
#: In the value-aware bound pass: the least and the most a row's field can be anywhere in the
#: region (its range), in the rise and fall columns that pass does not use.
LEAST, MOST = 7, 8
#: In the value-free bound pass, row pp's columns REGION .. REGION + 5 save the region (lo, hi)
#: while a warp's frame is entered (the row's own values are not needed there).
REGION = 1
#: Columns of a value stack.
COLUMNS = 9
#: Columns a point's evaluation leaves (field, gradient, colour): enough for stacks that run
#: no bound pass.
RESULT_COLUMNS = COLOR + 3

# ----- the point stack: ps[pp, column], one row per warp frame entered ------------------------
#: ps[pp, POINT:POINT + 3]: the point to restore on leaving the frame; ps[pp, JACOBIAN:
#: JACOBIAN + 9]: the Jacobian from the frame to the outer one, row by row; ps[pp, WARP:WARP + 18]
#: a warp's scratch (its Jacobian in the canonical axes, then the product).  The bound pass keeps
#: the region (lo, hi) in ps[pp, SAVED_BOX:SAVED_BOX + 6] (it needs no Jacobian).
POINT, JACOBIAN, WARP, SAVED_BOX = 0, 3, 12, 3
#: Columns of a point stack.
POINT_COLUMNS = 30


#: Rows at the end of a batch's value stack (engine.batch.value_rows) past its depth, free for
#: operators' ``rows`` kernels: whole rows of per-point scratch, so their loops run over the
#: batch's points one step at a time and vectorise.
ROWS_SCRATCH = 3
