"""numba kernels that run a compiled BlobTree program (see ``compile.py`` for its layout).

The program is postfix: primitives push (field, gradient, colour) on a value stack, operators pop
their children and push the result, warps push a transformed point on a point stack.  Every
primitive and every BOX instruction first tests its world box; a miss pushes 0 and jumps over
the subtree (``code[i, 2]``), so a subtree whose box misses the point costs one test.

``eval_point``, ``lipschitz_box`` and ``lipschitz_segment`` are the building blocks other kernels
(mesh, render) call.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .fields import SLOPE_BY_ID, falloff, falloff_ds, falloff_peak

# Opcodes (code[i, 0]).  Primitives first: every op <= OP_CYLINDER is a primitive.
OP_POINT, OP_CONE, OP_TORUS, OP_DISC, OP_CYLINDER = 0, 1, 2, 3, 4
OP_BOX, OP_BLEND, OP_SUPER, OP_UNION, OP_INTER, OP_DIFF, OP_CBLEND = 5, 6, 7, 8, 9, 10, 11
OP_PUSHPT, OP_BEND, OP_TWIST, OP_TAPER, OP_POPPT, OP_COLOR = 12, 13, 14, 15, 16, 17
OP_ZERO = 18  # pushes 0: a subtree removed by specialisation (specialize.py)
OP_TEXBOUND = 19  # bounding-surface texture (texture.HelicoSurface) over the subtree below


@njit(cache=True, inline="always")
def is_paint(op):
    """Ops that repaint the value below them (a one-child subtree closing)."""
    return op == OP_COLOR or op == OP_TEXBOUND

#: Size of the common primitive header in params: 3x4 frame->local map, R, falloff id.
PRIM_HEADER = 14
DEFAULT_GREY = 0.8

_fo = njit(cache=True, inline="always")(falloff)
_fo_ds = njit(cache=True, inline="always")(falloff_ds)
_fo_peak = njit(cache=True, inline="always")(falloff_peak)


@njit(cache=True)
def scratch(depth):
    """Per-thread stacks for ``eval_point``: values (depth, 7): field, gradient, colour; and
    points (depth, 30): the point to restore, the Jacobian to the outer frame, warp scratch."""
    return np.empty((depth, 7)), np.empty((depth, 30))


@njit(cache=True, inline="always")
def _outside(boxes, i, x, y, z):
    return (x < boxes[i, 0] or y < boxes[i, 1] or z < boxes[i, 2]
            or x > boxes[i, 3] or y > boxes[i, 4] or z > boxes[i, 5])


@njit(cache=True, inline="always")
def _push_zero(vs, sp, mode):
    vs[sp, 0] = 0.0
    if mode == 0:
        return
    vs[sp, 1] = 0.0
    vs[sp, 2] = 0.0
    vs[sp, 3] = 0.0
    vs[sp, 4] = DEFAULT_GREY
    vs[sp, 5] = DEFAULT_GREY
    vs[sp, 6] = DEFAULT_GREY


@njit(cache=True, inline="always")
def _ring_delta(qx, qy, qz, ring, solid):
    """q minus the closest point of a circle (or solid disc) of radius ``ring`` in xz."""
    rho = math.sqrt(qx * qx + qz * qz)
    if solid and rho <= ring:
        return 0.0, qy, 0.0
    if rho > 0.0:
        return qx - ring * qx / rho, qy, qz - ring * qz / rho
    return qx - ring, qy, qz


@njit(cache=True, inline="always")
def _prim_s(op, p, o, qx, qy, qz):
    """s = r^2 / R^2 and ds/dq in the primitive's local coordinates."""
    h = o + PRIM_HEADER
    r = p[o + 12]
    if op == OP_POINT:
        dx, dy, dz = qx - p[h], qy - p[h + 1], qz - p[h + 2]
    elif op == OP_CONE:
        ax, ay, az = p[h], p[h + 1], p[h + 2]
        ux, uy, uz = p[h + 3] - ax, p[h + 4] - ay, p[h + 5] - az
        l2 = ux * ux + uy * uy + uz * uz
        t_raw = ((qx - ax) * ux + (qy - ay) * uy + (qz - az) * uz) / l2
        t = min(max(t_raw, 0.0), 1.0)
        dx, dy, dz = qx - ax - t * ux, qy - ay - t * uy, qz - az - t * uz
        ra, dr = p[h + 6], p[h + 7] - p[h + 6]
        rt = ra + t * dr
        d2 = dx * dx + dy * dy + dz * dz
        s = d2 / (rt * rt)
        k = 2.0 / (rt * rt)
        if 0.0 < t_raw < 1.0:
            c = 2.0 * d2 / (rt * rt * rt) * dr / l2
            return s, k * dx - c * ux, k * dy - c * uy, k * dz - c * uz
        return s, k * dx, k * dy, k * dz
    elif op == OP_TORUS or op == OP_DISC:
        dx, dy, dz = _ring_delta(qx - p[h + 1], qy - p[h + 2], qz - p[h + 3], p[h],
                                 op == OP_DISC)
    else:  # OP_CYLINDER
        ax, ay, az = p[h], p[h + 1], p[h + 2]
        ux, uy, uz = p[h + 3] - ax, p[h + 4] - ay, p[h + 5] - az
        length = math.sqrt(ux * ux + uy * uy + uz * uz)
        ux, uy, uz = ux / length, uy / length, uz / length
        wx, wy, wz = qx - ax, qy - ay, qz - az
        hh = wx * ux + wy * uy + wz * uz
        rx, ry, rz = wx - hh * ux, wy - hh * uy, wz - hh * uz
        rho = math.sqrt(rx * rx + ry * ry + rz * rz)
        sc = min(rho, p[h + 6]) / rho if rho > 0.0 else 0.0
        t = min(max(hh, 0.0), length)
        dx = qx - (ax + t * ux + sc * rx)
        dy = qy - (ay + t * uy + sc * ry)
        dz = qz - (az + t * uz + sc * rz)
    k = 1.0 / (r * r)
    return (dx * dx + dy * dy + dz * dz) * k, 2.0 * k * dx, 2.0 * k * dy, 2.0 * k * dz


