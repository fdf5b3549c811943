"""The bench record: results appended by the bench scripts run with ``--record``.

``bench/results.jsonl`` holds one JSON object per line, one per bench run: the bench script,
the commit (``-dirty`` when ``blobtree/`` or ``bench/`` had uncommitted changes to tracked
files), the UTC date, the machine, the command line and its rows, each a workload's figure in
seconds against a peer's (or none).  The file is only ever appended to, and every write replaces
it whole through a temporary file, so an interrupted write leaves the old record intact.
``bench/report.py`` turns it into ``docs/benchmarks.md``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import shlex
import stat
import subprocess
import sys
import tempfile
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
RECORD = ROOT / "bench" / "results.jsonl"

ENTRY_KEYS = ("bench", "commit", "date", "machine", "command", "rows")
ROW_KEYS = ("workload", "blobtree_s", "peer", "peer_s", "ratio", "note")
DATE = "%Y-%m-%dT%H:%M:%SZ"  # UTC, to the second


class RecordError(ValueError):
    """A record file that is not a sequence of complete, well-formed entries."""


def timed(fn: Any) -> tuple[Any, float]:
    """(result, seconds) of fn()."""
    start = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - start


def sig4(x: float) -> float:
    """``x`` rounded to 4 significant digits."""
    return float(f"{x:.4g}")


def row(workload: str, blobtree_s: float, peer: str | None = None, peer_s: float | None = None,
        note: str | None = None) -> dict[str, Any]:
    """One row: ``workload``'s time in seconds and the peer's (both rounded to 4 significant
    digits), with their ratio blobtree / peer computed before rounding."""
    if not (math.isfinite(blobtree_s) and blobtree_s > 0):
        raise ValueError(f"{workload}: blobtree time {blobtree_s!r} is not a positive time")
    if (peer is None) != (peer_s is None):
        raise ValueError(f"{workload}: a peer needs both its name and its time")
    if peer_s is not None and not (math.isfinite(peer_s) and peer_s > 0):
        raise ValueError(f"{workload}: peer time {peer_s!r} is not a positive time")
    return {"workload": workload, "blobtree_s": sig4(blobtree_s), "peer": peer,
            "peer_s": None if peer_s is None else sig4(peer_s),
            "ratio": None if peer_s is None else sig4(blobtree_s / peer_s), "note": note}


def machine() -> dict[str, Any]:
    """CPU model, logical cores, widest vector extension (avx512, avx2 or none), memory GiB."""
    cpu, flags = "", set()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            if key.strip() == "model name" and not cpu:
                cpu = value.strip()
            elif key.strip() == "flags" and not flags:
                flags = set(value.split())
    except OSError:
        pass
    simd = "avx512" if "avx512f" in flags else "avx2" if "avx2" in flags else "none"
    memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    return {"cpu": re.sub(r"\s+", " ", cpu) or "unknown", "cores": os.cpu_count(),
            "simd": simd, "memory_gib": round(memory, 1)}


def commit(root: Path = ROOT) -> str:
    """``git rev-parse --short HEAD`` of ``root``, with ``-dirty`` when tracked files under
    ``blobtree/`` or ``bench/`` (the record itself aside) have uncommitted changes."""
    def git(*args: str) -> str:
        return subprocess.run(["git", "-C", str(root), *args], check=True, capture_output=True,
                              text=True).stdout

    try:
        head = git("rev-parse", "--short", "HEAD").strip()
        status = git("status", "--porcelain", "--", "blobtree", "bench",
                     f":(exclude){RECORD.relative_to(ROOT).as_posix()}")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    dirty = any(line and not line.startswith("??") for line in status.splitlines())
    return head + ("-dirty" if dirty else "")


def command_line(argv: list[str] | None = None) -> str:
    """The command as run: ``python`` and the script's path relative to the repository."""
    argv = sys.argv if argv is None else argv
    script = Path(argv[0]).resolve()
    shown = script.relative_to(ROOT) if script.is_relative_to(ROOT) else script
    return shlex.join(["python", shown.as_posix(), *argv[1:]])


