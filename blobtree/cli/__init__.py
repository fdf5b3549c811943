"""The ``blobtree`` command line."""

from __future__ import annotations

import contextlib
import gc
import sys
from collections.abc import Iterator

import click
from tqdm import tqdm

from ..runtime.jit import on_compile


def start_command() -> None:
    """Process-wide set-up of a ``blobtree`` command, before it runs (not on import, so code
    that imports the CLI keeps the garbage collector as it was)."""
    # The ~70,000 objects numpy and numba create on import live as long as the command: frozen,
    # they are no longer walked by every full collection.
    gc.freeze()


@contextlib.contextmanager
def compile_notice(quiet: bool = False) -> Iterator[None]:
    """Say once, when numba starts compiling within the block, that this is a first run."""

    def notice() -> None:
        if not quiet:  # through tqdm, so a progress bar on screen stays whole
            tqdm.write("compiling kernels, first run only (a minute or two) ...", file=sys.stderr)

    with on_compile(notice):
        yield


def floats(n: int):
    """A click callback parsing ``"a,b,c"`` into a tuple of n floats (None stays None)."""

    def parse(ctx, param, value):
        if value is None:
            return None
        try:
            out = tuple(float(v) for v in value.split(","))
        except ValueError:
            out = ()
        if len(out) != n:
            raise click.BadParameter(f"expected {n} comma-separated numbers, got {value!r}")
        return out

    return parse


#: Millimetres per unit of length accepted by --height.
UNITS = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4}


def length_mm(ctx, param, value):
    """A click callback reading a length such as ``80mm`` or ``3in`` into millimetres."""
    if value is None:
        return None
    text = value.strip().lower()
    unit = next((u for u in sorted(UNITS, key=len, reverse=True) if text.endswith(u)), "mm")
    number = text[: len(text) - len(unit)] if text.endswith(unit) else text
    try:
        mm = float(number) * UNITS[unit]
    except ValueError:
        mm = float("nan")
    if not 0.01 <= mm <= 1e5:
        raise click.BadParameter(f"expected a length from 0.01 mm to 100 m such as 80mm, 8cm or "
                                 f"3in, got {value!r}")
    return mm