@njit(cache=True, _nrt=False)
def _warp(op, p, o, x, y, z, ps, pp, mode):
    """Apply a warp's query map to (x, y, z) and compose its Jacobian into ps[pp, 3:12].

    Params: a signed permutation Pm (9) taking frame axes to the warp's canonical axes, then
    the canonical parameters.  Canonical forms: bend along x toward +y; twist and taper about z.
    """
    X = p[o] * x + p[o + 1] * y + p[o + 2] * z
    Y = p[o + 3] * x + p[o + 4] * y + p[o + 5] * z
    Z = p[o + 6] * x + p[o + 7] * y + p[o + 8] * z
    c = o + 9
    j00, j01, j02, j10, j11, j12 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0  # rows 0-1 of dQ/dX; row 2 = e_z
    if op == OP_BEND:
        k, length = p[c], p[c + 1]
        ik = 1.0 / k
        u, v = X, ik - Y
        phi = math.atan2(u, v)
        th = min(max(phi, 0.0), k * length)
        sn, cs = math.sin(th), math.cos(th)
        dx, dy = X - sn * ik, Y - (1.0 - cs) * ik
        qx, qy = th * ik + dx * cs + dy * sn, -dx * sn + dy * cs
        if 0.0 < phi < k * length:
            rho2 = u * u + v * v
            rho = math.sqrt(rho2)
            j00, j01, j10, j11 = v / (k * rho2), u / (k * rho2), -u / rho, v / rho
        else:
            j00, j01, j10, j11 = cs, sn, -sn, cs
    elif op == OP_TWIST:
        k = p[c]
        th = k * Z
        cs, sn = math.cos(th), math.sin(th)
        qx, qy = cs * X + sn * Y, -sn * X + cs * Y
        j00, j01, j02, j10, j11, j12 = cs, sn, k * qy, -sn, cs, -k * qx
    else:  # OP_TAPER
        rate, t0, t1 = p[c], p[c + 1], p[c + 2]
        s = 1.0 + rate * min(max(Z, t0), t1)
        qx, qy = X / s, Y / s
        j00, j11 = 1.0 / s, 1.0 / s
        if t0 < Z < t1:
            j02, j12 = -qx * rate / s, -qy * rate / s
    # back to frame axes: q = Pm^T Q; J = Pm^T Jc Pm, then J_total = J @ J_before
    nx = p[o] * qx + p[o + 3] * qy + p[o + 6] * Z
    ny = p[o + 1] * qx + p[o + 4] * qy + p[o + 7] * Z
    nz = p[o + 2] * qx + p[o + 5] * qy + p[o + 8] * Z
    if mode == 0:
        return nx, ny, nz
    for col in range(3):  # column col of Jc Pm, then of Pm^T (Jc Pm), then times J_before
        m0, m1, m2 = p[o + col], p[o + 3 + col], p[o + 6 + col]
        a0 = j00 * m0 + j01 * m1 + j02 * m2
        a1 = j10 * m0 + j11 * m1 + j12 * m2
        a2 = m2
        for r in range(3):
            ps[pp, 12 + 3 * r + col] = p[o + r] * a0 + p[o + 3 + r] * a1 + p[o + 6 + r] * a2
    for r in range(3):
        for col in range(3):
            acc = 0.0
            for m in range(3):
                acc += ps[pp, 12 + 3 * r + m] * ps[pp, 3 + 3 * m + col]
            ps[pp, 21 + 3 * r + col] = acc
    for q in range(9):
        ps[pp, 3 + q] = ps[pp, 21 + q]
    return nx, ny, nz


@njit(cache=True, inline="always")
def _turn(y, x):
    """atan2(y, x) as a fraction of a turn in [0, 1)."""
    t = math.atan2(y, x) / (2.0 * math.pi)
    if t < 0.0:
        t += 1.0
    return 0.0 if t >= 1.0 else t


@njit(cache=True, inline="always")
def _wrap(i, n, mode):
    if mode == 0:
        return i % n
    return min(max(i, 0), n - 1)


