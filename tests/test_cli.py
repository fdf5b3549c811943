"""The command line: --version, info, errors."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

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


def test_a_cached_command_loads_its_kernels_without_numbas_registries(tmp_path):
    """Loading kernels from numba's cache skips numba's registry refresh (jit._QuickCache), which
    imports its array maths and probes SciPy for BLAS (0.25-0.5 s of every command): only
    compiling needs it.  Run here first (compiling the kernels into the cache if need be), the
    command then runs in a new process without starting the registries, and draws the same
    picture.  Its kernels' caches are made only for the few it loads by name
    (jit._LazyCache: making one probes the cache directory)."""
    out_png = [tmp_path / "a.png", tmp_path / "b.png"]
    args = ["render", "whorl126", "--size", "16x16", "--quiet", "-o"]
    r = CliRunner().invoke(main, [*args, str(out_png[0])])
    assert r.exit_code == 0, r.output
    script = ("import gc, sys\n"
              "from blobtree.cli.main import run\n"
              "from blobtree.runtime.jit import _LazyCache\n"
              "caches = [o for o in gc.get_objects() if isinstance(o, _LazyCache)]\n"
              "def made():\n"
              "    return sum(c._real is not None for c in caches), len(caches)\n"
              "print(*made())\n"
              f"sys.argv = ['blobtree', *{args!r}, {str(out_png[1])!r}]\n"
              "try:\n"
              "    run()\n"
              "except SystemExit as e:\n"
              "    assert not e.code, e.code\n"
              "print(*made())\n"
              "print('numba.np.arraymath' in sys.modules, 'scipy.linalg' in sys.modules)\n")
    root = Path(__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": str(root)}
    out = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    before, after, registries = out.stdout.splitlines()
    made_at_import, kernels = map(int, before.split())
    made_by_render = int(after.split()[0])
    assert made_at_import == 0 and kernels > 100
    assert 0 < made_by_render < kernels / 4
    assert registries.split() == ["False", "False"]
    assert out_png[0].read_bytes() == out_png[1].read_bytes()