def load(path: Path = RECORD) -> list[dict[str, Any]]:
    """The entries of a record file (none if it does not exist); raises :class:`RecordError`
    naming the file and line of an incomplete or malformed line."""
    try:
        return parse(path.read_text(encoding="utf-8"), path)
    except FileNotFoundError:
        return []


def parse(text: str, path: Path) -> list[dict[str, Any]]:
    """The entries of the record ``text`` read from ``path`` (see :func:`load`)."""
    lines = text.split("\n")
    if lines[-1]:
        raise RecordError(f"{path}:{len(lines)}: incomplete last line (no newline at its end: "
                          f"an interrupted write?)")
    entries = []
    for number, line in enumerate(lines[:-1], 1):
        try:
            entry = json.loads(line)
            check_entry(entry)
        except (json.JSONDecodeError, ValueError) as exc:
            raise RecordError(f"{path}:{number}: not a complete record entry: {exc}") from None
        entries.append(entry)
    return entries


def check_entry(entry: Any) -> None:
    """Raise ValueError unless ``entry`` has the record's keys, a UTC date, and rows with
    theirs (``note`` optional), numbers for times and workloads distinct within the entry."""
    if not isinstance(entry, dict) or set(entry) != set(ENTRY_KEYS):
        raise ValueError(f"keys must be {', '.join(ENTRY_KEYS)}")
    datetime.strptime(str(entry["date"]), DATE)
    if not isinstance(entry["rows"], list):
        raise ValueError("rows must be a list")
    for r in entry["rows"]:
        if not isinstance(r, dict) or not set(ROW_KEYS) - {"note"} <= set(r) <= set(ROW_KEYS):
            raise ValueError(f"each row's keys must be {', '.join(ROW_KEYS)} (note optional)")
        if not isinstance(r["workload"], str):
            raise ValueError("a workload must be a string")
        if not all(is_number(r[k]) or (k != "blobtree_s" and r[k] is None)
                   for k in ("blobtree_s", "peer_s", "ratio")):
            raise ValueError(f"{r['workload']}: times and ratio must be numbers")
    workloads = [r["workload"] for r in entry["rows"]]
    if len(set(workloads)) != len(workloads):
        raise ValueError("a workload appears twice in one entry")


def is_number(x: Any) -> bool:
    """Whether ``x`` is a JSON number (not a boolean)."""
    return isinstance(x, int | float) and not isinstance(x, bool)


def append(bench: str, rows: list[dict[str, Any]], path: Path = RECORD,
           now: datetime | None = None) -> dict[str, Any]:
    """Append one bench run's entry to the record at ``path`` and return it.

    The commit, machine and command line are read here, the date from the clock (or ``now``).
    An existing record is checked first (a malformed one is refused, not extended); the old
    content and the new line go to a temporary file that then replaces the record.
    """
    if not rows:
        raise ValueError("no rows to record")
    entry = {"bench": bench, "commit": commit(),
             "date": (now or datetime.now(UTC)).astimezone(UTC).strftime(DATE),
             "machine": machine(), "command": command_line(), "rows": rows}
    check_entry(entry)
    old, mode = b"", 0o644
    if path.exists():
        old, mode = path.read_bytes(), stat.S_IMODE(path.stat().st_mode)
        parse(old.decode("utf-8"), path)
    new = old + (json.dumps(entry, ensure_ascii=False) + "\n").encode("utf-8")
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.chmod(tmp, mode)  # mkstemp's file is private (0600)
        with os.fdopen(fd, "wb") as f:
            f.write(new)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return entry


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The bench scripts' ``--record`` and ``--record-file`` options."""
    shown = RECORD.relative_to(ROOT).as_posix()
    parser.add_argument("--record", action="store_true",
                        help=f"append the figures to {shown} (then: python bench/report.py)")
    parser.add_argument("--record-file", type=Path, default=None, metavar="PATH",
                        help=f"append the figures to PATH instead of {shown} (implies --record)")


def target(args: argparse.Namespace) -> Path | None:
    """The record file the parsed options ask for (None: no recording), checked before the
    bench runs so a malformed record fails at once rather than after the measurements."""
    if not (args.record or args.record_file):
        return None
    path = args.record_file or RECORD
    load(path)
    return path
