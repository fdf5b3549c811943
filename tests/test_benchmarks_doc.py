"""docs/benchmarks.md (and README.md's bench table) are what bench/report.py makes of the record
bench/results.jsonl; bench/record.py and bench/report.py checked on temporary records."""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
from datetime import UTC, datetime
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))

import record  # noqa: E402
import report  # noqa: E402

D1 = datetime(2030, 1, 2, 3, 4, 5, tzinfo=UTC)
D2 = datetime(2030, 2, 3, 4, 5, 6, tzinfo=UTC)


def test_committed_docs_match_the_record():
    done = subprocess.run([sys.executable, "bench/report.py", "--check"], cwd=ROOT,
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""


def rec(root: Path) -> Path:
    """The record file of ``root``, made like the repository (with bench/ and docs/)."""
    (root / "docs").mkdir(exist_ok=True)
    path = root / "bench" / "results.jsonl"
    path.parent.mkdir(exist_ok=True)
    return path


def section(doc: str, workload: str) -> str:
    """The text of ``workload``'s section of a generated page."""
    return doc.split(f"\n## {workload}\n", 1)[1].split("\n## ", 1)[0]


def test_row_rounds_to_4_digits_and_ratio_is_blobtree_over_peer():
    r = record.row("w", 1.234567, "P", 4.938271, "best of 3")
    assert r == {"workload": "w", "blobtree_s": 1.235, "peer": "P", "peer_s": 4.938,
                 "ratio": 0.25, "note": "best of 3"}
    assert record.row("w", 2.0, "P", 0.5)["ratio"] == 4.0
    assert record.row("w", 0.0123456)["blobtree_s"] == 0.01235
    alone = record.row("w", 3.0)
    assert alone["peer"] is alone["peer_s"] is alone["ratio"] is None


@pytest.mark.parametrize("args", [("w", float("inf")), ("w", 0.0), ("w", 1.0, "P"),
                                  ("w", 1.0, None, 2.0), ("w", 1.0, "P", float("nan"))])
def test_row_refuses_missing_or_invalid_times(args):
    with pytest.raises(ValueError, match="^w: "):
        record.row(*args)


def test_two_entries_give_tables_newest_first(tmp_path):
    path = rec(tmp_path)
    # appended out of date order (as after merging two branches' records): dates decide
    record.append("bench_x.py", [record.row("w", 2.0, "P", 4.0, "best of 3"),
                                 record.row("v", 9.0)], path, now=D2)
    record.append("bench_x.py", [record.row("w", 3.0, "P", 4.0, "best of 3")], path, now=D1)
    lines = path.read_text().splitlines()
    assert [json.loads(x)["date"] for x in lines] == ["2030-02-03T04:05:06Z",
                                                      "2030-01-02T03:04:05Z"]
    doc = report.outputs(tmp_path)[report.DOC]
    w = section(doc, "w")
    new, old = w.index("| 2030-02-03 04:05 |"), w.index("| 2030-01-02 03:04 |")
    assert new < old
    assert "| 2 s | P: 4 s | 0.5 |" in w and "| 3 s | P: 4 s | 0.75 |" in w
    assert "| 9 s | – | – |" in section(doc, "v")
    latest = doc.split("## Newest figure per workload\n", 1)[1].split("\n## ", 1)[0]
    assert "| w | 2 s | P: 4 s | 0.5 |" in latest and "| 3 s |" not in latest
    assert latest.index("| w |") < latest.index("| v |")  # the record's order of workloads
    for word in ("session", "today", "latest run", "slow day"):
        assert word not in doc.lower()


def test_append_records_commit_machine_command_and_keeps_old_bytes(tmp_path):
    path = rec(tmp_path)
    path.write_bytes(b'{"bench": "b", "commit": "c", "date": "2030-01-01T00:00:00Z", '
                     b'"machine": {}, "command": "x", "rows": []}\n')
    path.chmod(0o640)
    old = path.read_bytes()
    entry = record.append("bench_x.py", [record.row("w", 1.0)], path, now=D1)
    assert path.read_bytes().startswith(old)
    assert json.loads(path.read_bytes()[len(old):]) == entry
    assert re.fullmatch(r"([0-9a-f]{4,40}(-dirty)?|unknown)", entry["commit"])
    assert set(entry["machine"]) == {"cpu", "cores", "simd", "memory_gib"}
    assert entry["machine"]["simd"] in {"avx512", "avx2", "none"}
    assert entry["machine"]["memory_gib"] > 0
    assert entry["command"].startswith("python ")
    assert sorted(p.name for p in path.parent.iterdir()) == ["results.jsonl"]  # no temp file
    assert path.stat().st_mode & 0o777 == 0o640


def test_a_write_cut_short_leaves_the_record_as_it_was(tmp_path, monkeypatch):
    path = rec(tmp_path)
    record.append("bench_x.py", [record.row("w", 1.0)], path, now=D1)
    before = path.read_bytes()

    def cut(src, dst):
        raise KeyboardInterrupt

    monkeypatch.setattr(record.os, "replace", cut)
    with pytest.raises(KeyboardInterrupt):
        record.append("bench_x.py", [record.row("w", 2.0)], path, now=D2)
    assert path.read_bytes() == before
    assert sorted(p.name for p in path.parent.iterdir()) == ["results.jsonl"]


def test_a_partial_last_line_is_refused_naming_file_and_line(tmp_path, capsys):
    path = rec(tmp_path)
    record.append("bench_x.py", [record.row("w", 1.0)], path, now=D1)
    whole = path.read_text()
    path.write_text(whole + whole[: len(whole) // 2])  # a write cut short
    with pytest.raises(record.RecordError, match=re.escape(f"{path}:2: incomplete last line")):
        record.load(path)
    before = path.read_bytes()
    with pytest.raises(record.RecordError):
        record.append("bench_x.py", [record.row("w", 1.0)], path, now=D2)
    assert path.read_bytes() == before
    assert report.main(["--check"], root=tmp_path) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{path}:2" in err


@pytest.mark.parametrize("bad", ['{"bench": "b"', '{"bench": "b"}', "[1, 2]",
                                 '{"bench": "b", "commit": "c", "date": "yesterday", '
                                 '"machine": {}, "command": "x", "rows": []}'])
def test_a_malformed_line_is_refused_naming_its_line(tmp_path, bad):
    path = rec(tmp_path)
    record.append("bench_x.py", [record.row("w", 1.0)], path, now=D1)
    path.write_text(path.read_text() + bad + "\n" + path.read_text())
    with pytest.raises(record.RecordError, match=re.escape(f"{path}:2: not a complete")):
        record.load(path)


def test_an_entry_without_rows_or_with_a_workload_twice_is_refused(tmp_path):
    with pytest.raises(ValueError, match="twice"):
        record.append("bench_x.py", [record.row("w", 1.0), record.row("w", 2.0)],
                      rec(tmp_path), now=D1)
    with pytest.raises(ValueError, match="no rows"):
        record.append("bench_x.py", [], rec(tmp_path), now=D1)
    assert not rec(tmp_path).exists()


def test_check_writes_nothing_and_fails_on_a_stale_page(tmp_path, capsys):
    path = rec(tmp_path)
    record.append("bench_x.py", [record.row("w", 1.0, "P", 2.0)], path, now=D1)
    assert report.main(["--check"], root=tmp_path) == 1  # no page yet
    assert not (tmp_path / report.DOC).exists()
    assert report.main([], root=tmp_path) == 0
    assert report.main(["--check"], root=tmp_path) == 0
    record.append("bench_x.py", [record.row("w", 1.5, "P", 2.0)], path, now=D2)
    page = (tmp_path / report.DOC).read_text()
    capsys.readouterr()
    assert report.main(["--check"], root=tmp_path) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "docs/benchmarks.md" in err
    assert (tmp_path / report.DOC).read_text() == page


def test_an_empty_record_gives_a_page_without_figures(tmp_path):
    rec(tmp_path).write_text("")
    doc = report.outputs(tmp_path)[report.DOC]
    assert "No figures are recorded yet" in doc
    assert "\n## " not in doc and "\n| " not in doc


def test_readme_table_goes_between_the_markers_only(tmp_path, capsys):
    record.append("bench_x.py", [record.row("w", 1.0, "P", 2.0)], rec(tmp_path), now=D1)
    readme = tmp_path / "README.md"
    readme.write_text("# Title\n\nNo markers here.\n")
    assert report.main([], root=tmp_path) == 0
    assert readme.read_text() == "# Title\n\nNo markers here.\n"
    head, tail = "# Title\n\nFigures:\n\n", "\nMore text.\n"
    readme.write_text(f"{head}{report.START}\nhand-written\n{report.END}{tail}")
    assert report.main([], root=tmp_path) == 0
    text = readme.read_text()
    assert text.startswith(head + report.START + "\n") and text.endswith(report.END + tail)
    assert "hand-written" not in text
    assert "| workload | blobtree | peer | ratio | machine | commit |" in text
    assert "| w | 1 s | P: 2 s | 0.5 |" in text
    assert report.main(["--check"], root=tmp_path) == 0
    readme.write_text(text.replace("| 0.5 |", "| 0.4 |"))
    capsys.readouterr()
    assert report.main(["--check"], root=tmp_path) == 1
    assert "README.md" in capsys.readouterr().err
    readme.write_text(f"{report.END}\n{report.START}\n")
    with pytest.raises(report.MarkerError):
        report.outputs(tmp_path)


def git(root: Path, *args: str) -> None:
    """Run git in ``root`` quietly."""
    subprocess.run(["git", "-C", str(root), "-c", "user.name=t", "-c", "user.email=t@t", *args],
                   check=True, capture_output=True)


def test_commit_is_dirty_only_for_tracked_changes_under_blobtree_or_bench(tmp_path):
    for name in ("blobtree/a.py", "bench/results.jsonl", "docs/x.md"):
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_text("x\n")
    git(tmp_path, "init", "-q")
    git(tmp_path, "add", ".")
    git(tmp_path, "commit", "-qm", "start")
    head = record.commit(tmp_path)
    assert re.fullmatch(r"[0-9a-f]{4,40}", head)
    (tmp_path / "bench" / "new.py").write_text("x\n")  # untracked
    (tmp_path / "bench" / "results.jsonl").write_text("y\n")  # the record itself
    (tmp_path / "docs" / "x.md").write_text("y\n")  # outside blobtree/ and bench/
    assert record.commit(tmp_path) == head
    (tmp_path / "blobtree" / "a.py").write_text("y\n")
    assert record.commit(tmp_path) == head + "-dirty"


def test_command_line_is_relative_to_the_repository():
    argv = [str(ROOT / "bench" / "bench_render.py"), "--sizes", "64", "--out", "a b"]
    assert record.command_line(argv) == "python bench/bench_render.py --sizes 64 --out 'a b'"


def test_record_options(tmp_path):
    ap = argparse.ArgumentParser()
    record.add_arguments(ap)
    assert record.target(ap.parse_args([])) is None
    assert record.target(ap.parse_args(["--record"])) == record.RECORD
    other = tmp_path / "r.jsonl"
    assert record.target(ap.parse_args(["--record-file", str(other)])) == other
    other.write_text("{")  # a malformed record fails before the bench runs
    with pytest.raises(record.RecordError, match="r.jsonl:1"):
        record.target(ap.parse_args(["--record-file", str(other)]))
