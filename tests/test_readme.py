"""The README as a new user meets it: its example runs as written, its command lines name real
commands and options, and it stays short."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from blobtree.cli.main import main

README = (Path(__file__).resolve().parents[1] / "README.md").read_text()


def blocks(language: str) -> list[str]:
    """The README's fenced blocks opened with ```language."""
    found: list[str] = []
    current: list[str] | None = None
    skipping = False
    for line in README.splitlines():
        if line.startswith("```"):
            if current is None and not skipping:
                if line[3:].strip() == language:
                    current = []
                else:
                    skipping = True
            else:
                if current is not None:
                    found.append("\n".join(current) + "\n")
                current, skipping = None, False
        elif current is not None:
            current.append(line)
    return found


@pytest.mark.slow
def test_the_example_runs_as_written(tmp_path):
    (code,) = blocks("python")
    result = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                            text=True, timeout=1200)
    assert result.returncode == 0, result.stderr[-3000:]
    assert {"shell.png", "shell.ply", "shell.json"} <= {p.name for p in tmp_path.iterdir()}


def test_every_command_line_option_exists():
    """Each `blobtree COMMAND ... --option` of the README is accepted by that command."""
    lines = [line for block in blocks("") + blocks("bash") for line in block.splitlines()]
    seen = 0
    for line in lines:
        words = line.split("#")[0].split()
        if len(words) < 2 or words[0] != "blobtree":
            continue
        help_text = CliRunner().invoke(main, [words[1], "--help"]).output
        assert "Usage:" in help_text, f"no command {words[1]!r}"
        for option in re.findall(r"--[a-z][a-z-]*", " ".join(words[2:])):
            assert option in help_text, f"blobtree {words[1]} has no {option}"
        seen += 1
    assert seen >= 8


def test_the_readme_is_at_most_1500_words():
    assert len(README.split()) <= 1500
