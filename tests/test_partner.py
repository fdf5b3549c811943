"""A first run's compiling shared with a partner process (``runtime.partner``): what the partner
compiles is loaded, not compiled, by the process waiting for it, its kernels behave as the ones
compiled in one process, and a partner that fails or dies costs only time."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from blobtree.runtime import partner

ROOT = Path(__file__).resolve().parents[1]
#: The Lipschitz walk, as the compile listener names it.
WALK = "blobtree.engine.walk.walk_lipschitz"

#: Runs in a fresh process (its argv[1]: the partner's units, or "" for none); prints the
#: functions this process compiled and a few field and bound values.
_SCRIPT = """
import json, sys
import numpy as np
from numba.core import event
from blobtree import Point, Blend, Cylinder
from blobtree.engine import bounds
from blobtree.runtime import partner
from compiled import Compiled

count = Compiled()
event.register("numba:compile", count)
key = bounds.lipschitz_walk.symbol
units = json.loads(sys.argv[1])
if units:
    proc = partner.start(units)
    if sys.argv[2] == "kill":
        proc.kill()
    partner.wait(key)
loaded = bounds.lipschitz_walk.ensure(compile=False)
prog = Blend(Point().translate(0.3, 0, 0), Cylinder(a=(0, -1, 0), b=(0, 1, 0))).program()
lo = np.array([[-1.0, -1.0, -1.0], [0.2, 0.0, -0.3]])
hi = lo + 0.5
print(json.dumps({"loaded": loaded, "compiled": count.names,
                  "bounds": prog.lipschitz(lo, hi).tolist(),
                  "field": prog.field(lo).tolist()}))
"""


def _run(tmp_path: Path, cache: str, units: dict[str, str], how: str = "",
         threads: int = 2) -> dict:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / cache),
           "PYTHONPATH": f"{ROOT}{os.pathsep}{ROOT / 'tests'}", "NUMBA_NUM_THREADS": str(threads)}
    run = subprocess.run([sys.executable, "-c", _SCRIPT, json.dumps(units), how],
                         capture_output=True, text=True, env=env, cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-2000:]
    return json.loads(run.stdout.splitlines()[-1])


def _lipschitz_unit() -> dict[str, str]:
    from blobtree.engine import bounds

    return {bounds.lipschitz_walk.symbol: f"{bounds.__name__}:lipschitz_walk"}


@pytest.mark.slow
def test_a_partners_walk_is_loaded_not_compiled_and_bounds_the_same(tmp_path):
    shared = _run(tmp_path, "shared", _lipschitz_unit())
    alone = _run(tmp_path, "alone", {}, threads=1)
    assert shared["loaded"] and not alone["loaded"]  # the partner left it in the cache
    assert WALK not in shared["compiled"]
    assert WALK in alone["compiled"]  # (the listener sees the walk compiled)
    assert shared["bounds"] == alone["bounds"] and shared["field"] == alone["field"]


@pytest.mark.slow
def test_a_killed_partner_costs_only_time(tmp_path):
    killed = _run(tmp_path, "killed", _lipschitz_unit(), "kill")
    alone = _run(tmp_path, "alone", {}, threads=1)
    assert WALK in killed["compiled"]  # compiled here instead
    assert killed["bounds"] == alone["bounds"] and killed["field"] == alone["field"]


@pytest.mark.slow
def test_a_render_and_a_mesh_shared_with_a_partner_are_the_same(tmp_path):
    """The tracer and the contouring compiled by the partner (around placeholders for the
    walks this process compiles): loaded here, they call the real walks; the picture and the
    mesh are those of one process alone, and the cache left is complete."""

    def run(cache: str, threads: int, *args: str) -> bytes:
        env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / cache),
               "PYTHONPATH": str(ROOT), "NUMBA_NUM_THREADS": str(threads)}
        name = f"{cache}-{len(list(tmp_path.iterdir()))}.{'ply' if args[0] == 'mesh' else 'png'}"
        done = subprocess.run([sys.executable, "-m", "blobtree.cli.main", *args, "-o", name],
                              capture_output=True, text=True, env=env, cwd=tmp_path)
        assert done.returncode == 0, done.stderr[-2000:]
        return (tmp_path / name).read_bytes()

    render = ("render", "whorl126", "--size", "40x32")
    mesh = ("mesh", "whorl126", "--resolution", "24")
    shared = run("shared", 2, *render), run("shared", 2, *mesh)
    assert shared == (run("alone", 1, *render), run("alone", 1, *mesh))
    assert (run("shared", 2, *render), run("shared", 2, *mesh)) == shared  # from the cache


def test_unknown_units_and_keys_release_at_once(tmp_path, monkeypatch):
    """A unit the partner cannot find is reported failed (the waiting process goes on to
    compile it), and a key no partner owns is not waited for."""
    partner.wait("no such unit")
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    proc = partner.start({"a": "blobtree.runtime.partner:no_such_name",
                          "b": "no.such.module:x"})
    if proc is None:
        pytest.skip("kernels run on one thread here: no partner is started")
    partner.wait("a")
    partner.wait("b")
    assert proc.wait(timeout=60) == 0


def test_no_partner_on_one_thread(monkeypatch):
    monkeypatch.setattr(partner, "threads", lambda: 1)
    assert partner.start({"a": "blobtree.runtime.partner:no_such_name"}) is None