@njit(cache=True)
def texel(p, t, u, v):
    """Bilinear colour of the texture block at params[t:] ([w, h, wrap, rgb rows...])."""
    w, h, wrap = int(p[t]), int(p[t + 1]), int(p[t + 2])
    x = u * w - 0.5
    y = v * h - 0.5
    fx0, fy0 = math.floor(x), math.floor(y)
    fx, fy = x - fx0, y - fy0
    x0, y0 = int(fx0), int(fy0)
    xa, xb = _wrap(x0, w, wrap), _wrap(x0 + 1, w, wrap)
    ya, yb = _wrap(y0, h, wrap), _wrap(y0 + 1, h, wrap)
    a, b = t + 3 + 3 * (ya * w + xa), t + 3 + 3 * (ya * w + xb)
    c, d = t + 3 + 3 * (yb * w + xa), t + 3 + 3 * (yb * w + xb)
    wa, wb, wc, wd = (1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy
    return (wa * p[a] + wb * p[b] + wc * p[c] + wd * p[d],
            wa * p[a + 1] + wb * p[b + 1] + wc * p[c + 1] + wd * p[d + 1],
            wa * p[a + 2] + wb * p[b + 2] + wc * p[c + 2] + wd * p[d + 2])


@njit(cache=True)
def _prim_uv(op, p, o, qx, qy, qz):
    """The primitive's own (u, v) (see the ``uv`` methods in nodes.py)."""
    h = o + PRIM_HEADER
    if op == OP_POINT:
        dx, dy, dz = qx - p[h], qy - p[h + 1], qz - p[h + 2]
        r = math.sqrt(dx * dx + dy * dy + dz * dz)
        c = min(max(dy / r if r > 0.0 else 0.0, -1.0), 1.0)
        return _turn(-dz, dx), math.acos(c) / math.pi
    if op == OP_TORUS or op == OP_DISC:
        dx, dy, dz = qx - p[h + 1], qy - p[h + 2], qz - p[h + 3]
        rho = math.sqrt(dx * dx + dz * dz)
        if op == OP_DISC:
            return _turn(-dz, dx), min(rho / p[h], 1.0)
        return _turn(-dz, dx), _turn(dy, rho - p[h])
    ax, ay, az = p[h], p[h + 1], p[h + 2]
    ux, uy, uz = p[h + 3] - ax, p[h + 4] - ay, p[h + 5] - az
    l2 = ux * ux + uy * uy + uz * uz
    t = min(max(((qx - ax) * ux + (qy - ay) * uy + (qz - az) * uz) / l2, 0.0), 1.0)
    e = h + 8 if op == OP_CONE else h + 7
    if op == OP_CONE:
        dx, dy, dz = qx - ax - t * ux, qy - ay - t * uy, qz - az - t * uz
    else:
        dx, dy, dz = qx - ax, qy - ay, qz - az
    d1 = dx * p[e] + dy * p[e + 1] + dz * p[e + 2]
    d2 = dx * p[e + 3] + dy * p[e + 4] + dz * p[e + 5]
    return _turn(d2, d1), t


@njit(cache=True)
def _helico_locate(p, s, x, y, z):
    """Nearest whorl of the spiral (params at s): theta, dr, dy, radial unit (rx, rz), D."""
    r0, rho_, cot, dr_ratio, theta_max = p[s], p[s + 1], p[s + 2], p[s + 3], p[s + 4]
    rho = math.sqrt(x * x + z * z)
    phi = math.degrees(math.atan2(-z, x))
    if phi < 0.0:
        phi += 360.0
    best_t, best_d = 0.0, np.inf
    for k in range(int(theta_max // 360.0) + 2):
        t = phi + 360.0 * k
        r = r0 * rho_ ** (t / 360.0)
        d = ((rho - r) ** 2 + (y - r * cot) ** 2) / (r * r)  # relative to the whorl's size
        if d < best_d:
            best_t, best_d = t, d
    r = r0 * rho_ ** (best_t / 360.0)
    rx, rz = (x / rho, z / rho) if rho > 0.0 else (0.0, 0.0)
    return best_t, rho - r, y - r * cot, rx, rz, dr_ratio * r


@njit(cache=True)
def _texbound(p, o, px, py, pz, gx, gy, gz):
    """Colour of the bounding-surface texture (texture.HelicoSurface) at a point with
    gradient g (frame coordinates); params: frame->local map (12), inverse-transpose (9),
    r0, rho, cot(beta), D/R, theta_max, u_period, radius_factor, gradient_weight, step,
    max_steps, texture offset."""
    x = p[o] * px + p[o + 1] * py + p[o + 2] * pz + p[o + 3]
    y = p[o + 4] * px + p[o + 5] * py + p[o + 6] * pz + p[o + 7]
    z = p[o + 8] * px + p[o + 9] * py + p[o + 10] * pz + p[o + 11]
    m = o + 12
    lx = p[m] * gx + p[m + 1] * gy + p[m + 2] * gz
    ly = p[m + 3] * gx + p[m + 4] * gy + p[m + 5] * gz
    lz = p[m + 6] * gx + p[m + 7] * gy + p[m + 8] * gz
    gn = math.sqrt(lx * lx + ly * ly + lz * lz)
    if gn > 0.0:
        lx, ly, lz = -lx / gn, -ly / gn, -lz / gn  # the field falls outward
    s = o + 21
    u_period, factor, wgt = p[s + 5], p[s + 6], p[s + 7]
    step, nsteps, tex = p[s + 8], int(p[s + 9]), int(p[s + 10])
    for _ in range(nsteps):
        theta, dr, dy, rx, rz, d = _helico_locate(p, s, x, y, z)
        dist = math.sqrt(dr * dr + dy * dy)
        if dist >= factor * d:
            break
        nx, ny, nz = 0.0, 0.0, 0.0
        if dist > 0.0:
            nx, ny, nz = dr / dist * rx, dy / dist, dr / dist * rz
        sx = wgt * lx + (1.0 - wgt) * nx
        sy = wgt * ly + (1.0 - wgt) * ny
        sz = wgt * lz + (1.0 - wgt) * nz
        sn = math.sqrt(sx * sx + sy * sy + sz * sz)
        if sn > 0.0:
            h = step * d / sn
            x, y, z = x + h * sx, y + h * sy, z + h * sz
    theta, dr, dy, rx, rz, d = _helico_locate(p, s, x, y, z)
    return texel(p, tex, theta / u_period, _turn(dy, dr))


@njit(cache=True, inline="always")
def eval_point(code, params, boxes, x, y, z, mode, vs, ps):
    """Field at (x, y, z); mode 1 also leaves the gradient in vs[0, 1:4], mode 2 the gradient
    and the colour in vs[0, 4:7]."""
    n = code.shape[0]
    p = params
    sp = 0
    pp = 0
    px, py, pz = x, y, z
    i = 0
    while i < n:
        op = code[i, 0]
        o = code[i, 1]
        if op <= OP_CYLINDER:
            if _outside(boxes, i, px, py, pz):
                _push_zero(vs, sp, mode)
                sp += 1
                i += 1
                continue
            qx = p[o] * px + p[o + 1] * py + p[o + 2] * pz + p[o + 3]
            qy = p[o + 4] * px + p[o + 5] * py + p[o + 6] * pz + p[o + 7]
            qz = p[o + 8] * px + p[o + 9] * py + p[o + 10] * pz + p[o + 11]
            s, sx, sy, sz = _prim_s(op, p, o, qx, qy, qz)
            if s >= 1.0:
                _push_zero(vs, sp, mode)
            else:
                fid = int(p[o + 13])
                vs[sp, 0] = _fo(fid, s)
                if mode > 0:
                    d = _fo_ds(fid, s)
                    gx, gy, gz = d * sx, d * sy, d * sz
                    vs[sp, 1] = p[o] * gx + p[o + 4] * gy + p[o + 8] * gz
                    vs[sp, 2] = p[o + 1] * gx + p[o + 5] * gy + p[o + 9] * gz
                    vs[sp, 3] = p[o + 2] * gx + p[o + 6] * gy + p[o + 10] * gz
                    if mode > 1 and code[i, 3] >= 0:  # field-interpolated texture
                        tu, tv = _prim_uv(op, p, o, qx, qy, qz)
                        vs[sp, 4], vs[sp, 5], vs[sp, 6] = texel(p, code[i, 3], tu, tv)
                    else:
                        vs[sp, 4] = DEFAULT_GREY
                        vs[sp, 5] = DEFAULT_GREY
                        vs[sp, 6] = DEFAULT_GREY
            sp += 1
            i += 1
        elif op == OP_BOX or op == OP_PUSHPT:
            if _outside(boxes, i, px, py, pz):
                _push_zero(vs, sp, mode)
                sp += 1
                i = code[i, 2]
                continue
            if op == OP_PUSHPT:
                nx = p[o] * px + p[o + 1] * py + p[o + 2] * pz + p[o + 3]
                ny = p[o + 4] * px + p[o + 5] * py + p[o + 6] * pz + p[o + 7]
                nz = p[o + 8] * px + p[o + 9] * py + p[o + 10] * pz + p[o + 11]
                pp += 1
                ps[pp, 0], ps[pp, 1], ps[pp, 2] = px, py, pz  # the point to restore
                for r in range(3):
                    for c in range(3):
                        ps[pp, 3 + 3 * r + c] = p[o + 4 * r + c]
                px, py, pz = nx, ny, nz
            i += 1
        elif op == OP_BEND or op == OP_TWIST or op == OP_TAPER:
            if _outside(boxes, i, px, py, pz):
                _push_zero(vs, sp, mode)
                sp += 1
                i = code[i, 2]
                continue
            px, py, pz = _warp(op, p, o, px, py, pz, ps, pp, mode)
            i += 1
        elif op == OP_POPPT:
            t = sp - 1
            if mode > 0:  # gradient back to the outer frame: g <- J^T g
                gx, gy, gz = vs[t, 1], vs[t, 2], vs[t, 3]
                vs[t, 1] = ps[pp, 3] * gx + ps[pp, 6] * gy + ps[pp, 9] * gz
                vs[t, 2] = ps[pp, 4] * gx + ps[pp, 7] * gy + ps[pp, 10] * gz
                vs[t, 3] = ps[pp, 5] * gx + ps[pp, 8] * gy + ps[pp, 11] * gz
            px, py, pz = ps[pp, 0], ps[pp, 1], ps[pp, 2]
            pp -= 1
            i += 1
        elif op == OP_COLOR:
            vs[sp - 1, 4] = p[o]
            vs[sp - 1, 5] = p[o + 1]
            vs[sp - 1, 6] = p[o + 2]
            i += 1
        elif op == OP_ZERO:
            _push_zero(vs, sp, mode)
            sp += 1
            i += 1
        elif op == OP_TEXBOUND:
            t = sp - 1
            if mode > 1 and vs[t, 0] > 0.0:
                vs[t, 4], vs[t, 5], vs[t, 6] = _texbound(p, o, px, py, pz, vs[t, 1], vs[t, 2],
                                                         vs[t, 3])
            i += 1
        else:
            k = code[i, 3]
            b = sp - k
            if op == OP_BLEND:
                _blend(vs, b, k, mode)
            elif op == OP_SUPER:
                _super(vs, b, k, p[o], mode)
            elif op == OP_CBLEND:
                _cblend(vs, b, p, o, mode)
            else:
                _select(vs, b, k, op, mode)
            sp = b + 1
            i += 1
    return vs[0, 0]


@njit(cache=True, inline="always")
def _blend(vs, b, k, mode):
    f = vs[b, 0]
    for m in range(b + 1, b + k):
        f += vs[m, 0]
    if mode > 0:
        g0 = g1 = g2 = 0.0
        c0 = c1 = c2 = 0.0
        for m in range(b, b + k):
            g0 += vs[m, 1]
            g1 += vs[m, 2]
            g2 += vs[m, 3]
            c0 += vs[m, 0] * vs[m, 4]
            c1 += vs[m, 0] * vs[m, 5]
            c2 += vs[m, 0] * vs[m, 6]
        vs[b, 1], vs[b, 2], vs[b, 3] = g0, g1, g2
        if f > 0.0:
            vs[b, 4], vs[b, 5], vs[b, 6] = c0 / f, c1 / f, c2 / f
    vs[b, 0] = f


@njit(cache=True, inline="always")
def _super(vs, b, k, n, mode):
    m = 0.0
    for j in range(b, b + k):
        m = max(m, vs[j, 0])
    if m <= 0.0:
        vs[b, 0] = 0.0
        vs[b, 1] = vs[b, 2] = vs[b, 3] = 0.0
        return
    s = 0.0
    for j in range(b, b + k):
        s += (vs[j, 0] / m) ** n
    f = m * s ** (1.0 / n)
    if mode > 0:
        g0 = g1 = g2 = 0.0
        c0 = c1 = c2 = 0.0
        for j in range(b, b + k):
            w = (vs[j, 0] / f) ** (n - 1.0)
            g0 += w * vs[j, 1]
            g1 += w * vs[j, 2]
            g2 += w * vs[j, 3]
            cw = (vs[j, 0] / m) ** n
            c0 += cw * vs[j, 4]
            c1 += cw * vs[j, 5]
            c2 += cw * vs[j, 6]
        vs[b, 1], vs[b, 2], vs[b, 3] = g0, g1, g2
        vs[b, 4], vs[b, 5], vs[b, 6] = c0 / s, c1 / s, c2 / s
    vs[b, 0] = f


@njit(cache=True, inline="always")
def _copy_entry(vs, src, dst, sign):
    vs[dst, 0] = vs[src, 0] if sign > 0 else 1.0 - vs[src, 0]
    for c in range(1, 4):
        vs[dst, c] = sign * vs[src, c]
    for c in range(4, 7):
        vs[dst, c] = vs[src, c]


@njit(cache=True, inline="always")
def _select(vs, b, k, op, mode):
    """Union (max), intersection (min) and difference (min of f_0 and 1 - f_i)."""
    best = b
    bf = vs[b, 0]
    sign = 1.0
    for j in range(b + 1, b + k):
        f = vs[j, 0]
        if op == OP_UNION:
            if f > bf:
                best, bf = j, f
        elif op == OP_INTER:
            if f < bf:
                best, bf = j, f
        else:
            f = 1.0 - f  # 2 * iso - f_B, iso = 0.5
            if f < bf:
                best, bf, sign = j, f, -1.0
    if best != b:
        _copy_entry(vs, best, b, sign)
    if vs[b, 0] < 0.0:  # difference with a subtrahend above 1: clamp to 0 (as nodes.py)
        vs[b, 0] = 0.0
        vs[b, 1] = vs[b, 2] = vs[b, 3] = 0.0


@njit(cache=True, _nrt=False)
def _cblend(vs, b, p, o, mode):
    """Controlled blend (Eq. 6): max over pairs (j, k) of f_j + f_k and over single children."""
    npairs = int(p[o])
    nsingle = int(p[o + 1 + 2 * npairs])
    best_f = -1.0
    bi = bj = -1
    for q in range(npairs):
        j = b + int(p[o + 1 + 2 * q])
        k = b + int(p[o + 2 + 2 * q])
        f = vs[j, 0] + vs[k, 0]
        if f > best_f:
            best_f, bi, bj = f, j, k
    for q in range(nsingle):
        j = b + int(p[o + 2 + 2 * npairs + q])
        if vs[j, 0] > best_f:
            best_f, bi, bj = vs[j, 0], j, -1
    if mode > 0:
        if bj < 0:
            g0, g1, g2 = vs[bi, 1], vs[bi, 2], vs[bi, 3]
            c0, c1, c2 = vs[bi, 4], vs[bi, 5], vs[bi, 6]
        else:
            g0, g1, g2 = vs[bi, 1] + vs[bj, 1], vs[bi, 2] + vs[bj, 2], vs[bi, 3] + vs[bj, 3]
            if best_f > 0.0:
                wi, wj = vs[bi, 0] / best_f, vs[bj, 0] / best_f
                c0 = wi * vs[bi, 4] + wj * vs[bj, 4]
                c1 = wi * vs[bi, 5] + wj * vs[bj, 5]
                c2 = wi * vs[bi, 6] + wj * vs[bj, 6]
            else:
                c0, c1, c2 = vs[bi, 4], vs[bi, 5], vs[bi, 6]
        vs[b, 1], vs[b, 2], vs[b, 3] = g0, g1, g2
        vs[b, 4], vs[b, 5], vs[b, 6] = c0, c1, c2
    vs[b, 0] = best_f


@njit(cache=True, inline="always")
def _misses(boxes, i, lox, loy, loz, hix, hiy, hiz):
    return (hix < boxes[i, 0] or hiy < boxes[i, 1] or hiz < boxes[i, 2]
            or lox > boxes[i, 3] or loy > boxes[i, 4] or loz > boxes[i, 5])


def _slope_peak(fid: int) -> float:
    """r/R where falloff ``fid`` is steepest: its slope |df/dr| R = 2 (r/R) |f'(s)| rises from 0
    at the skeleton to one peak and falls to 0 at R (ternary search)."""
    lo, hi = 0.0, 1.0
    for _ in range(200):
        a, b = lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0
        if abs(falloff_ds(fid, a * a)) * a < abs(falloff_ds(fid, b * b)) * b:
            lo = a
        else:
            hi = b
    return lo


#: Per falloff id: where the slope peaks (r/R), and the peak slope |df/dr| R.
SLOPE_PEAK = np.array([_slope_peak(fid) for fid in range(len(SLOPE_BY_ID))])
PEAK_SLOPE = np.array([2.0 * r * abs(falloff_ds(fid, r * r)) for fid, r in enumerate(SLOPE_PEAK)])


@njit(cache=True, inline="always")
def _slope_at(fid, rmin, rmax):
    """max |df/dr| R of falloff fid over r/R in [rmin, rmax], as a fraction of its peak: the
    slope rises from 0 at the skeleton to one peak and falls to 0 at R."""
    if rmin >= 1.0:
        return 0.0
    r = min(max(SLOPE_PEAK[fid], rmin), rmax)
    return 2.0 * r * abs(_fo_ds(fid, r * r)) / PEAK_SLOPE[fid]


@njit(cache=True, inline="always")
def _map_box(p, o, lox, loy, loz, hix, hiy, hiz):
    """Centre and half extents of the box around the image of [lo, hi] under the 3x4 affine map
    at params[o:o + 12]."""
    cx, cy, cz = 0.5 * (lox + hix), 0.5 * (loy + hiy), 0.5 * (loz + hiz)
    ex, ey, ez = 0.5 * (hix - lox), 0.5 * (hiy - loy), 0.5 * (hiz - loz)
    return (p[o] * cx + p[o + 1] * cy + p[o + 2] * cz + p[o + 3],
            p[o + 4] * cx + p[o + 5] * cy + p[o + 6] * cz + p[o + 7],
            p[o + 8] * cx + p[o + 9] * cy + p[o + 10] * cz + p[o + 11],
            abs(p[o]) * ex + abs(p[o + 1]) * ey + abs(p[o + 2]) * ez,
            abs(p[o + 4]) * ex + abs(p[o + 5]) * ey + abs(p[o + 6]) * ez,
            abs(p[o + 8]) * ex + abs(p[o + 9]) * ey + abs(p[o + 10]) * ez)


@njit(cache=True, _nrt=False)
def _prim_lipschitz(op, p, o, lip, lox, loy, loz, hix, hiy, hiz):
    """A bound on the primitive's |grad f| over the box (segment tracing's distance-aware bound,
    Galin et al. 2020): the box, mapped to the primitive's frame, lies within rho of its
    centre c, so distances to the skeleton lie in [d(c) - rho, d(c) + rho]; the falloff's slope
    is bounded there.  ``lip`` is the primitive's global bound."""
    qx, qy, qz, hx, hy, hz = _map_box(p, o, lox, loy, loz, hix, hiy, hiz)
    fid = int(p[o + 13])
    if op == OP_POINT:  # distances from the centre to the (mapped) box itself, per axis
        h = o + PRIM_HEADER
        dmin2 = dmax2 = 0.0
        for off, half in ((qx - p[h], hx), (qy - p[h + 1], hy), (qz - p[h + 2], hz)):
            gap = max(abs(off) - half, 0.0)
            dmin2 += gap * gap
            dmax2 += (abs(off) + half) ** 2
        radius = p[o + 12]
        return lip * _slope_at(fid, math.sqrt(dmin2) / radius, math.sqrt(dmax2) / radius)
    rho = math.sqrt(hx * hx + hy * hy + hz * hz)
    if op != OP_CONE:
        s, _, _, _ = _prim_s(op, p, o, qx, qy, qz)
        radius = p[o + 12]
        d = math.sqrt(s) * radius
        return lip * _slope_at(fid, max(d - rho, 0.0) / radius, (d + rho) / radius)
    # cone: field radius R(t) varies along the axis; bound R over the t the box can reach
    h = o + PRIM_HEADER
    ax, ay, az = p[h], p[h + 1], p[h + 2]
    ux, uy, uz = p[h + 3] - ax, p[h + 4] - ay, p[h + 5] - az
    length = math.sqrt(ux * ux + uy * uy + uz * uz)
    tc = ((qx - ax) * ux + (qy - ay) * uy + (qz - az) * uz) / (length * length)
    t = min(max(tc, 0.0), 1.0)
    dx, dy, dz = qx - ax - t * ux, qy - ay - t * uy, qz - az - t * uz
    d = math.sqrt(dx * dx + dy * dy + dz * dz)
    ra, rb = p[h + 6], p[h + 7]
    t0 = min(max(tc - rho / length, 0.0), 1.0)
    t1 = min(max(tc + rho / length, 0.0), 1.0)
    r0, r1 = ra + t0 * (rb - ra), ra + t1 * (rb - ra)
    rlo, rhi = min(r0, r1), max(r0, r1)
    # lip = SLOPE (1 + |dR| / L) / min(ra, rb) * |A|: rescale its 1 / min(ra, rb) to 1 / rlo
    return lip * _slope_at(fid, max(d - rho, 0.0) / rhi, (d + rho) / rlo) * min(ra, rb) / rlo


@njit(cache=True, inline="always")
def _point_along(p, o, ox, oy, oz, dx, dy, dz, length):
    """The largest |df/dt| of a point primitive along the segment o + t d, 0 <= t <= length
    (segment tracing's directional bound, Galin et al. 2020).  In the primitive's frame the
    segment is q(t) = w + t e about the centre, so s = u^2 + c with u = |e| (t - t_c) / R and c
    the squared perpendicular distance over R^2, and |df/dt| = 2 |e| / R |u| |f'(s)|: a function
    of |u| with one peak (``fields.falloff_peak``), so its maximum over the segment's range of
    |u| is at the peak clamped to that range.  It never exceeds |grad f| anywhere on the segment,
    so it is at most the box bound, and small where the segment passes the primitive sideways."""
    h = o + PRIM_HEADER
    ex = p[o] * dx + p[o + 1] * dy + p[o + 2] * dz
    ey = p[o + 4] * dx + p[o + 5] * dy + p[o + 6] * dz
    ez = p[o + 8] * dx + p[o + 9] * dy + p[o + 10] * dz
    wx = p[o] * ox + p[o + 1] * oy + p[o + 2] * oz + p[o + 3] - p[h]
    wy = p[o + 4] * ox + p[o + 5] * oy + p[o + 6] * oz + p[o + 7] - p[h + 1]
    wz = p[o + 8] * ox + p[o + 9] * oy + p[o + 10] * oz + p[o + 11] - p[h + 2]
    e2 = ex * ex + ey * ey + ez * ez
    if e2 == 0.0:
        return 0.0
    r = p[o + 12]
    we = wx * ex + wy * ey + wz * ez
    c = max(wx * wx + wy * wy + wz * wz - we * we / e2, 0.0) / (r * r)
    if c >= 1.0:
        return 0.0
    e = math.sqrt(e2)
    u0 = we / (e * r)  # u at t = 0 and at t = length
    u1 = u0 + e * length / r
    a = 0.0 if u0 <= 0.0 <= u1 else min(abs(u0), abs(u1))  # the range [a, b] of |u|
    b = min(max(abs(u0), abs(u1)), math.sqrt(1.0 - c))
    if a >= b:
        return 0.0
    fid = int(p[o + 13])
    u = min(max(math.sqrt(_fo_peak(fid, c)), a), b)
    return 2.0 * e / r * u * abs(_fo_ds(fid, min(u * u + c, 1.0)))


@njit(cache=True, inline="always")
def _lipschitz(code, params, boxes, lips, lox, loy, loz, hix, hiy, hiz, ray, ox, oy, oz, dx,
               dy, dz, length, vs):
    """``lipschitz_box``; with ``ray``, point primitives outside warps take instead their exact
    directional bound along the segment o + t d, 0 <= t <= length inside the box."""
    n = code.shape[0]
    sp = 0
    pp = 0
    i = 0
    while i < n:
        op = code[i, 0]
        if op <= OP_CYLINDER:
            if _misses(boxes, i, lox, loy, loz, hix, hiy, hiz):
                vs[sp, 0] = 0.0
            elif ray and op == OP_POINT and pp == 0:
                vs[sp, 0] = _point_along(params, code[i, 1], ox, oy, oz, dx, dy, dz, length)
            else:
                vs[sp, 0] = _prim_lipschitz(op, params, code[i, 1], lips[i], lox, loy, loz,
                                            hix, hiy, hiz)
            sp += 1
            i += 1
        elif op == OP_BOX or op == OP_PUSHPT or op == OP_BEND or op == OP_TWIST \
                or op == OP_TAPER:
            if _misses(boxes, i, lox, loy, loz, hix, hiy, hiz):
                vs[sp, 0] = 0.0
                sp += 1
                i = code[i, 2]
                continue
            o = code[i, 1]
            if op == OP_PUSHPT:  # save the region, carry it into the warp's output frame
                pp += 1
                vs[pp, 1], vs[pp, 2], vs[pp, 3] = lox, loy, loz
                vs[pp, 4], vs[pp, 5], vs[pp, 6] = hix, hiy, hiz
                cx, cy, cz, ex, ey, ez = _map_box(params, o, lox, loy, loz, hix, hiy, hiz)
                lox, loy, loz = cx - ex, cy - ey, cz - ez
                hix, hiy, hiz = cx + ex, cy + ey, cz + ez
            elif op != OP_BOX:  # a warp: the query map moves points by at most stretch * dist
                cx, cy, cz = 0.5 * (lox + hix), 0.5 * (loy + hiy), 0.5 * (loz + hiz)
                ex, ey, ez = 0.5 * (hix - lox), 0.5 * (hiy - loy), 0.5 * (hiz - loz)
                reach = lips[i] * math.sqrt(ex * ex + ey * ey + ez * ez)
                wx, wy, wz = _warp(op, params, o, cx, cy, cz, vs, 0, 0)
                lox, loy, loz = wx - reach, wy - reach, wz - reach
                hix, hiy, hiz = wx + reach, wy + reach, wz + reach
            i += 1
        elif op == OP_POPPT:
            vs[sp - 1, 0] *= lips[i]
            lox, loy, loz = vs[pp, 1], vs[pp, 2], vs[pp, 3]
            hix, hiy, hiz = vs[pp, 4], vs[pp, 5], vs[pp, 6]
            pp -= 1
            i += 1
        elif is_paint(op):
            i += 1
        elif op == OP_ZERO:
            vs[sp, 0] = 0.0
            sp += 1
            i += 1
        else:
            k = code[i, 3]
            b = sp - k
            acc = 0.0
            for j in range(b, sp):
                if op == OP_BLEND or op == OP_SUPER or op == OP_CBLEND:
                    acc += vs[j, 0]
                else:
                    acc = max(acc, vs[j, 0])
            vs[b, 0] = acc
            sp = b + 1
            i += 1
    return vs[0, 0]


@njit(cache=True, _nrt=False)
def lipschitz_box(code, params, boxes, lips, lox, loy, loz, hix, hiy, hiz, vs):
    """A bound on |grad f| over the box [lo, hi] (world coordinates): the tree's Lipschitz rules
    (sum at blends, max at CSG) over only the primitives whose boxes meet it, each with its
    distance-aware bound; through a warp the box is carried into the warp's child frame (as a
    cube around the warped centre, grown by the warp's stretch) and the result scaled back.
    Uses vs[:, 0] as the value stack and vs[:, 1:7] to save regions across warps."""
    return _lipschitz(code, params, boxes, lips, lox, loy, loz, hix, hiy, hiz, False, 0.0, 0.0,
                      0.0, 0.0, 0.0, 0.0, 0.0, vs)


@njit(cache=True, _nrt=False)
def lipschitz_segment(code, params, boxes, lips, ox, oy, oz, dx, dy, dz, length, vs):
    """A bound on |df/dt| along the segment o + t d, 0 <= t <= length (d a unit vector): the
    bound of ``lipschitz_box`` over the segment's box, except that point primitives outside warps
    take their directional bound (never larger, and small where the segment passes a primitive
    sideways, so grazing rays take long steps)."""
    bx, by, bz = ox + length * dx, oy + length * dy, oz + length * dz
    return _lipschitz(code, params, boxes, lips, min(ox, bx), min(oy, by), min(oz, bz),
                      max(ox, bx), max(oy, by), max(oz, bz), True, ox, oy, oz, dx, dy, dz,
                      length, vs)


CHUNK = 512


@njit(parallel=True, cache=True)
def eval_batch(code, params, boxes, P, mode, depth, out_f, out_g, out_c):
    """Evaluate (N, 3) points in parallel chunks; fills out_f and, by mode, out_g / out_c."""
    n = P.shape[0]
    nchunks = (n + CHUNK - 1) // CHUNK
    for ch in prange(nchunks):
        vs, ps = scratch(depth)
        for m in range(ch * CHUNK, min(n, (ch + 1) * CHUNK)):
            out_f[m] = eval_point(code, params, boxes, P[m, 0], P[m, 1], P[m, 2], mode, vs, ps)
            if mode > 0:
                out_g[m, 0], out_g[m, 1], out_g[m, 2] = vs[0, 1], vs[0, 2], vs[0, 3]
            if mode > 1:
                out_c[m, 0], out_c[m, 1], out_c[m, 2] = vs[0, 4], vs[0, 5], vs[0, 6]


@njit(parallel=True, cache=True)
def lipschitz_batch(code, params, boxes, lips, lo, hi, depth, out):
    """``lipschitz_box`` for many boxes in parallel."""
    n = lo.shape[0]
    nchunks = (n + CHUNK - 1) // CHUNK
    for ch in prange(nchunks):
        vs, _ = scratch(depth)
        for m in range(ch * CHUNK, min(n, (ch + 1) * CHUNK)):
            out[m] = lipschitz_box(code, params, boxes, lips, lo[m, 0], lo[m, 1], lo[m, 2],
                                   hi[m, 0], hi[m, 1], hi[m, 2], vs)
