"""Where a render's time goes, kernel by kernel: Linux ``perf`` samples of the render alone, with
numba's compiled functions named (perf cannot name JIT code by itself).

The kernels are compiled afresh into a temporary numba cache (a minute or two); the names,
addresses and sizes of their functions (from each library's object code) go to the
``/tmp/perf-PID.map`` file perf reads.  Then ``perf record`` samples this process while it
renders, and the top functions are printed (a function's share includes what LLVM inlined into
it).  Needs ``perf`` (Debian package ``linux-perf``).

    python bench/perf_kernels.py [--model murex] [--size 512] [--no-shadows] [--look studio]
                                 [--top 25] [--rect X0 Y0 X1 Y1 [--repeat 4]]

``--rect`` samples only that rectangle of the studio picture, rendered ``--repeat`` times on
one thread (``profile_tiles.py``'s renderer): where a slow part of the picture spends its time.
"""

from __future__ import annotations

import argparse
import gc
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="blobtree-perf-")  # before numba loads

import numba  # noqa: E402
from profile_tiles import check_rect, rect_renderer  # noqa: E402

from blobtree.cli.scenes import resolve_scene  # noqa: E402
from blobtree.render import LOOKS, render  # noqa: E402


def _short(name: str) -> str:
    """module.function from a mangled name such as _ZN8blobtree6engine8dispatch9prim_rowsB4v..."""
    parts, i = [], name.find("_ZN") + 3 if "_ZN" in name else len(name)
    while i < len(name) and name[i].isdigit():
        digits = re.match(r"\d+", name[i:]).group()
        i += len(digits)
        parts.append(name[i:i + int(digits)])
        i += int(digits)
    return ".".join(parts[-2:]) if parts else name[:60]


def _symbols(library) -> dict[str, int]:
    """The functions in a numba library's object code and their sizes in bytes (``nm -S``);
    empty if the object code is not at hand."""
    try:
        obj = library._get_compiled_object()
    except Exception:  # (a library without its object code)
        return {}
    with tempfile.NamedTemporaryFile(suffix=".o") as f:
        f.write(obj)
        f.flush()
        listing = subprocess.run(["nm", "-S", "--defined-only", f.name], capture_output=True,
                                 text=True).stdout
    out = {}
    for line in listing.splitlines():
        parts = line.split(maxsplit=3)
        if len(parts) == 4 and parts[2] in "Tt":
            out[parts[3]] = int(parts[1], 16)
    return out


def write_perf_map() -> int:
    """Write the address, size and name of every function compiled for this process's numba
    dispatchers and linked kernels (``runtime.linked``, compiled here or loaded from the cache
    a partner process filled) to /tmp/perf-PID.map; return how many.  Names and sizes come
    from the object code's symbol table: a function taken up to the next named one instead
    bills code that has no name here to its neighbour."""
    from numba.core.registry import CPUDispatcher

    from blobtree.runtime.linked import LINKED

    libraries = {id(c.library): c.library for obj in gc.get_objects()
                 if isinstance(obj, CPUDispatcher) for c in obj.overloads.values()}
    libraries.update({id(k._cfunc._library): k._cfunc._library for k in LINKED
                      if k._cfunc is not None})
    entries = {}
    for lib in libraries.values():
        for name, size in _symbols(lib).items():
            address = lib.get_pointer_to_function(name)
            if address and size:
                entries[address] = (size, _short(name))
    with open(f"/tmp/perf-{os.getpid()}.map", "w") as f:
        for address, (size, name) in sorted(entries.items()):
            f.write(f"{address:x} {size:x} {name}\n")
    return len(entries)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default="murex")
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--look", default="studio", choices=sorted(LOOKS))
    ap.add_argument("--no-shadows", action="store_true")
    ap.add_argument("--top", type=int, default=25)
    ap.add_argument("--rect", type=int, nargs=4, metavar=("X0", "Y0", "X1", "Y1"))
    ap.add_argument("--repeat", type=int, default=4)
    args = ap.parse_args()
    check_rect(ap, args.rect, args.size)
    if args.rect and args.look != "studio":
        ap.error(f"--rect renders the studio look, got --look {args.look}")
    if args.repeat < 1:
        ap.error(f"--repeat must be at least 1, got {args.repeat}")
    perf = shutil.which("perf")
    if perf is None:
        sys.exit("perf not found: install the Debian package linux-perf")
    t0 = time.perf_counter()
    if args.rect:
        numba.set_num_threads(1)
        draw = rect_renderer(args.model, args.size, not args.no_shadows)

        def picture() -> None:
            for _ in range(args.repeat):
                draw(*args.rect)
    else:
        tree = resolve_scene(args.model)
        options = dict(shadows=not args.no_shadows, look=args.look, progress=False)
        render(tree, 32, 32, **options)

        def picture() -> None:
            render(tree, args.size, args.size, **options)
    print(f"compiled in {time.perf_counter() - t0:.0f} s; {write_perf_map()} functions mapped")
    data = os.path.join(tempfile.mkdtemp(prefix="blobtree-perf-"), "perf.data")
    rec = subprocess.Popen([perf, "record", "-q", "-F", "2000", "-p", str(os.getpid()), "-o",
                            data], stderr=subprocess.DEVNULL)
    time.sleep(0.5)  # (perf attaches)
    t0 = time.perf_counter()
    picture()
    seconds = time.perf_counter() - t0
    rec.send_signal(signal.SIGINT)
    rec.wait()
    report = subprocess.run([perf, "report", "-i", data, "--sort", "symbol", "--stdio", "-q"],
                            capture_output=True, text=True).stdout
    what = (f"pixels {args.rect} {args.repeat} times on one thread" if args.rect
            else "the whole picture")
    print(f"{args.model} {args.size}x{args.size}, {args.look}, shadows "
          f"{'off' if args.no_shadows else 'on'}, {what}: {seconds:.2f} s; share of the "
          f"samples:")
    for line in report.splitlines()[:args.top]:
        m = re.match(r"\s*([\d.]+%)\s+\[(.)\]\s+(.*?)[\s-]*$", line)
        if m:
            share, where, name = m.groups()
            print(f"  {share:>7}  {name[:70]}{' (kernel)' if where == 'k' else ''}")


if __name__ == "__main__":
    main()
