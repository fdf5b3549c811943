"""Rendering one rectangle of the image: the unit of parallel and distributed work.

Every pixel depends only on its own coordinates and those of its cone's other pixels (anti-
aliasing jitter comes from a hash of the seed, the pixel and the sample index; the cones marched
ahead of the rays lie on a grid fixed to the image, and all the rays of a cone are traced
together whatever part of it a rectangle wants), so any set of tiles, rendered in any order on
any machine, assembles into a byte-identical image.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..checks import Integer, Number
from ..engine.batch import BATCH, point_rows, value_rows
from ..engine.specialize import specialize, specialize_work
from ..nodes.layout import COLUMNS, POINT_COLUMNS, RESULT_COLUMNS
from ..runtime.jit import kernel, linked
from .bundles import SUB_BLOCK
from .camera import Camera, as_color
from .shade import (
    AMBIENT,
    CR,
    EPS,
    HIT,
    INSIDE,
    LIGHT_TAN,
    OCC,
    OCCLUSION,
    OCCLUSION_RADIUS,
    OCCLUSION_SAMPLES,
    OUT,
    SHININESS,
    SKY,
    SPECULAR,
    T0,
    T1,
    T_END,
    Light,
    T,
    linear_to_srgb_byte,
    pack_lights,
    shade_packet,
    srgb_to_linear_array,
)
from .trace import LOW, PACKET_ROWS, RISE, clip_box, march_cone, trace_packet

#: Largest image side accepted (a 16384^2 image is 805 MB of RGB).
MAX_SIDE = 16384
MAX_SAMPLES = 1024
#: Range of a camera ray's smallest step, in pixels (``RenderSettings.step``).
MIN_STEP, MAX_STEP = 0.05, 8.0
#: Smallest ray step, as a fraction of the scene's diagonal (camera rays also allow
#: ``RenderSettings.step`` pixels' footprint).
EPS_SCENE = 1e-6
#: Shadow-ray start offset along the normal, as a fraction of the scene's diagonal.
SHADOW_OFFSET = 1e-4
#: Side in pixels of the cones marched before the rays (see ``_render_blocks``); a PACKET_SIDE
#: cone's rays are traced together (at most ``batch.BATCH`` of them: one batch of the engine).
CONE_SIDE, PACKET_SIDE = 16, 8
#: Length of the stretch of a PACKET_SIDE cone (in cone radii) its specialised program covers.
LOCAL_SPAN = 12.0
#: First candidate segment of a ray, as a fraction of its chord through the bounds box.
DELTA0 = 0.02
#: First candidate segment of a ray leaving a stopped cone, in radii of that cone.
PIXEL_SPAN = 4.0


@dataclass(frozen=True)
class RenderSettings:
    """Everything besides the scene, camera and lights that decides the pixels.

    The defaults are the plain look of the paper's figures (``LOOKS["paper"]``).  ``background``
    is the backdrop's colour at the top of the image; ``background_bottom``, if given, the colour
    it fades to at the bottom (a studio backdrop).  ``occlusion`` (0-1) darkens the ambient light
    in creases, from field samples up to ``occlusion_radius`` (a fraction of the scene's
    diagonal) along the normal; ``light_radius`` (degrees, 0 = a point: hard shadows) is the
    angular radius of every light seen from the scene, an area light whose penumbra widens with
    the distance from occluder to receiver; ``sky`` (0-1) dims the ambient light on surfaces
    facing down (-y); ``step`` is a camera ray's smallest step, in pixels (a feature thinner
    than that along the ray may be skipped: half a pixel keeps the thinnest spines' tips; a
    draft drawn while a control moves may take longer ones)."""

    width: int
    height: int
    samples: int = 1
    shadows: bool = True
    background: tuple[float, float, float] = (1.0, 1.0, 1.0)
    ambient: float = 0.12
    specular: float = 0.25
    shininess: float = 40.0
    seed: int = 0
    background_bottom: tuple[float, float, float] | None = None
    occlusion: float = 0.0
    occlusion_radius: float = 0.03
    light_radius: float = 0.0
    sky: float = 0.0
    step: float = 0.5

    def __post_init__(self) -> None:
        for name, kind in (("width", Integer(1, MAX_SIDE)), ("height", Integer(1, MAX_SIDE)),
                           ("samples", Integer(1, MAX_SAMPLES)), ("seed", Integer(0, 2**32 - 1))):
            object.__setattr__(self, name, kind.check(name, getattr(self, name)))
        for name in ("background", "background_bottom"):
            value = getattr(self, name)
            if value is not None or name == "background":
                object.__setattr__(self, name, tuple(float(c) for c in as_color(name, value)))
        for name in ("ambient", "specular", "shininess"):
            object.__setattr__(self, name, Number(lo=0.0, hi=1e6).check(name, getattr(self, name)))
        for name, kind in (("occlusion", Number(lo=0.0, hi=1.0)),
                           ("occlusion_radius", Number(lo=0.0, hi=1.0, lo_open=True)),
                           ("light_radius", Number(lo=0.0, hi=30.0)),
                           ("sky", Number(lo=0.0, hi=1.0)),
                           ("step", Number(lo=MIN_STEP, hi=MAX_STEP))):
            object.__setattr__(self, name, kind.check(name, getattr(self, name)))
        if not isinstance(self.shadows, bool | np.bool_):
            raise ValueError(f"shadows must be True or False, got {str(self.shadows)[:60]}")

    def packed_look(self, diagonal: float) -> np.ndarray:
        """The shading values for the kernels (layout: ``shade.AMBIENT`` ...)."""
        look = np.zeros(7)
        look[AMBIENT], look[SPECULAR], look[SHININESS] = self.ambient, self.specular, \
            self.shininess
        look[OCCLUSION], look[OCCLUSION_RADIUS] = self.occlusion, self.occlusion_radius * diagonal
        look[LIGHT_TAN] = math.tan(math.radians(self.light_radius))
        look[SKY] = self.sky
        return look

    @cached_property
    def backdrop(self) -> tuple[np.ndarray, np.ndarray]:
        """Each image row's backdrop: (height, 3) linear RGB and (height, 3) sRGB bytes,
        computed once (every tile reads them; decoding them per tile took 0.12 ms of numpy a
        tile, holding the lock other tiles wait on)."""
        top = np.array(self.background)
        bottom = top if self.background_bottom is None else np.array(self.background_bottom)
        s = ((np.arange(self.height) + 0.5) / self.height)[:, None]
        rows = top + (bottom - top) * s * s  # light above, darkening toward the floor
        return srgb_to_linear_array(rows), (rows * 255.0 + 0.5).astype(np.int64).astype(np.uint8)


#: Named looks: keyword values for :class:`RenderSettings`.  ``paper``: the plain style of the
#: paper's figures (white, one light, hard shadows); ``studio``: a soft backdrop, soft shadows,
#: ambient occlusion and a sky-lit ambient; ``glossy``: studio with a polished shell.
LOOKS: dict[str, dict] = {
    "paper": {},
    "studio": dict(background=(0.99, 0.99, 0.99), background_bottom=(0.55, 0.57, 0.62),
                   ambient=0.3, sky=0.7, occlusion=1.0, occlusion_radius=0.08,
                   light_radius=4.0, specular=0.15, shininess=30.0),
}
LOOKS["glossy"] = dict(LOOKS["studio"], specular=0.7, shininess=120.0)


def check_rect(settings: RenderSettings, x0: int, y0: int, x1: int, y1: int) -> None:
    """ValueError unless 0 <= x0 < x1 <= width and 0 <= y0 < y1 <= height."""
    if not (0 <= x0 < x1 <= settings.width and 0 <= y0 < y1 <= settings.height):
        raise ValueError(
            f"tile (x0, y0, x1, y1) = ({x0}, {y0}, {x1}, {y1}) must satisfy "
            f"0 <= x0 < x1 <= {settings.width} and 0 <= y0 < y1 <= {settings.height}"
        )


def render_tile(prog, camera: Camera, lights: list[Light], settings: RenderSettings,
                x0: int, y0: int, x1: int, y1: int) -> np.ndarray:
    """Pixels [y0, y1) x [x0, x1) of the image, as a (y1 - y0, x1 - x0, 3) uint8 array."""
    check_rect(settings, x0, y0, x1, y1)
    if not isinstance(camera, Camera):
        raise ValueError(f"camera must be a blobtree Camera, got {type(camera).__name__[:60]}")
    return trace_rect(prog, camera.packed(settings.width, settings.height), pack_lights(lights),
                      settings, x0, y0, x1, y1)


def stop_flag() -> np.ndarray:
    """A new stop flag, unset: a one-element int8 array that another thread sets (to 1) to give
    a render up (:func:`trace_rect`, ``render.local_tiles``)."""
    return np.zeros(1, dtype=np.int8)


def trace_rect(prog, cam: np.ndarray, lights: np.ndarray, settings: RenderSettings,
               x0: int, y0: int, x1: int, y1: int, stop: np.ndarray | None = None
               ) -> np.ndarray:
    """:func:`render_tile` on an already packed camera and lights (no argument checks).
    ``stop`` (:func:`stop_flag`), once another thread sets it, gives the tile up: its tracing
    then ends at the next packet of 8x8 pixels, the pixels left unfinished."""
    args = render_arguments(prog, cam, lights, settings, x0, y0, x1, y1, stop)
    _render_blocks(*args)
    return args[3]


def compile_tracer(prog, cam: np.ndarray, lights: np.ndarray, settings: RenderSettings) -> None:
    """Compile the kernels :func:`trace_rect` runs for these arguments (one pixel's), without
    running them (a partner process's work, ``runtime.partner``)."""
    args = render_arguments(prog, cam, lights, settings, 0, 0, 1, 1)
    _render_blocks.compile(tuple(_render_blocks.typeof_pyval(a) for a in args))


def render_arguments(prog, cam: np.ndarray, lights: np.ndarray, settings: RenderSettings,
                     x0: int, y0: int, x1: int, y1: int, stop: np.ndarray | None = None
                     ) -> tuple:
    """The arguments of the tracer's kernel for pixels [y0, y1) x [x0, x1): the program, the
    view, the tile, the pixels (to fill), buffers, stacks and the stop flag (``trace_rect``)."""
    lo, hi = (np.asarray(b, dtype=np.float64) for b in prog.bounds)
    diag = float(np.linalg.norm(hi - lo))
    s = settings
    out = np.empty((y1 - y0, x1 - x0, 3), dtype=np.uint8)
    bg, bg_bytes = s.backdrop
    # Camera rays may skip features thinner than ``step`` pixels' footprint (along the ray):
    # cam[9:12] spans half the image's height at unit distance.
    eps_rel = 2.0 * s.step * float(np.linalg.norm(cam[9:12])) / s.height
    # No ray meets the surface before reaching the bounds box, nor after its farthest corner.
    eye = cam[:3]
    t_near = float(np.linalg.norm(np.maximum(np.maximum(lo - eye, 0.0), eye - hi)))
    t_far = float(np.linalg.norm(np.maximum(np.abs(eye - lo), np.abs(eye - hi))))
    view = (cam, lights, lo, hi, s.width, s.height, s.samples, s.shadows, bg, bg_bytes,
            s.packed_look(diag), EPS_SCENE * diag, eps_rel, SHADOW_OFFSET * diag, s.seed, t_near,
            t_far)
    # Blocks and sub-blocks lie on a grid fixed to the image, not to the rectangle, and their
    # cones always cover the whole grid cell: a pixel's result never depends on the tiling.
    gx0, gy0 = x0 // CONE_SIDE, y0 // CONE_SIDE
    nbx, nby = (x1 - 1) // CONE_SIDE - gx0 + 1, (y1 - 1) // CONE_SIDE - gy0 + 1
    st = (np.empty((prog.depth, COLUMNS)), np.empty((prog.depth, POINT_COLUMNS)))
    # (specialising is never nested: one serves every call; the scratch comes from the
    # kernels' own Python, so that a render loads one kernel, not four: 12-15 ms a command)
    work = specialize_work.py_func(prog.code)
    buffers = (_program_buffers(len(prog.code)), _program_buffers(len(prog.code)), np.empty(3),
               np.empty(3), work, _packet_scratch(prog.depth, len(prog.code), work))
    if stop is None:
        stop = stop_flag()
    return prog.arrays, view, (x0, y0, x1, y1, gx0, gy0, nbx, nby), out, buffers, st, stop


def _program_buffers(n: int) -> tuple:
    """Room for a program of up to n instructions specialised to a box (code, boxes, lips)."""
    return np.empty((n, 4), dtype=np.int64), np.empty((n, 6)), np.empty(n)


def _packet_scratch(depth: int, ncode: int, work: np.ndarray) -> tuple:
    """The scratch of ``_sub_block`` for a cone of n = PACKET_SIDE^2 rays: the pixels' sums
    (n, 4); the ray table (``shade.T`` ...); the camera rays' origins and directions, the shadow
    rays' (n, 3 each); the surface table (``shade.NX`` ...); :func:`trace_packet`'s (its rows,
    its ids, and ``eval_rows``' (pts, vs, tmp)); room for a program of up to ``ncode``
    instructions specialised to a box, ``specialize``'s ``work`` and the box; and the occlusion
    samples of the hits (``shade._occlusions``: which sample each batch lane holds, and their
    values)."""
    n = PACKET_SIDE * PACKET_SIDE
    return (np.empty((n, 4)), np.empty((10, n)), np.empty((n, 3)), np.empty((n, 3)),
            np.empty((n, 3)), np.empty((n, 3)), np.empty((n, OCC + 1)),
            np.empty((PACKET_ROWS, n)), np.empty((3, n), dtype=np.int64),
            (point_rows.py_func(depth), value_rows.py_func(depth),
             np.empty((depth, RESULT_COLUMNS))),
            (_program_buffers(ncode), work, np.empty(3), np.empty(3)),
            (np.empty(BATCH, dtype=np.int64), np.empty((n, OCCLUSION_SAMPLES))))


@kernel
def _hash(a):
    """A 32-bit integer mix (Wellons' lowbias32 shape) on int64 values in [0, 2^32)."""
    a ^= a >> 16
    a = (a * 0x7FEB352D) & 0xFFFFFFFF
    a ^= a >> 15
    a = (a * 0x5BD1E995) & 0xFFFFFFFF
    a ^= a >> 16
    return a


@kernel
def _uniform(seed, x, y, s, k):
    """A reproducible uniform number in [0, 1) for sample s, coordinate k of pixel (x, y)."""
    h = _hash((seed ^ x) & 0xFFFFFFFF)
    h = _hash((h + y) & 0xFFFFFFFF)
    h = _hash((h + s * 2 + k) & 0xFFFFFFFF)
    return h / 4294967296.0


@kernel
def _ray(cam, width, height, x, y):
    """Unit direction of the camera ray through image point (x, y) (in pixels)."""
    sx = 2.0 * x / width - 1.0
    sy = 1.0 - 2.0 * y / height
    dx = cam[3] + sx * cam[6] + sy * cam[9]
    dy = cam[4] + sx * cam[7] + sy * cam[10]
    dz = cam[5] + sx * cam[8] + sy * cam[11]
    n = np.sqrt(dx * dx + dy * dy + dz * dz)
    return dx / n, dy / n, dz / n


@kernel
def _block_start(prog, view, rect, span, st):
    """A depth in span = (t, t_far) before which no ray through the pixels of rect = (bx0, by0,
    bx1, by1) meets the surface (:func:`march_cone` on the cone around them), inf if none of
    them does; and the cone's unit axis and tan of its half-angle."""
    cam, width, height = view[0], view[4], view[5]
    bx0, by0, bx1, by1 = rect
    ax, ay, az = _ray(cam, width, height, 0.5 * (bx0 + bx1), 0.5 * (by0 + by1))
    tan_a = 0.0
    for cx in (bx0, bx1):
        for cy in (by0, by1):
            dx, dy, dz = _ray(cam, width, height, cx, cy)
            c = dx * ax + dy * ay + dz * az
            tan_a = max(tan_a, np.sqrt(max(1.0 - c * c, 0.0)) / c)
    tan_a *= 1.000001
    t = march_cone(prog, (cam[0], cam[1], cam[2]), (ax, ay, az), tan_a, span[0], span[1], st)
    return t, ax, ay, az, tan_a


def _sub_block(prog, local, view, cone, packet, st):
    """Trace and shade the pixels of cone = (sx0, sy0, sx1, sy1, t_start, t_local, seg0) (a
    cone's), every ray starting at depth t_start (finite): their linear RGB summed over the
    samples into acc[k, 0:3] and the number of rays that hit into acc[k, 3] (``packet[0]``; k =
    the pixel's row-major place in the cone; the backdrop where a ray misses).  The rays are
    traced together (:func:`trace_packet`): up to depth t_local, where they stay in the box
    [llo, lhi] the program of ``local = (program, llo, lhi)`` is specialised to, with first
    candidate segment ``seg0``, then on the full program; and shaded together
    (:func:`shade_packet`).  All the cone's pixels are traced and shaded, whatever part of them
    a tile wants, so no pixel depends on the tiling.  ``view``: see :func:`trace_rect`;
    ``packet``: the scratch ``trace_rect`` allocates."""
    cam, _, lo, hi, width, height, samples, _, bg, _, _, eps_abs, eps_rel, _, seed, _, _ = view
    sx0, sy0, sx1, sy1, t_start, t_local, seg0 = cone
    acc, rays, O, D, _, _, surf, pk, ids, rows, _, _ = packet
    nx = sx1 - sx0
    n = nx * (sy1 - sy0)
    m = int(np.ceil(np.sqrt(samples)))
    nrows = (samples + m - 1) // m
    for k in range(n):
        acc[k, 0] = acc[k, 1] = acc[k, 2] = acc[k, 3] = 0.0
    for s in range(samples):
        delta0 = seg0
        for k in range(n):
            px, py = sx0 + k % nx, sy0 + k // nx
            if samples == 1:
                u = 0.5
                v = 0.5
            else:
                u = (s % m + _uniform(seed, px, py, s, 0)) / m
                v = (s // m + _uniform(seed, px, py, s, 1)) / nrows
            O[k, 0], O[k, 1], O[k, 2] = cam[0], cam[1], cam[2]
            D[k, 0], D[k, 1], D[k, 2] = _ray(cam, width, height, px + u, py + v)
            t0, t1 = clip_box(cam[0], cam[1], cam[2], D[k, 0], D[k, 1], D[k, 2], lo, hi,
                              t_start, np.inf)
            rays[T0, k], rays[T1, k], rays[EPS, k] = t0, t1, eps_abs
            rays[T, k], rays[T_END, k] = t0, min(t1, t_local)
            pk[LOW, k], pk[RISE, k] = np.inf, 0.0
            if t0 <= t1:
                delta0 = min(delta0, DELTA0 * (t1 - t0))
        trace_packet(local[0], (O, D), n, (rays[T], rays[T_END]), (rays[EPS], eps_rel),
                     delta0 + eps_abs, rays[OUT], True, (pk, ids, rows), st)
        d_full = np.inf
        for k in range(n):  # rays that got past the local stretch go on on the full program
            rays[HIT, k], rays[INSIDE, k] = rays[OUT, k], 1.0
            rays[T, k], rays[T_END, k] = 1.0, 0.0
            if rays[OUT, k] < 0.0 and rays[T0, k] <= rays[T1, k] and t_local < rays[T1, k]:
                rays[T, k], rays[T_END, k] = max(rays[T0, k], t_local), rays[T1, k]
                rays[INSIDE, k] = 0.0
                d_full = min(d_full, DELTA0 * (rays[T1, k] - rays[T, k]))
        trace_packet(prog, (O, D), n, (rays[T], rays[T_END]), (rays[EPS], eps_rel),
                     d_full + eps_abs, rays[OUT], True, (pk, ids, rows), st)
        for k in range(n):
            if rays[INSIDE, k] == 0.0:
                rays[HIT, k] = rays[OUT, k]
        shade_packet(prog, local, n, view, packet, st)
        for k in range(n):
            if rays[HIT, k] < 0.0:
                for c in range(3):
                    acc[k, c] += bg[sy0 + k // nx, c]
                continue
            for c in range(3):
                acc[k, c] += surf[k, CR + c]
            acc[k, 3] += 1.0


#: :func:`_sub_block` compiled once, called by symbol (``runtime.linked``): the tracer's kernel
#: then links only its own blocks' code, not every packet's tracing and shading again.
cone_packet = linked(SUB_BLOCK)(_sub_block)
sub_block = cone_packet.call


@kernel
def _localize(prog, eye, cone, depths, out, box):
    """Specialise the program to the box around the cone (apex: the eye, cone = (ax, ay, az,
    tan_a): unit axis a, half-angle atan(tan_a)) between axis depths depths = (t_a, t_b), into
    the buffers ``out`` (with ``specialize``'s work), the box into box = (lo, hi); return the
    program (``PROGRAM``: views of the buffers)."""
    ax, ay, az, tan_a = cone
    t_a, t_b = depths
    lo, hi = box
    r = t_b * tan_a
    for k in range(3):
        a = eye[k] + t_a * (ax, ay, az)[k]
        b = eye[k] + t_b * (ax, ay, az)[k]
        lo[k] = min(a, b) - r
        hi[k] = max(a, b) + r
    code, work = out
    n = specialize(prog, lo, hi, code, work)
    return code[0][:n], prog[1], code[1][:n], code[2][:n]


@kernel(nogil=True)
def _render_blocks(prog, view, tile, out, buffers, st, stop):
    """Pixels [x0, x1) x [y0, y1) into ``out``, on one core without the GIL, on buffers
    ``trace_rect`` allocated: tile = (x0, y0, x1, y1, gx0, gy0, nbx, nby), the nbx x nby blocks of
    CONE_SIDE^2 pixels from block (gx0, gy0), each first marched as one cone, then as cones of
    PACKET_SIDE^2 pixels (on the program specialised to the block cone's stretch past where it
    stopped, then on the whole program beyond it); each of those specialises the program to the
    stretch of its cone just past where it stopped, then traces its rays together there
    (:func:`_sub_block`).  Compiled without reference counting (like every kernel on the way
    from here to the field: numba's atomic counts on the shared program arrays cost a quarter
    of the time with two threads), so nothing here allocates or keeps an array.  Once
    stop[0] is set (by another thread) it returns before the next packet."""
    cam, width, height, samples, bg_bytes = view[0], view[4], view[5], view[6], view[9]
    t_near, t_far = view[15], view[16]
    x0, y0, x1, y1, gx0, gy0, nbx, nby = tile
    block_buffers, cone_buffers, rlo, rhi, work, packet = buffers
    eye = (cam[0], cam[1], cam[2])
    for b in range(nbx * nby):
        bx0 = (gx0 + b % nbx) * CONE_SIDE
        by0 = (gy0 + b // nbx) * CONE_SIDE
        bx1 = min(bx0 + CONE_SIDE, width)
        by1 = min(by0 + CONE_SIDE, height)
        tb, bax, bay, baz, btan = _block_start(prog, view, (bx0, by0, bx1, by1), (t_near, t_far),
                                               st)
        # the block's cones march first on the program specialised to the block's stretch
        t_blk = tb
        blk = prog
        if tb < np.inf:
            t_blk = min(tb + LOCAL_SPAN * tb * btan, t_far)
            blk = _localize(prog, eye, (bax, bay, baz, btan),
                            (tb / np.sqrt(1.0 + btan * btan), t_blk), (block_buffers, work),
                            (rlo, rhi))
        for sy0 in range(by0, by1, PACKET_SIDE):
            for sx0 in range(bx0, bx1, PACKET_SIDE):
                sx1 = min(sx0 + PACKET_SIDE, bx1)
                sy1 = min(sy0 + PACKET_SIDE, by1)
                if sx1 <= x0 or sx0 >= x1 or sy1 <= y0 or sy0 >= y1:
                    continue
                if stop[0] != 0:
                    return
                ts = tb
                t_local = tb
                seg0 = np.inf
                local = prog
                if tb < np.inf:
                    rect = (sx0, sy0, sx1, sy1)
                    ts, ax, ay, az, tan_a = _block_start(blk, view, rect, (tb, t_blk), st)
                    if ts == np.inf and t_blk < t_far:  # past the block's stretch
                        ts, ax, ay, az, tan_a = _block_start(prog, view, rect, (t_blk, t_far), st)
                    if ts < np.inf:
                        t_local = ts + LOCAL_SPAN * ts * tan_a
                        seg0 = PIXEL_SPAN * ts * tan_a
                        local = _localize(prog, eye, (ax, ay, az, tan_a),
                                          (ts / np.sqrt(1.0 + tan_a * tan_a), t_local),
                                          (cone_buffers, work), (rlo, rhi))
                if ts < np.inf:
                    sub_block(prog, (local, rlo, rhi), view,
                              (sx0, sy0, sx1, sy1, ts, t_local, seg0), packet, st)
                acc = packet[0]
                for py in range(max(sy0, y0), min(sy1, y1)):
                    for px in range(max(sx0, x0), min(sx1, x1)):
                        k = (py - sy0) * (sx1 - sx0) + px - sx0
                        if ts == np.inf or acc[k, 3] == 0.0:  # no ray of the pixel hit
                            for c in range(3):
                                out[py - y0, px - x0, c] = bg_bytes[py, c]
                            continue
                        for c in range(3):
                            out[py - y0, px - x0, c] = linear_to_srgb_byte(acc[k, c] / samples)
