"""The command line's contract for a user's mistakes: one line, a non-zero exit code, never a
traceback; Ctrl-C stops any command (exit code 130) and writes nothing."""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import os
import signal
import sys
import time

import pytest
from click.testing import CliRunner

import blobtree as bt
from blobtree.cli.main import main
from blobtree.mesh.export import import_trimesh


@pytest.fixture
def scene(tmp_path):
    path = tmp_path / "s.json"
    bt.save(bt.Point(radius=1.0), path)
    (tmp_path / "afile").write_text("not a directory")
    return path


@pytest.mark.parametrize("args, words", [
    (["render", "{scene}", "-o", "{tmp}/afile/x.png"], "which is not a directory"),
    (["render", "{scene}", "-o", "{tmp}"], "is a directory"),
    (["render", "{scene}", "-o", "{tmp}/missing/x.png"], "which does not exist"),
    (["mesh", "{scene}", "-o", "{tmp}/missing/x.ply"], "which does not exist"),
    (["mesh", "{scene}", "-o", "{tmp}/afile/x.ply"], "which is not a directory"),
    (["mesh", "{scene}", "-o", "{tmp}/x.xyz"], "extension"),
    (["mesh", "{scene}", "-o", "{tmp}/x.ply", "-r", "3"], "the mesh has no triangles"),
    (["mesh", "{scene}", "-o", "{tmp}/x.ply", "-r", "100000"], "too large"),
    (["render", "{scene}", "--size", "5x0"], "width and height must be in [1, 16384]"),
    (["render", "{scene}", "--size", "99999x5"], "width and height must be in [1, 16384]"),
    (["render", "{tmp}/nested.json"], "nested too deeply"),
    (["render", "{tmp}/bigint.json"], "4300"),
    (["info", "{tmp}/afile"], "not valid JSON"),
    (["render", "{tmp}/nan.json"], "$.nodes[0].params.radius: NaN"),
])
def test_mistakes_are_one_line_errors(scene, tmp_path, args, words):
    (tmp_path / "nested.json").write_text("[" * 50_000 + "]" * 50_000)
    (tmp_path / "bigint.json").write_text('{"version": ' + "9" * 5000 + "}")
    (tmp_path / "nan.json").write_text(scene.read_text().replace('"radius":1.0', '"radius":NaN'))
    args = [a.format(scene=scene, tmp=tmp_path) for a in args]
    r = CliRunner().invoke(main, args)
    assert r.exit_code in (1, 2), r.output
    assert words in r.output, r.output
    assert "Traceback" not in r.output and not isinstance(r.exception, ValueError | OSError)
    assert [line for line in r.output.splitlines() if line.startswith("Error")] == [
        next(line for line in r.output.splitlines() if words in line)]
    assert not any(p.suffix in (".png", ".ply") for p in tmp_path.rglob("*"))


def test_ctrl_c_stops_mesh_and_writes_nothing(scene, tmp_path, monkeypatch):
    out = tmp_path / "m.ply"
    out.write_text("the user's previous mesh")
    mesh_module = sys.modules["blobtree.cli.mesh_cmd"]

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(mesh_module, "polygonize", interrupted)
    r = CliRunner().invoke(main, ["mesh", str(scene), "-o", str(out), "-r", "8"])
    assert r.exit_code == 130 and "interrupted; nothing written" in r.output
    assert out.read_text() == "the user's previous mesh"


class _SwallowingImport(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """A stand-in for trimesh's import, which catches BaseException around optional imports:
    Ctrl-C arrives while it runs and is swallowed there unless held back."""

    def find_spec(self, name, path, target=None):
        return importlib.machinery.ModuleSpec(name, self) if name == "trimesh" else None

    def create_module(self, spec):
        return None

    def exec_module(self, module):
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.2)
        except BaseException:
            pass


def test_ctrl_c_during_the_trimesh_import_is_not_lost(monkeypatch):
    import trimesh  # noqa: F401  (imported once, so that the test can take it away again)

    monkeypatch.delitem(sys.modules, "trimesh")
    monkeypatch.setattr(sys, "meta_path", [_SwallowingImport(), *sys.meta_path])
    # Python's own handler, as in a terminal: a shell starts background jobs with SIGINT ignored
    outer = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            import_trimesh()
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, outer)
