"""The API reference (docs/api, Sphinx autodoc): it builds from the docstrings with no warning,
holds every public name of ``blobtree`` and ``blobtree.models``, and its build fails on a broken
cross-reference or an undocumented public name."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import blobtree as bt

DOCS = Path(__file__).resolve().parents[1] / "docs" / "api"


def build(source: Path, out: Path, pythonpath: Path | None = None) -> subprocess.CompletedProcess:
    """sphinx-build with warnings as errors, from scratch."""
    env = None
    if pythonpath is not None:
        import os
        env = {**os.environ, "PYTHONPATH": str(pythonpath)}
    return subprocess.run([sys.executable, "-m", "sphinx", "-E", "-q", "-W", "--keep-going",
                           "-b", "html", str(source), str(out)],
                          capture_output=True, text=True, env=env, timeout=300)


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> str:
    out = tmp_path_factory.mktemp("api")
    result = build(DOCS, out)
    assert result.returncode == 0, result.stderr
    return (out / "index.html").read_text()


def test_the_reference_builds_without_a_warning(built):
    assert "blobtree API reference" in built


@pytest.mark.parametrize("package", [bt, bt.models])
def test_every_public_name_is_in_the_reference(built, package):
    missing = [name for name in package.__all__
               if f"{name}</span>" not in built and f".{name}\"" not in built]
    assert not missing


def _copy_with_page(tmp_path: Path, page: str) -> Path:
    source = tmp_path / "src"
    shutil.copytree(DOCS, source)
    (source / "index.rst").write_text((source / "index.rst").read_text() + "\n" + page)
    return source


def test_a_broken_reference_fails_the_build(tmp_path):
    source = _copy_with_page(tmp_path, "See :func:`blobtree.no_such_function`.\n")
    result = build(source, tmp_path / "out")
    assert result.returncode != 0 and "no_such_function" in result.stderr


def test_an_undocumented_public_name_fails_the_build(tmp_path):
    (tmp_path / "bare.py").write_text("def shown(x):\n    return x\n")
    source = _copy_with_page(tmp_path, ".. autofunction:: bare.shown\n")
    result = build(source, tmp_path / "out", pythonpath=tmp_path)
    assert result.returncode != 0 and "bare.shown (function) has no docstring" in result.stderr
