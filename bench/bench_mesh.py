"""Benchmark the polygonizer on whorl126 against two peers measured in the same run.

Peers, at the same bounds and cell size, all timed best of ``--repeat`` runs (the machine is
shared):
  (a) numpy: the field on the dense grid, each primitive evaluated only inside its own box,
      then ``skimage.measure.marching_cubes``;
  (b) fogleman's ``sdf`` (PyPI ``sdf-fork``) meshing the custom function ``0.5 - field``, the
      field in numpy as in (a) (each primitive only on the points inside its box).  Its sparse
      block skip assumes a distance bound, so the function is divided by the global Lipschitz
      constant (same surface).  Its triangle soup is welded (equal positions) before the
      watertight check.
Our first call (numba compile or cache load) is reported apart.

Then the whole command ``blobtree mesh murex --resolution 512 -o murex.stl`` (start-up, tree,
meshing, file, checks), best of ``--repeat``, against the bar of 8 s (``--murex 0`` skips
it).  With ``--record`` the figures are appended to bench/results.jsonl (see bench/record.py).

Usage: python bench/bench_mesh.py [--resolutions 128 256 512] [--peer-b-max 256] [--repeat 3]
                                  [--murex 512] [--record] [--record-file PATH]
"""

from __future__ import annotations

import argparse
import compileall
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import record

import blobtree as bt
from blobtree.fields import soft_object
from blobtree.mesh import Mesh, polygonize

PEER_A = "numpy + scikit-image marching_cubes"
PEER_B = "sdf (sdf-fork)"


def whorl_spheres() -> tuple[np.ndarray, np.ndarray]:
    """Centres and field radii of the 126 points of whorl126 (docs/conventions.md)."""
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


def numpy_field(p: np.ndarray) -> np.ndarray:
    """whorl126's field at points (N, 3) in numpy, each primitive only on points in its box."""
    centres, radii = whorl_spheres()
    f = np.zeros(len(p))
    lo, hi = p.min(axis=0), p.max(axis=0)
    near = np.all((centres + radii[:, None] >= lo) & (centres - radii[:, None] <= hi), axis=1)
    for c, rad in zip(centres[near], radii[near], strict=True):
        inside = np.flatnonzero(np.all(np.abs(p - c) <= rad, axis=1))
        s = np.sum((p[inside] - c) ** 2, axis=1) / rad**2
        f[inside] += np.where(s < 1.0, soft_object(s), 0.0)
    return f


def peer_sdf(scale: float, lo, hi, cell: float):
    """Peer (b): fogleman's sdf on 0.5 - field (scaled to a distance bound); a triangle soup."""
    from sdf import sdf3
    from sdf.mesh import generate

    @sdf3
    def shape():
        return lambda p: (0.5 - numpy_field(np.asarray(p, dtype=np.float64))) * scale

    return np.asarray(generate(shape(), step=cell, bounds=(lo - cell, hi + cell), verbose=False))


def welded(verts: np.ndarray, faces: np.ndarray) -> Mesh:
    """A Mesh of a triangle list, with coincident vertices merged."""
    uniq, inv = np.unique(np.round(verts, 9), axis=0, return_inverse=True)
    z = np.zeros_like(uniq)
    return Mesh(uniq, inv.reshape(-1)[faces], z, z)


def best(repeat: int, fn, *args, **kw):
    """(result, best wall time in seconds) over ``repeat`` runs."""
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn(*args, **kw)
        times.append(time.perf_counter() - t)
    return out, min(times)


