"""Lights and shading: Blinn-Phong with shadows (hard, or soft from the field), ambient occlusion
from the field, in linear RGB, encoded to sRGB at the end."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..checks import Number
from ..engine.batch import BATCH, eval_rows
from ..engine.point import eval_point
from ..engine.specialize import specialize
from ..nodes import kernel_math
from ..nodes.layout import COLOR, FIELD, GRAD, GRADIENT, SHADE
from ..nodes.node import ISO
from ..runtime.jit import kernel, linked
from .bundles import SHADE_PACKET
from .camera import Camera, as_color, as_vec3
from .trace import LOW, PEAK, RISE, clip_box, trace_packet

#: Row layout of the packed light array: kind (0 directional, 1 point), xyz, linear rgb.
DIRECTIONAL, POINT = 0.0, 1.0


@dataclass(frozen=True)
class Light:
    """A light: ``direction`` (the way the light travels, e.g. (0, -1, 0) shines straight down)
    or ``position`` (a point light, no falloff), with an RGB ``color`` in [0, 1] and an
    ``intensity`` multiplier."""

    direction: tuple[float, float, float] | None = None
    position: tuple[float, float, float] | None = None
    color: tuple[float, float, float] = (1.0, 1.0, 1.0)
    intensity: float = 1.0

    def __post_init__(self) -> None:
        if (self.direction is None) == (self.position is None):
            raise ValueError(
                f"Light needs exactly one of direction or position, got direction="
                f"{self.direction!r}, position={self.position!r}"
            )
        if self.direction is not None:
            d = as_vec3("direction", self.direction)
            if not np.linalg.norm(d) > 0.0:
                raise ValueError(f"direction must be a non-zero vector, got {self.direction!r}")
        else:
            as_vec3("position", self.position)
        as_color("color", self.color)
        Number(lo=0.0, hi=1e6).check("intensity", self.intensity)

    def packed(self) -> np.ndarray:
        """The light as one kernel row: kind, toward-light direction (unit) or position, rgb."""
        rgb = srgb_to_linear_array(as_color("color", self.color)) * self.intensity
        if self.direction is not None:
            d = -as_vec3("direction", self.direction)
            return np.concatenate([[DIRECTIONAL], d / np.linalg.norm(d), rgb])
        return np.concatenate([[POINT], as_vec3("position", self.position), rgb])


def default_lights(camera: Camera) -> list[Light]:
    """One white key light from above, to the left of and behind the camera."""
    fwd, right, up = camera.basis()
    toward = -fwd * 1.0 - right * 0.7 + up * 0.8
    return [Light(direction=tuple(-toward / np.linalg.norm(toward)))]


def pack_lights(lights: list[Light]) -> np.ndarray:
    """(n, 7) float64 array of the lights for the kernels."""
    if len(lights) == 0:
        return np.zeros((0, 7))
    for i, light in enumerate(lights):
        if not isinstance(light, Light):
            raise ValueError(f"lights[{i}] must be a blobtree Light, got "
                             f"{type(light).__name__[:60]}")
    return np.stack([light.packed() for light in lights])


def srgb_to_linear_array(c: np.ndarray) -> np.ndarray:
    """sRGB-encoded [0, 1] values to linear light (IEC 61966-2-1)."""
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


@kernel
def srgb_to_linear(c):
    """Scalar version of :func:`srgb_to_linear_array`."""
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


#: Where the 8-bit sRGB code steps up: the linear value of each half level (k - 0.5) / 255,
#: k = 1 ... 255 (:func:`linear_to_srgb_byte`).
SRGB_STEPS = srgb_to_linear_array((np.arange(1, 256) - 0.5) / 255.0)


@kernel
def linear_to_srgb_byte(c):
    """Linear light (clamped to [0, 1]) to its 8-bit sRGB code, rounded: how many of the
    :data:`SRGB_STEPS` it reaches, by binary search (no power per pixel)."""
    lo, hi = 0, SRGB_STEPS.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if SRGB_STEPS[mid] <= c:
            lo = mid + 1
        else:
            hi = mid
    return np.uint8(lo)


#: Layout of the packed look (``RenderSettings.packed_look``): ambient, specular, shininess,
#: occlusion strength, occlusion radius (scene units), tan of the lights' angular radius, sky.
AMBIENT, SPECULAR, SHININESS, OCCLUSION, OCCLUSION_RADIUS, LIGHT_TAN, SKY = range(7)
#: Field samples along the normal for ambient occlusion.
OCCLUSION_SAMPLES = 4


@kernel
def _occlusions(prog, local, n, look, packet):
    """Ambient occlusion in [0, 1] at every hit of the packet, into column OCC of the surface
    table, from the field alone: a lone surface falls off along its normal as 0.5 - slope * d
    (slope = ``|grad f|`` at the hit), so whatever the samples at d = radius * k /
    OCCLUSION_SAMPLES exceed that by is other surface nearby (a crease, the inside of the
    aperture); nearer samples weigh more.  The samples in the local program's box [llo, lhi]
    are evaluated on it, the rest on the full program, a batch at a time
    (``batch.eval_rows``).  ``local = (program, llo, lhi)``."""
    _, rays, O, D, _, _, surf, _, _, rows, _, hits = packet
    pts, vs = rows[0], rows[1]
    which, values = hits
    lprog, llo, lhi = local
    radius = look[OCCLUSION_RADIUS]
    ns = OCCLUSION_SAMPLES
    for in_local in (True, False):
        run = lprog if in_local else prog
        m = 0
        for q in range(n * ns + 1):
            if q < n * ns and rays[HIT, q // ns] >= 0.0:
                k, kk = q // ns, q % ns + 1
                t = rays[HIT, k]
                d = radius * kk / ns
                x = O[k, 0] + t * D[k, 0] + d * surf[k, NX]
                y = O[k, 1] + t * D[k, 1] + d * surf[k, NY]
                z = O[k, 2] + t * D[k, 2] + d * surf[k, NZ]
                if (llo[0] <= x <= lhi[0] and llo[1] <= y <= lhi[1]
                        and llo[2] <= z <= lhi[2]) == in_local:
                    which[m] = q
                    pts[0, 0, m], pts[0, 1, m], pts[0, 2, m] = x, y, z
                    m += 1
            if m == BATCH or (q == n * ns and m > 0):
                eval_rows(run, m, rows)
                for j in range(m):
                    values[which[j] // ns, which[j] % ns] = vs[0, j]
                m = 0
    for k in range(n):
        if rays[HIT, k] < 0.0:
            continue
        occ = 0.0
        total = 0.0
        for kk in range(1, ns + 1):
            d = radius * kk / ns
            weight = 1.0 / kk
            occ += weight * min(max(values[k, kk - 1] - max(0.5 - surf[k, SLOPE] * d, 0.0),
                                    0.0) / 0.5, 1.0)
            total += weight
        surf[k, OCC] = occ / total


@kernel
def penumbra(prog, point, t, light_tan, st):
    """How much of an area light of angular radius atan(light_tan) a shadow ray that missed
    still sees, from ``point`` (x, y, z) at distance t where it passed nearest another surface:
    that surface lies about d = (0.5 - f) / ``|grad f|`` away (the field's first-order Taylor
    estimate), and the light's disc, t * light_tan wide there, is seen in full once d exceeds
    it (the penumbra of an area light, estimated from one ray)."""
    vs = st[0]
    eval_point(prog, (point[0], point[1], point[2], GRADIENT), st)
    g = np.sqrt(vs[0, GRAD] ** 2 + vs[0, GRAD + 1] ** 2 + vs[0, GRAD + 2] ** 2)
    if g <= 0.0 or t <= 0.0:
        return 1.0
    return _smoothstep((ISO - vs[0, FIELD]) / (g * t * light_tan))


@kernel(inline="always")
def _smoothstep(x):
    """0 below 0, 1 above 1, the cubic 3x^2 - 2x^3 between."""
    x = min(max(x, 0.0), 1.0)
    return x * x * (3.0 - 2.0 * x)


#: Rows of a packet's ray table (``tiles._packet_scratch``), for the ray being traced (camera
#: or shadow ray): where it is, where this trace ends, where it leaves the scene's bounds, where
#: it started, its smallest step, the trace's result (-1: no hit), where it leaves the local
#: box (a shadow ray; -inf if it starts outside; on the full program, the end of its current
#: stretch, -1 if it takes no part in it: :func:`_trace_stretches`); then the camera ray's
#: hit (-1: none), whether the hit came from the local program (1) or the full one (0), and
#: whether the light being shaded may reach the hit (1: it faces the light and no shadow ray
#: found it blocked yet).
T, T_END, T1, T0, EPS, OUT, SPLIT, HIT, INSIDE, REACHED = range(10)
#: sRGB albedos this close are decoded once (a field's colour is its children's weighted by
#: their fields, so one colour blended with itself comes back a few ulps off; the decoded
#: values then differ by less than 1e-12, against 8-bit steps of about 1/255).
ALBEDO_SAME = 1e-13
#: Columns of a packet's surface table: a hit's outward unit normal, linear albedo, colour, its
#: albedo as the field gave it (sRGB, clamped to [0, 1]), ``|grad f|`` there and its ambient
#: occlusion.
NX, NY, NZ, AR, AG, AB, CR, CG, CB, SR, SG, SB, SLOPE, OCC = range(14)


@kernel(inline="always")
def _surface(vx, vy, vz, surf, k, last, ev):
    """The outward normal, albedo and slope at a surface point seen along view direction v
    (unit, toward the surface), into row k of the surface table ``surf`` (columns :data:`NX`
    ...), from ``ev``: the field, gradient and colour there (``point.eval_point``'s mode SHADE
    row); the linear albedo is row ``last``'s (the last hit's, -1: none) where the field gives
    the same colour (within :data:`ALBEDO_SAME`).  The occlusion OCC is 0 until
    :func:`_occlusions` measures it; :func:`_ambient` then lights the row."""
    row = surf[k]
    # The field decreases outward, so the outward normal is -grad f.
    nx, ny, nz = -ev[GRAD], -ev[GRAD + 1], -ev[GRAD + 2]
    nn = np.sqrt(nx * nx + ny * ny + nz * nz)
    if nn > 0.0:
        nx, ny, nz = nx / nn, ny / nn, nz / nn
    else:
        nx, ny, nz = -vx, -vy, -vz
    row[NX], row[NY], row[NZ] = nx, ny, nz
    for c in range(3):
        row[SR + c] = min(max(ev[COLOR + c], 0.0), 1.0)
    prev = surf[max(last, 0)]
    same = last >= 0 and (abs(row[SR] - prev[SR]) <= ALBEDO_SAME
                          and abs(row[SG] - prev[SG]) <= ALBEDO_SAME
                          and abs(row[SB] - prev[SB]) <= ALBEDO_SAME)
    for c in range(3):
        row[AR + c] = prev[AR + c] if same else srgb_to_linear(row[SR + c])
    row[SLOPE], row[OCC] = nn, 0.0


@kernel(inline="always")
def _ambient(look, row):
    """The ambient-lit colour of a surface table row: brighter from above by ``SKY``, darkened
    by the row's occlusion OCC (where the look has any)."""
    ambient = look[AMBIENT] * (1.0 - look[SKY] * 0.5 * (1.0 - row[NY]))
    if look[OCCLUSION] > 0.0:
        ambient *= 1.0 - look[OCCLUSION] * row[OCC]
    for c in range(3):
        row[CR + c] = ambient * row[AR + c]


