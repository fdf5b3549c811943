"""Benchmark the polygonizer on whorl126 against two peers measured in the same run.

Peers, at the same bounds and cell size:
  (a) numpy: the field on the dense grid, each primitive evaluated only inside its own box,
      then ``skimage.measure.marching_cubes``;
  (b) fogleman's ``sdf`` (PyPI ``sdf-fork``) meshing the custom function ``0.5 - field`` with our
      engine's field (its sparse block skip needs a distance bound, so it gets |grad| <= 1 by
      dividing by the global Lipschitz constant; the surface is the same).

Usage: python bench/bench_mesh.py [--resolutions 128 256 512] [--peer-b-max 256]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

import blobtree as bt
from blobtree.fields import soft_object
from blobtree.mesh import Mesh, polygonize


def whorl_spheres() -> tuple[np.ndarray, np.ndarray]:
    """Centres and field radii of the 126 points of whorl126 (DESIGN.md)."""
    theta = np.arange(126) * 116.0 / 6.0
    r = 0.2 * 1.3 ** (theta / 360.0)
    h = r / math.tan(math.radians(22.5))
    t = np.radians(theta)
    centres = np.stack([r * np.cos(t), h, -r * np.sin(t)], axis=1)
    return centres, 2.0 * 0.341 * r


def peer_numpy(lo, hi, cell: float):
    """Peer (a): dense grid, each primitive evaluated in its own box, skimage marching cubes."""
    from skimage.measure import marching_cubes

    centres, radii = whorl_spheres()
    origin = lo - cell
    n = np.ceil((hi - lo) / cell).astype(int) + 3
    axes = [origin[a] + cell * np.arange(n[a]) for a in range(3)]
    f = np.zeros(tuple(n))
    for c, rad in zip(centres, radii, strict=True):
        i0 = np.maximum(np.floor((c - rad - origin) / cell).astype(int), 0)
        i1 = np.minimum(np.ceil((c + rad - origin) / cell).astype(int) + 1, n)
        x, y, z = (axes[a][i0[a] : i1[a]] - c[a] for a in range(3))
        s = (x[:, None, None] ** 2 + y[None, :, None] ** 2 + z[None, None, :] ** 2) / rad**2
        f[i0[0] : i1[0], i0[1] : i1[1], i0[2] : i1[2]] += np.where(s < 1.0, soft_object(s), 0.0)
    verts, faces, _, _ = marching_cubes(f, 0.5, spacing=(cell, cell, cell))
    return verts + origin, faces


def peer_sdf(prog, lo, hi, cell: float):
    """Peer (b): fogleman's sdf on 0.5 - field (scaled to a distance bound), welded afterwards."""
    from sdf import sdf3
    from sdf.mesh import generate

    scale = 1.0 / prog.lipschitz_global

    @sdf3
    def shape():
        return lambda p: (0.5 - prog.field(np.ascontiguousarray(p, dtype=np.float64))) * scale

    points = np.asarray(generate(shape(), step=cell, bounds=(lo - cell, hi + cell), verbose=False))
    return points


def welded(verts: np.ndarray, faces: np.ndarray) -> Mesh:
    """A Mesh of a triangle list, with coincident vertices merged."""
    uniq, inv = np.unique(np.round(verts, 9), axis=0, return_inverse=True)
    z = np.zeros_like(uniq)
    return Mesh(uniq, inv.reshape(-1)[faces], z, z)


def timed(fn, *args, **kw):
    t = time.perf_counter()
    out = fn(*args, **kw)
    return out, time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolutions", type=int, nargs="+", default=[128, 256, 512])
    ap.add_argument("--peer-b-max", type=int, default=256, help="skip peer (b) above this N")
    args = ap.parse_args()

    tree = bt.models.whorl126()
    prog = tree.program()
    lo, hi = (np.asarray(b, dtype=np.float64) for b in prog.bounds)
    _, compile_s = timed(polygonize, tree, resolution=16)  # numba compile / cache load
    print(f"whorl126, bounds {np.round(lo, 3)} .. {np.round(hi, 3)}")
    print(f"first call (numba compile or cache load): {compile_s:.2f} s")
    print(
        f"{'N':>5} {'method':<10} {'seconds':>8} {'triangles':>10} {'watertight':>10} {'ratio':>7}"
    )
    ours = {}
    for n in args.resolutions:
        cell = float(np.max(hi - lo)) / n
        mesh, t_ours = timed(polygonize, tree, resolution=n)
        ours[n] = t_ours
        print(
            f"{n:>5} {'blobtree':<10} {t_ours:>8.2f} {len(mesh.faces):>10} "
            f"{'yes' if mesh.is_watertight else 'NO':>10} {'':>7}"
        )
        (v, f), t_a = timed(peer_numpy, lo, hi, cell)
        print(
            f"{n:>5} {'numpy+mc':<10} {t_a:>8.2f} {len(f):>10} "
            f"{'yes' if welded(v, f).is_watertight else 'NO':>10} {t_ours / t_a:>6.2f}x"
        )
        if n <= args.peer_b_max:
            pts, t_b = timed(peer_sdf, prog, lo, hi, cell)
            tri = np.arange(len(pts)).reshape(-1, 3)
            print(
                f"{n:>5} {'sdf':<10} {t_b:>8.2f} {len(tri):>10} "
                f"{'yes' if welded(pts, tri).is_watertight else 'NO':>10} "
                f"{t_ours / t_b:>6.2f}x"
            )
    for n in args.resolutions:
        if 2 * n in ours:
            print(f"T({2 * n}) / T({n}) = {ours[2 * n] / ours[n]:.2f}")


if __name__ == "__main__":
    main()
