"""The tracer's bundles as numba types: the signatures of the kernels compiled once and called
by symbol (``runtime.linked``) - the packet tracer, the packet shader and a cone's packet.

Each type spells what its maker allocates: the view (``tiles.render_arguments``), a packet's
scratch (``tiles._packet_scratch``), a cone of pixels (``tiles._render_blocks``).  A caller
passing anything else is refused while it is typed.
"""

from __future__ import annotations

from numba import types

from ..engine.batch import ROWS
from ..engine.point import PROGRAM, STACKS
from ..engine.specialize import BUFFERS

_F1, _F2, _I1, _I2 = (types.float64[::1], types.float64[:, ::1], types.int64[::1],
                      types.int64[:, ::1])
_I, _F = types.int64, types.float64
#: ``trace_packet``'s scratch: (pk, ids, rows).
TRACE_SCRATCH = types.Tuple((_F2, _I2, ROWS))
#: ``tiles.render_arguments``' view: camera, lights, bounds, sizes, shadows, backdrop, look,
#: steps, seed, depths.
VIEW = types.Tuple((_F1, _F2, _F1, _F1, _I, _I, _I, types.boolean, _F2, types.uint8[:, ::1],
                    _F1, _F, _F, _F, _I, _F, _F))
#: A program specialised to a box, with the box: (program, lo, hi).
LOCAL = types.Tuple((PROGRAM, _F1, _F1))
#: ``tiles._packet_scratch``: sums, ray table, rays, shadow rays, surface table, the tracer's
#: scratch, room for a specialised program, the occlusion samples.
PACKET = types.Tuple((_F2, _F2, _F2, _F2, _F2, _F2, _F2, _F2, _I2, ROWS,
                      types.Tuple((BUFFERS, _I2, _F1, _F1)),
                      types.Tuple((_I1, _F2))))
#: A cone of a packet's pixels: (sx0, sy0, sx1, sy1, t_start, t_local, seg0).
CONE = types.Tuple((_I, _I, _I, _I, _F, _F, _F))
#: ``trace.trace_packet(prog, (O, D), n, (t, t_end), (eps, eps_rel), delta0, out, refine,
#: scratch, st)``.
TRACE_PACKET = types.none(PROGRAM, types.UniTuple(_F2, 2), _I, types.UniTuple(_F1, 2),
                          types.Tuple((_F1, _F)), _F, _F1, types.boolean, TRACE_SCRATCH, STACKS)
#: ``shade.shade_packet(prog, local, n, view, packet, st)``.
SHADE_PACKET = types.none(PROGRAM, LOCAL, _I, VIEW, PACKET, STACKS)
#: ``tiles.sub_block(prog, local, view, cone, packet, st)``.
SUB_BLOCK = types.none(PROGRAM, LOCAL, VIEW, CONE, PACKET, STACKS)