@kernel(inline="always")
def _toward(lights, j, px, py, pz):
    """Unit direction from p toward light j, and its distance (inf for a directional light; 0
    where p is the light's position)."""
    if lights[j, 0] == DIRECTIONAL:
        return lights[j, 1], lights[j, 2], lights[j, 3], np.inf
    lx, ly, lz = lights[j, 1] - px, lights[j, 2] - py, lights[j, 3] - pz
    dist = np.sqrt(lx * lx + ly * ly + lz * lz)
    if dist == 0.0:
        return 0.0, 0.0, 0.0, 0.0
    return lx / dist, ly / dist, lz / dist, dist


@kernel(inline="always")
def _add_light(lights, j, look, row, lx, ly, lz, vx, vy, vz, lit):
    """Blinn-Phong: light j from unit direction l, seen along v, times ``lit``, added to the
    colour in ``row``."""
    ndl = row[NX] * lx + row[NY] * ly + row[NZ] * lz
    hx, hy, hz = lx - vx, ly - vy, lz - vz
    hn = np.sqrt(hx * hx + hy * hy + hz * hz)
    spec = 0.0
    if hn > 0.0:
        ndh = (row[NX] * hx + row[NY] * hy + row[NZ] * hz) / hn
        if ndh > 0.0:
            spec = look[SPECULAR] * kernel_math.power(ndh, look[SHININESS])
    for c in range(3):
        row[CR + c] += lit * lights[j, 4 + c] * (row[AR + c] * ndl + spec)


