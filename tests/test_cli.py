"""The command line: --version, info, errors."""

from __future__ import annotations

from click.testing import CliRunner

import blobtree as bt
from blobtree.cli.main import main


def test_version():
    r = CliRunner().invoke(main, ["--version"])
    assert r.exit_code == 0 and bt.__version__ in r.output


def test_info_builtin_and_file(tmp_path):
    r = CliRunner().invoke(main, ["info", "whorl126"])
    assert r.exit_code == 0, r.output
    assert "point                  126" in r.output
    assert "program:" in r.output
    path = tmp_path / "s.json"
    bt.save(bt.Point(radius=1.0) + bt.Point(radius=1.0, center=(1, 0, 0)), path)
    r = CliRunner().invoke(main, ["info", str(path)])
    assert r.exit_code == 0 and "point" in r.output and "blend" in r.output


def test_info_unknown_scene_is_a_clear_error(tmp_path):
    r = CliRunner().invoke(main, ["info", "no-such-model"])
    assert r.exit_code != 0 and "whorl126" in r.output
    bad = tmp_path / "bad.json"
    bad.write_text('{"format": "blobtree-scene", "version": 1, "root": {"type": "x"}}')
    r = CliRunner().invoke(main, ["info", str(bad)])
    assert r.exit_code != 0 and "$.root.type" in r.output
