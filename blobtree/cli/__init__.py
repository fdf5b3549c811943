"""The ``blobtree`` command line."""

from __future__ import annotations

import contextlib
import gc
import os
import sys
from collections.abc import Callable, Iterator, Mapping
from typing import Any

import click
from tqdm import tqdm

from ..output import check_writable, file_format
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
            tqdm.write("compiling kernels, first run only (under a minute) ...", file=sys.stderr)

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


def direction(ctx, param, value):
    """A click callback parsing ``"x,y,z"`` into a non-zero direction (None stays None)."""
    value = floats(3)(ctx, param, value)
    if value is not None and not any(value):
        raise click.BadParameter(f"expected a non-zero direction x,y,z, got {value}")
    return value


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


def format_option(formats: Mapping[str, str]) -> Callable[[Callable[..., Any]], Any]:
    """A command's ``--format`` option: one of ``formats``' names, for ``-o -`` or a path whose
    extension does not name the format (such as a named pipe)."""
    return click.option(
        "--format", "fmt", type=click.Choice(list(formats), case_sensitive=False),
        help="The output's format  [default: -o's extension; needed with -o -, standard output].")


def checked_output(output: str | os.PathLike, formats: Mapping[str, str] | None = None,
                   fmt: str | None = None) -> str | None:
    """Check ``-o`` before any work: a path that can be written (``-``, standard output, too;
    see :mod:`blobtree.output`) and, with ``formats``, its format (from ``--format`` or else its
    extension), which is returned.  A usage error naming the option otherwise."""
    try:
        check_writable(output, "--output")
        if formats is None:
            return None
        return file_format(output, formats, fmt, name="--output", format_name="--format")
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="-o") from None
