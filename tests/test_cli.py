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


def test_command_line_skips_numbas_blas_probe_but_keeps_scipy_importable(tmp_path):
    """numba's CPU target imports scipy.linalg only to probe for BLAS; the blobtree command
    starts it with scipy.linalg hidden (0.2 s saved per command), and scipy.linalg stays
    importable."""
    fake = tmp_path / "scipy"
    (fake / "linalg").mkdir(parents=True)
    (fake / "__init__.py").write_text('__version__ = "1.17.0"\n')
    (fake / "linalg" / "__init__.py").write_text("LOADED = True\n")
    (fake / "linalg" / "cython_blas.py").write_text("")
    script = ("import sys\n"
              "from blobtree.cli.main import run\n"
              "assert 'numba.np.arraymath' not in sys.modules  # importing changes nothing\n"
              "sys.argv = ['blobtree', '--version']\n"
              "try:\n"
              "    run()\n"
              "except SystemExit:\n"
              "    pass\n"
              "import numba.np.arraymath as am\n"
              "assert 'scipy.linalg' not in sys.modules and not am._HAVE_BLAS\n"
              "import scipy.linalg\n"
              "print(scipy.linalg.LOADED, scipy.linalg.__file__)\n")
    root = Path(__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), str(root)])}
    out = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines()[-1].startswith("True " + str(fake / "linalg"))
