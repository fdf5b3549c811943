"""Writing files whole or not at all."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def check_writable(path: str | os.PathLike, name: str = "path") -> Path:
    """``path`` as a Path if a file can be written there (its directory exists and is writable,
    and it is not itself a directory); ValueError naming ``name`` otherwise."""
    target = Path(path)
    parent, where = target.parent, repr(str(target.parent)[:200])
    problem = (
        "is a directory" if target.is_dir()
        else f"is in {where}, which does not exist" if not parent.exists()
        else f"is in {where}, which is not a directory" if not parent.is_dir()
        else f"is in {where}, which is not writable" if not os.access(parent, os.W_OK)
        else None)
    if problem:
        raise ValueError(f"{name} {str(target)[:200]!r} {problem}")
    return target


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it replaces ``path`` in one step.

    On any error (or Ctrl-C) the temporary file is removed and ``path`` is left as it was.
    """
    target = check_writable(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=target.suffix or ".tmp",
                               dir=target.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes files private; use the usual mode
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