#: Full programs of at least this many instructions are specialised anew for each stretch of a
#: packet's shadow rays, from where the rays start: the cone's program spans the cone's whole
#: stretch in depth, and starting from the rays takes some 18% off the Murex's shadow rays'
#: time (its 2,681 instructions; ``bench/ab.py``).  whorl126's 292 gain less than the
#: specialising costs: its shadow rays start on the cone's program, then take the full one.
#: Shorter programs are specialised to the box around a packet's hits instead, for their
#: normals and colours (:func:`_hits_program`).
STRETCH_MIN = 1000
#: A packet's first stretch of shadow rays on the full program, in first candidate segments
#: (each next stretch is twice as long).
STRETCH = 4.0
#: A shadow ray's first candidate segment, as a fraction of what is left of it to the light (or
#: out of the bounds box); from the surface on a long program's own stretches (STRETCH_MIN),
#: OWN_DELTA0, so that the first stretch is specialised to less about the surface (the
#: Murex's 512 studio picture 0.97 times as long as with SHADOW_DELTA0, Chicoreus's 0.98;
#: short programs' pictures as long or longer with it).
SHADOW_DELTA0, OWN_DELTA0 = 0.05, 0.01
#: A shadow ray's smallest step grows with its distance t by SHADOW_STEP t tan(light radius):
#: a feature thinner than that (a fraction of the area light's width seen from there) may be
#: stepped over; the field's rise near it still darkens the penumbra.
SHADOW_STEP = 1.0


