"""Where a node's parameters sit in a compiled program, and the value-stack columns and rows
that node kernels share with the engine (docs/engine.md)."""

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


#: Columns of the value stack that, in the engine's bound pass (field only: the colour's columns
#: are free there), hold a row's gradient bound over a region and the distances from the
#: region's point over which its field surely stays below / above ISO, as an operator proved
#: them (read by operators' ``bound`` kernels).
BOUND, BELOW, ABOVE = 4, 5, 6


#: Rows at the end of a batch's value stack (engine.batch.value_rows) past its depth, free for
#: operators' ``rows`` kernels: whole rows of per-point scratch, so their loops run over the
#: batch's points one step at a time and vectorise.
ROWS_SCRATCH = 3
