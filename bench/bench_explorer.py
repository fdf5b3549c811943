"""Modelling live as the notebook shows it: seconds from setting a control of ``bt.explore`` to
each picture it shows.

    python bench/bench_explorer.py [--spec murex] [--rounds 2] [--settle SECONDS]

Drives the explorer in-process (needs ``blobtree[explore]``), warm, the way a notebook does:
the control set from the main thread, which then blocks (as a kernel's event loop does) until
the picture is shown (``image`` changes).  For each change of ``bench_live.CHANGES``, each
round a new value: the draft (``live.DRAFT``, at ``coarse`` pixels), then, after the ``settle``
pause, the 512 studio picture: its first glimpse (the tiles finished after ``live.GLIMPSE``
seconds, over the draft scaled) and the whole picture; the parts of the draft as
``LiveShell.timings`` reports them.  Then, as a modeller does who changes a number again while
looking at the studio picture forming: the control set anew, and once the first glimpse is shown
set once more; "again" is the seconds from that last change to its draft (the studio picture
being drawn is stopped first).  Last, a slider dragged: ``canal.tilt`` set to ``DRAGGED``
values ``DRAG_GAP`` seconds apart, and the seconds from the last to its draft and its studio
picture.  Unlike ``bench/bench_live.py`` this includes waking the
drawing thread, encoding the PNG and the settle pause.  A main thread that polls instead of
blocking takes the GIL from the drawing thread's compile: sleeping 2 ms between looks made the
drafts a third slower here.
"""

from __future__ import annotations

import argparse
import threading
import time

from bench_live import CHANGES, cpu_name

#: The drag timed last: this many values of a control, DRAG_GAP seconds apart (a slider held
#: and moved sends a value every few hundredths of a second).
DRAGGED, DRAG_GAP = 20, 0.06


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--spec", default="murex")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--settle", type=float, default=None,
                    help="the explorer's settle pause, seconds (default: its own)")
    args = ap.parse_args()
    import blobtree as bt

    explorer = bt.explore(args.spec, **({} if args.settle is None else {"settle": args.settle}))
    explorer.wait()
    shown: list[tuple[float, int, dict[str, float]]] = []
    seen = {side: threading.Event() for side in (explorer.coarse, explorer.size)}

    def on_picture(change) -> None:  # (on the drawing thread, the picture's timings at hand)
        side = int.from_bytes(change["new"][16:20], "big")  # the PNG's width
        shown.append((time.perf_counter(), side, dict(explorer.live.timings)))
        seen[side].set()

    def again(name: str, value: float) -> float:
        """Seconds to the draft of a change made while the studio picture is drawn."""
        seen[explorer.size].clear()
        explorer.controls[name].value = value
        seen[explorer.size].wait()
        seen[explorer.coarse].clear()
        start = time.perf_counter()
        explorer.controls[name].value = value * 1.01
        seen[explorer.coarse].wait()
        took = time.perf_counter() - start
        explorer.wait()
        return took

    explorer.image.observe(on_picture, names="value")
    print(f"{cpu_name()}; {args.spec}; settle {explorer.settle} s; seconds from setting the "
          "control to each picture shown")
    print(f"{'change':<30}{'draft':>7}{'(tree':>7}{'program':>8}{'framing':>8}{'render)':>9}"
          f"{'glimpse':>8}{'studio':>8}{'again':>7}")
    try:
        for name, value in CHANGES:
            for r in range(args.rounds):
                shown.clear()
                start = time.perf_counter()
                explorer.controls[name].value = value * (1.0 + 0.02 * (r + 1))
                explorer.wait()
                at = {side: (t - start, parts) for t, side, parts in shown}  # (the last)
                first, parts = at[explorer.coarse]
                glimpse = next(t - start for t, side, _ in shown if side == explorer.size)
                print(f"{name + ' = ' + format(explorer.controls[name].value, '.4g'):<30}"
                      f"{first:>7.3f}{parts['tree']:>7.3f}{parts['program']:>8.3f}"
                      f"{parts['framing']:>8.3f}{parts['render']:>9.3f}"
                      f"{glimpse:>8.3f}{at[explorer.size][0]:>8.3f}"
                      f"{again(name, value * (1.01 + 0.02 * (r + 1))):>7.3f}")
        for r in range(args.rounds):  # a slider dragged: values DRAG_GAP s apart
            shown.clear()
            for k in range(DRAGGED):
                explorer.controls["canal.tilt"].value = 45.0 + 0.5 * k + 0.1 * r
                start = time.perf_counter()
                time.sleep(DRAG_GAP)
            explorer.wait()
            draft = [t for t, side, _ in shown if side == explorer.coarse]
            print(f"canal.tilt dragged, {DRAGGED} values {DRAG_GAP} s apart: {len(draft)} drafts "
                  f"shown; the last value's draft {draft[-1] - start:.3f} s after it, its "
                  f"studio picture {shown[-1][0] - start:.3f} s")
    finally:
        explorer.close()


if __name__ == "__main__":
    main()