@kernel
def _trace_stretches(prog, n, delta0, packet, st, shadow_rel):
    """:func:`trace_packet` of the shadow rays in the ray table (from T to T_END; a ray whose
    T_END is 0 takes no part) on the full program, first candidate segment delta0: a long
    program (:data:`STRETCH_MIN`) is specialised to the box around the rays' next stretch, the
    first ``STRETCH`` delta0 long, each next twice as long.  Rays found in shadow get REACHED 0."""
    _, rays, _, _, SO, SD, _, pk, ids, rows, spec, _ = packet
    out, work, lo, hi = spec
    stretch = STRETCH * delta0 if prog[0].shape[0] >= STRETCH_MIN else np.inf
    while True:
        m = 0
        for k in range(3):
            lo[k], hi[k] = np.inf, -np.inf
        for k in range(n):  # the stretch's end in SPLIT (-1: no part in it), and its box
            rays[SPLIT, k] = -1.0
            if rays[T_END, k] > 0.0 and rays[REACHED, k] == 1.0 and rays[T, k] < rays[T_END, k]:
                rays[SPLIT, k] = min(rays[T_END, k], rays[T, k] + stretch)
                for tt in (rays[T, k], rays[SPLIT, k]):
                    for r in range(3):
                        lo[r] = min(lo[r], SO[k, r] + tt * SD[k, r])
                        hi[r] = max(hi[r], SO[k, r] + tt * SD[k, r])
                m += 1
        if m == 0:
            return
        run = prog
        if stretch < np.inf:
            ln = specialize(prog, lo, hi, out, work)
            run = (out[0][:ln], prog[1], out[1][:ln], out[2][:ln])
        trace_packet(run, (SO, SD), n, (rays[T], rays[SPLIT]), (rays[EPS], shadow_rel),
                     min(delta0, stretch), rays[OUT], False, (pk, ids, rows), st)
        for k in range(n):
            if rays[OUT, k] >= 0.0:
                rays[REACHED, k] = 0.0
        stretch *= 2.0