def row(n: int, name: str, seconds: float, triangles: int, watertight: bool, ratio: str) -> None:
    print(
        f"{n:>5} {name:<10} {seconds:>8.2f} {triangles:>10} "
        f"{'yes' if watertight else 'NO':>10} {ratio:>7}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolutions", type=int, nargs="+", default=[128, 256, 512])
    ap.add_argument("--peer-b-max", type=int, default=256, help="skip peer (b) above this N")
    ap.add_argument("--repeat", type=int, default=3, help="best of this many runs")
    ap.add_argument("--murex", type=int, default=512,
                    help="resolution of the whole-command Murex mesh timing (0: skip it)")
    record.add_arguments(ap)
    args = ap.parse_args()
    record_file = record.target(args)
    note = f"best of {args.repeat}"
    recorded = []

    tree = bt.models.whorl126()
    prog = tree.program()
    lo, hi = (np.asarray(b, dtype=np.float64) for b in prog.bounds)
    _, compile_s = best(1, polygonize, tree, resolution=16)
    print(f"whorl126, bounds {np.round(lo, 3)} .. {np.round(hi, 3)}, best of {args.repeat}")
    print(f"first call (numba compile or cache load): {compile_s:.2f} s")
    print(
        f"{'N':>5} {'method':<10} {'seconds':>8} {'triangles':>10} {'watertight':>10} "
        f"{'ours/it':>7}"
    )
    ours = {}
    for n in args.resolutions:
        cell = float(np.max(hi - lo)) / n
        mesh, ours[n] = best(args.repeat, polygonize, tree, resolution=n)
        row(n, "blobtree", ours[n], len(mesh.faces), mesh.is_watertight, "")
        (v, f), t_a = best(args.repeat, peer_numpy, lo, hi, cell)
        zero = np.zeros_like(v)  # skimage's mesh is indexed already
        row(
            n,
            "numpy+mc",
            t_a,
            len(f),
            Mesh(v, f, zero, zero).is_watertight,
            f"{ours[n] / t_a:.2f}x",
        )
        recorded.append(record.row(f"whorl126 polygonize at resolution {n}", ours[n], PEER_A,
                                   t_a, note))
        if n <= args.peer_b_max:
            pts, t_b = best(args.repeat, peer_sdf, 1.0 / prog.lipschitz_global, lo, hi, cell)
            tri = np.arange(len(pts)).reshape(-1, 3)
            row(n, "sdf", t_b, len(tri), welded(pts, tri).is_watertight, f"{ours[n] / t_b:.2f}x")
            recorded.append(record.row(f"whorl126 polygonize at resolution {n}, sdf peer",
                                       ours[n], PEER_B, t_b, note))
    for n in args.resolutions:
        if 2 * n in ours:
            print(f"T({2 * n}) / T({n}) = {ours[2 * n] / ours[n]:.2f}")
    if args.murex:
        t_murex = murex_command(args.murex, args.repeat)
        recorded.append(record.row(f"murex mesh at resolution {args.murex}, whole command",
                                   t_murex, note=note))
    if record_file:
        record.append("bench_mesh.py", recorded, record_file)
        print(f"recorded in {record_file}")


#: the bar (the most it may take) for the whole ``blobtree mesh murex --resolution 512`` command,
#: seconds
MUREX_BAR = 8.0


def murex_command(resolution: int, repeat: int) -> float:
    """Time the whole ``blobtree mesh murex`` command (its kernels cached by a first run; the
    package's bytecode compiled, as an install has it); its best time in seconds."""
    compileall.compile_dir(Path(bt.__file__).parent, quiet=1)
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "blobtree.cli.main", "mesh", "murex", "--resolution",
               str(resolution), "-o", str(Path(tmp) / "murex.stl")]
        warm = cmd[:6] + ["16"] + cmd[7:]  # loads (or compiles) the kernels, untimed
        subprocess.run(warm, check=True, capture_output=True)
        times, out = [], ""
        for _ in range(repeat):
            t = time.perf_counter()
            out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
            times.append(time.perf_counter() - t)
    print(f"blobtree mesh murex --resolution {resolution}, whole command: {min(times):.2f} s "
          f"(best of {repeat}; bar at 512: {MUREX_BAR:g} s)  {out.strip()}")
    return min(times)


if __name__ == "__main__":
    main()
