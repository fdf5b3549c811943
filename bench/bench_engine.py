"""Field evaluations per second on whorl126: compiled engine vs plain numpy.

The numpy peer computes all 126 primitives at every point, vectorised over points in chunks.
Both are timed as the best of ``--repeat`` runs on the same points (the first touch of a large
fresh array costs page faults that a long-running process pays once).  With ``--record`` the
figures are appended to bench/results.jsonl (see bench/record.py).
Run: python bench/bench_engine.py [--sizes 1e6 1e7] [--repeat 3] [--record] [--record-file PATH]
"""

from __future__ import annotations

import argparse
import compileall
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import record

import blobtree as bt
from blobtree import geometry as geo
from blobtree.fields import falloff

CHUNK = 1 << 16
PEER = "numpy, every primitive at every point"


def numpy_peer(tree: bt.Node, P: np.ndarray) -> np.ndarray:
    """Sum of all point primitives at every point (each primitive's maths in numpy)."""
    prims = []
    for inst in tree.children:  # rotate(translate(scale(point)))
        m, node = geo.IDENTITY, inst
        while not isinstance(node, bt.Primitive):
            m = geo.compose(m, node.matrix)
            node = node.child
        prims.append((geo.invert(m), node.center, node.radius ** 2))
    out = np.empty(len(P))
    for s in range(0, len(P), CHUNK):
        q0 = P[s:s + CHUNK]
        acc = np.zeros(len(q0))
        x0, y0, z0 = q0[:, 0], q0[:, 1], q0[:, 2]
        for inv, c, r2 in prims:
            b = inv[:, 3] - c  # elementwise, no BLAS threads: a fair single-machine baseline
            qx = inv[0, 0] * x0 + inv[0, 1] * y0 + inv[0, 2] * z0 + b[0]
            qy = inv[1, 0] * x0 + inv[1, 1] * y0 + inv[1, 2] * z0 + b[1]
            qz = inv[2, 0] * x0 + inv[2, 1] * y0 + inv[2, 2] * z0 + b[2]
            x = (qx * qx + qy * qy + qz * qz) / r2
            acc += np.where(x < 1.0, falloff(0, np.minimum(x, 1.0)), 0.0)
        out[s:s + CHUNK] = acc
    return out


def best_of(repeat: int, fn, *args) -> tuple[float, np.ndarray]:
    """(best wall time of ``repeat`` calls, the result)."""
    best = float("inf")
    for _ in range(max(1, repeat)):
        t0 = time.perf_counter()
        out = fn(*args)
        best = min(best, time.perf_counter() - t0)
    return best, out


def second_process_start() -> float:
    """Seconds for a fresh process to import blobtree and evaluate (cache load, no compile),
    with the package's bytecode compiled as an install has it."""
    compileall.compile_dir(Path(bt.__file__).parent, quiet=1)
    code = ("import time; t=time.perf_counter(); import numpy as np, blobtree as bt; "
            "bt.models.whorl126().field(np.zeros((1, 3))); print(time.perf_counter()-t)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return float(out.stdout.strip())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--sizes", type=float, nargs="+", default=[1e6, 1e7])
    ap.add_argument("--repeat", type=int, default=3)
    record.add_arguments(ap)
    args = ap.parse_args()
    record_file = record.target(args)
    tree = bt.models.whorl126()
    t0 = time.perf_counter()
    prog = tree.program()
    from blobtree.engine import GRID_MIN_POINTS

    prog.field(np.zeros((1, 3)))
    prog.field(np.zeros((GRID_MIN_POINTS, 3)))  # builds the grid of specialised programs
    print(f"first calls in this process (kernel compile or cache load, tree compile, grid): "
          f"{time.perf_counter() - t0:.2f} s")
    t_start = second_process_start()
    print(f"fresh process, import + first evaluation: {t_start:.2f} s")
    recorded = [record.row("import blobtree and a first whorl126 field, fresh process", t_start,
                           note="one run, kernels cached")]
    lo, hi = prog.bounds
    rng = np.random.default_rng(1)
    for n in (int(s) for s in args.sizes):
        P = rng.uniform(lo, hi, (n, 3))
        te, f = best_of(args.repeat, prog.field, P)
        tn, ref = best_of(args.repeat, numpy_peer, tree, P)
        err = np.abs(f - ref).max()
        print(f"N={n:>9}: engine {te:7.3f} s ({n / te / 1e6:7.1f} M/s)   numpy {tn:7.2f} s "
              f"({n / tn / 1e6:6.2f} M/s)   ratio {tn / te:6.1f}x   max |diff| {err:.1e}"
              f"   (best of {args.repeat})")
        recorded.append(record.row(f"whorl126 field at {n:,} random points", te, PEER, tn,
                                   f"best of {args.repeat}"))
    if record_file:
        record.append("bench_engine.py", recorded, record_file)
        print(f"recorded in {record_file}")


if __name__ == "__main__":
    main()