@kernel
def _hits_program(prog, n, packet):
    """The program specialised to the box around the packet's hits (in the buffers of its
    ``spec``); empty for a long program (:data:`STRETCH_MIN`) or no hits.  The
    cone's own program spans its whole stretch in depth, so it keeps many primitives the hits
    are far from (whorl126: its hits' field, gradient and colour took a fifth of the render); a
    long program costs more to specialise than its hits' evaluations would save."""
    _, rays, O, D, _, _, _, _, _, _, spec, _ = packet
    out, work, lo, hi = spec
    for r in range(3):
        lo[r], hi[r] = np.inf, -np.inf
    for k in range(n):
        t = rays[HIT, k]
        if t >= 0.0:
            for r in range(3):
                lo[r] = min(lo[r], O[k, r] + t * D[k, r])
                hi[r] = max(hi[r], O[k, r] + t * D[k, r])
    m = 0
    if prog[0].shape[0] < STRETCH_MIN and lo[0] <= hi[0]:
        m = specialize(prog, lo, hi, out, work)
    return out[0][:m], prog[1], out[1][:m], out[2][:m]


def _shade_packet(prog, local, n, view, packet, st):
    """Linear RGB at the hits of the n camera rays O[k] + t D[k] of a packet, into columns CR, CG,
    CB of its surface table (``packet``: see ``tiles._packet_scratch``; the hits in its ray table;
    ``view``: see ``tiles.trace_rect``). ``local = (program, llo, lhi)``: the program specialised to
    the box [llo, lhi] the rays crossed: it gives the normals and albedos of the hits it found, and,
    where the full program is short (:data:`STRETCH_MIN`), carries the shadow rays that start in
    that box while they stay there; the full program takes them on. ``look`` (see :data:`AMBIENT`
    ...): Blinn-Phong lights of angular radius atan(``LIGHT_TAN``) besides the ambient light. The
    shadow rays toward each light start just off the surface along the normal (so they cannot re-hit
    it) and are traced together (:func:`trace_packet`; a long program is specialised to each stretch
    of them, :func:`_trace_stretches`); those that miss still darken by :func:`penumbra`."""
    _, rays, O, D, SO, SD, surf, pk, ids, rows, _, _ = packet
    lights, lo, hi, shadows, look = view[1], view[2], view[3], view[7], view[10]
    shadow_eps, eps_rel = view[13], view[12]
    lprog, llo, lhi = local
    shadow_rel = SHADOW_STEP * look[LIGHT_TAN]
    # a long program's shadow rays take programs of their own from the start (STRETCH_MIN)
    own = prog[0].shape[0] >= STRETCH_MIN
    delta0 = OWN_DELTA0 if own else SHADOW_DELTA0
    at = _hits_program(prog, n, packet)
    last = -1
    for k in range(n):
        t = rays[HIT, k]
        if t >= 0.0:
            near = at
            if near[0].shape[0] == 0:  # (a long program: the one that found the hit)
                near = lprog if rays[INSIDE, k] == 1.0 else prog
            eval_point(near, (O[k, 0] + t * D[k, 0], O[k, 1] + t * D[k, 1],
                              O[k, 2] + t * D[k, 2], SHADE), st)
            _surface(D[k, 0], D[k, 1], D[k, 2], surf, k, last, st[0][0])
            last = k
    if look[OCCLUSION] > 0.0:
        _occlusions(prog, local, n, look, packet)
    for k in range(n):
        if rays[HIT, k] >= 0.0:
            _ambient(look, surf[k])
    for j in range(lights.shape[0]):
        d_local = d_full = np.inf  # the first candidate segments of the two stretches
        for k in range(n):
            t = rays[HIT, k]
            rays[REACHED, k] = 0.0
            rays[T, k], rays[T_END, k], rays[SPLIT, k] = 1.0, 0.0, -np.inf  # (no shadow ray)
            rays[OUT, k] = -1.0
            if t < 0.0:
                continue
            px, py, pz = O[k, 0] + t * D[k, 0], O[k, 1] + t * D[k, 1], O[k, 2] + t * D[k, 2]
            lx, ly, lz, dist = _toward(lights, j, px, py, pz)
            if dist == 0.0 or surf[k, NX] * lx + surf[k, NY] * ly + surf[k, NZ] * lz <= 0.0:
                continue
            rays[REACHED, k] = 1.0
            SD[k, 0], SD[k, 1], SD[k, 2] = lx, ly, lz
            se = max(shadow_eps, eps_rel * t)
            SO[k, 0] = px + se * surf[k, NX]
            SO[k, 1] = py + se * surf[k, NY]
            SO[k, 2] = pz + se * surf[k, NZ]
            t0, t1 = clip_box(SO[k, 0], SO[k, 1], SO[k, 2], lx, ly, lz, lo, hi, 0.0, dist)
            rays[T0, k], rays[T1, k], rays[EPS, k] = t0, t1, 0.5 * se
            pk[LOW, k], pk[RISE, k], pk[PEAK, k] = np.inf, 0.0, t0
            if not shadows or t0 > t1 or own:
                continue
            ta, tb = clip_box(SO[k, 0], SO[k, 1], SO[k, 2], lx, ly, lz, llo, lhi, t0, t1)
            if ta == t0 and ta <= tb:  # starts in the local box
                rays[SPLIT, k] = tb
                rays[T, k], rays[T_END, k] = t0, min(t1, tb)
                d_local = min(d_local, SHADOW_DELTA0 * (tb - t0) + se)
        if shadows and not own:
            trace_packet(lprog, (SO, SD), n, (rays[T], rays[T_END]), (rays[EPS], shadow_rel),
                         d_local, rays[OUT], False, (pk, ids, rows), st)
        if shadows:
            for k in range(n):  # then on the full program, past the local box
                if rays[OUT, k] >= 0.0:
                    rays[REACHED, k] = 0.0  # in shadow
                rays[T, k], rays[T_END, k] = 1.0, 0.0
                if rays[REACHED, k] == 1.0 and rays[SPLIT, k] < rays[T1, k] and (
                        rays[T0, k] <= rays[T1, k]):
                    rays[T, k] = max(rays[T0, k], rays[SPLIT, k])
                    rays[T_END, k] = rays[T1, k]
                    d_full = min(d_full, delta0 * (rays[T1, k] - rays[T, k]) + 2.0 * rays[EPS, k])
            _trace_stretches(prog, n, d_full, packet, st, shadow_rel)
        for k in range(n):
            if rays[REACHED, k] == 0.0 or (shadows and rays[OUT, k] >= 0.0):
                continue
            lit = 1.0
            if shadows and look[LIGHT_TAN] > 0.0 and pk[RISE, k] > 0.0:
                tp = pk[PEAK, k]
                lit = penumbra(prog, (SO[k, 0] + tp * SD[k, 0], SO[k, 1] + tp * SD[k, 1],
                                      SO[k, 2] + tp * SD[k, 2]), tp, look[LIGHT_TAN], st)
            _add_light(lights, j, look, surf[k], SD[k, 0], SD[k, 1], SD[k, 2], D[k, 0], D[k, 1],
                       D[k, 2], lit)


#: :func:`_shade_packet` compiled once, called by symbol (``runtime.linked``).
packet_shade = linked(SHADE_PACKET)(_shade_packet)
shade_packet = packet_shade.call
