"""Modelling live: seconds from a change of a spec number to the picture, by part.

    python bench/bench_live.py [--spec murex] [--coarse 128] [--size 512] [--rounds 3]

Warm (the kernels loaded, one picture drawn first), for each change below, the best of
``--rounds`` of each column on its own (the rounds' noise differs by part): the parts of the
first picture (``--coarse`` pixels square, the draft the explorer draws while a control moves:
``live.DRAFT``, no shadow rays, a whole pixel as a camera ray's smallest step): building the
tree, compiling its program, framing it (the inside points the camera fits), rendering
(tracing, with the per-tile specialising of the program to each tile's frustum inside it);
then the studio picture (shadows) the explorer draws next, at ``--size`` pixels, from the
same tree.  A turn of the view only renders.  The targets of
docs/live.md: the first picture within 0.3 s of a change, the studio picture within 1.5 s.

Each change starts from the base spec, and its rounds follow one another (the same control
moved again); ``--in-turn`` moves the controls one after another instead, each change on top of
the ones before, as a modeller at the explorer does (a round is one pass over the changes).
"""

from __future__ import annotations

import argparse
import platform
import time

from blobtree.live import DRAFT, LiveShell, View, with_control
from blobtree.models.spec import load_spec

#: The changes timed: a control and its new value (each builds another tree).
CHANGES = (("canal.tilt", 50.0), ("bumps.size", 0.2), ("spiral.beta", 24.0),
           ("whorls.point_radius", 1.3), ("varices.spine_length", 1.0))


def cpu_name() -> str:
    """The processor's model name (Linux), else the platform's word for it."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--spec", default="murex")
    ap.add_argument("--coarse", type=int, default=128)
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--in-turn", action="store_true",
                    help="each change on top of the ones before, a round a pass over them")
    args = ap.parse_args()
    base = load_spec(args.spec)
    live = LiveShell(base)
    live.picture(args.coarse, args.coarse, **DRAFT)  # warm: kernels, caches
    live.picture(args.size, args.size)
    print(f"{cpu_name()}; {args.spec}; first picture {args.coarse}x{args.coarse} (draft: "
          f"{DRAFT}), studio {args.size}x{args.size}; each column the best of {args.rounds}, "
          "seconds")
    print(f"{'change':<28}{'tree':>7}{'program':>9}{'framing':>9}{'render':>8}{'first':>8}"
          f"{'studio':>8}{'total':>8}")
    order = [(r, change) for change in CHANGES for r in range(args.rounds)]
    if args.in_turn:
        order.sort(key=lambda item: item[0])
    best: dict[str, dict[str, float]] = {name: {} for name, _ in CHANGES}
    spec = base
    for r, (name, value) in order:
        # a value new each round, so nothing is reused from a round before
        spec = with_control(spec if args.in_turn else base, name, value * (1.0 + 0.001 * r))
        live.set(spec)
        live.picture(args.coarse, args.coarse, **DRAFT)
        t = dict(live.timings, first=sum(live.timings.values()))
        live.picture(args.size, args.size)
        t["studio"] = live.timings["render"]
        t["total"] = t["first"] + t["studio"]
        best[name] = {k: min(v, best[name].get(k, v)) for k, v in t.items()}
    for name, value in CHANGES:
        b = best[name]
        print(f"{name + ' = ' + format(value, 'g'):<28}{b['tree']:>7.3f}{b['program']:>9.3f}"
              f"{b['framing']:>9.3f}{b['render']:>8.3f}{b['first']:>8.3f}"
              f"{b['studio']:>8.3f}{b['total']:>8.3f}")
    live.set(base)
    live.picture(args.coarse, args.coarse, **DRAFT)  # built again: turns only render
    for label, size, options in (("turn 30 (first)", args.coarse, DRAFT),
                                 ("turn 30 (studio)", args.size, {})):
        start = time.perf_counter()
        live.picture(size, size, View(turn=30.0), **options)
        print(f"{label:<28}{'':>33}{time.perf_counter() - start:>8.3f}")
    start = time.perf_counter()
    live.picture(args.size, args.size, shadows=False)
    print(f"{'studio without shadows':<28}{'':>33}{time.perf_counter() - start:>8.3f}")


if __name__ == "__main__":
    main()
