"""How every output is written: the one place that decides, for any path, how its bytes get there.

- ``-`` is standard output.
- An existing FIFO, device or other file that is not a regular file is written into: opened and
  written, never replaced (a pipe's reader gets the bytes; a device reports its own errors).
- Anything else (a regular file, or a path not there yet), through any symlinks, is written whole
  or not at all: a temporary file beside the links' final target, renamed over that target, so
  the links stay links.
"""

from __future__ import annotations

import contextlib
import os
import stat
import sys
import tempfile
from collections.abc import Mapping
from pathlib import Path

#: The path that means standard output.
STDOUT = "-"


def is_stdout(path: str | os.PathLike) -> bool:
    """Whether ``path`` means standard output (``-``)."""
    return os.fspath(path) == STDOUT


def display_name(path: str | os.PathLike) -> str:
    """How messages name an output: its path, or "standard output" for ``-``."""
    return "standard output" if is_stdout(path) else os.fspath(path)


def _special(path: Path) -> bool:
    """Whether ``path`` exists and is neither a regular file nor a directory (a FIFO, a device,
    a socket): written into, never replaced."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return False
    return not (stat.S_ISREG(mode) or stat.S_ISDIR(mode))


def check_writable(path: str | os.PathLike, name: str = "path") -> Path:
    """``path`` as a Path if it can be written (see the module's docstring): standard output;
    an existing FIFO or device we may write to; else a file whose directory (a symlink's target's,
    for a link) exists and is writable.  ValueError naming ``name`` otherwise."""
    given = Path(path)
    if is_stdout(given):
        return given
    target = Path(os.path.realpath(given))
    shown = repr(str(given)[:200])
    if given.is_symlink():
        shown += f" (a link to {str(target)[:200]!r})"
    parent, where = target.parent, repr(str(target.parent)[:200])
    problem = (
        "is a directory" if target.is_dir()
        else ("is not writable" if not os.access(target, os.W_OK) else None) if _special(target)
        else f"is in {where}, which does not exist" if not parent.exists()
        else f"is in {where}, which is not a directory" if not parent.is_dir()
        else f"is in {where}, which is not writable" if not os.access(parent, os.W_OK)
        else None)
    if problem:
        raise ValueError(f"{name} {shown} {problem}")
    return given


def file_format(path: str | os.PathLike, formats: Mapping[str, str], format: str | None = None,
                name: str = "path", format_name: str = "format") -> str:
    """The format ``path`` is written in: ``format`` if given, else the one its extension names.
    ``formats`` maps each accepted name (an extension without its dot, such as ``"png"``) to the
    format it means.  Standard output (``-``) needs ``format``.  ValueError naming the parameter,
    the value and the names allowed otherwise."""
    allowed = ", ".join(formats)
    if format is not None:
        if format.lower() not in formats:
            raise ValueError(f"{format_name} {format!r} is not one of {allowed}")
        return formats[format.lower()]
    if is_stdout(path):
        raise ValueError(f"{name} '-' (standard output) needs {format_name}: one of {allowed}")
    suffix = Path(path).suffix
    if suffix.lower().lstrip(".") not in formats:
        raise ValueError(f"{name} {str(path)[:200]!r}: extension {suffix[:20]!r} is not one of "
                         f"{allowed} (or give {format_name})")
    return formats[suffix.lower().lstrip(".")]


def _write_all(fd: int, data: memoryview) -> None:
    """Write all of ``data`` to the file descriptor (a pipe may take it in pieces)."""
    while data:
        data = data[os.write(fd, data):]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _replace(target: Path, data: memoryview) -> None:
    """Write ``data`` to a temporary file beside ``target``, then rename it over ``target``; on
    any error (or Ctrl-C) remove the temporary file and leave ``target`` as it was."""
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=target.suffix or ".tmp",
                               dir=target.parent)
    try:
        try:
            _write_all(fd, data)
        finally:
            os.close(fd)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes files private; use the usual mode
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def write_file(path: str | os.PathLike, data: bytes | bytearray | memoryview) -> Path:
    """Write ``data`` (any bytes-like object, such as a uint8 array) to ``path`` the way the
    module's docstring says: standard output, into a FIFO or device, or whole or not at all.
    A failed write raises OSError naming the path and the system's reason."""
    given = check_writable(path)
    view = memoryview(data).cast("B")
    shown = display_name(given)[:200]
    try:
        if is_stdout(given):
            out = sys.stdout.buffer
            while view:  # (a write to a pipe its reader closed can return short, then fail)
                view = view[out.write(view):]
            out.flush()
            return given
        target = Path(os.path.realpath(given))
        if _special(target):
            fd = os.open(target, os.O_WRONLY)
            try:
                _write_all(fd, view)
            finally:
                os.close(fd)
        else:
            _replace(target, view)
    except OSError as exc:
        raise OSError(exc.errno, f"cannot write {shown}: {exc.strerror or exc}") from None
    return given
