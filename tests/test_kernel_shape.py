"""The shape of the compiled code: few arguments per kernel, one program walk, modes that refuse
what they do not handle."""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import pytest
from numba.core.registry import CPUDispatcher

import blobtree
from blobtree.engine import walk as W
from blobtree.engine.point import POINT_MODE
from blobtree.runtime.linked import LINKED, Linked

#: The packages whose kernels take a program, a region, a camera travel or a vector as bundled
#: values.
PACKAGES = ("engine", "nodes", "texture", "render", "mesh", "runtime")
MAX_PARAMETERS = 12


def _kernels():
    for pkg in PACKAGES:
        base = importlib.import_module(f"blobtree.{pkg}")
        names = [f"blobtree.{pkg}"] + [f"blobtree.{pkg}.{m.name}"
                                        for m in pkgutil.iter_modules(base.__path__)]
        for name in names:
            module = importlib.import_module(name)
            for attr, obj in vars(module).items():
                fn = getattr(obj, "py_func", None)
                if isinstance(obj, CPUDispatcher | Linked) and fn is not None:
                    yield f"{name}.{attr}", fn


def test_no_kernel_takes_more_than_twelve_parameters():
    kernels = dict(_kernels())
    assert len(kernels) > 80  # the walk over the packages found them
    wide = {name: len(inspect.signature(fn).parameters) for name, fn in kernels.items()
            if len(inspect.signature(fn).parameters) > MAX_PARAMETERS}
    assert wide == {}


def test_the_walks_are_one_function():
    """Every linked walk is the one template's code, with its mode's hooks."""
    walks = [k for k in LINKED if k.py_func.__name__.startswith("walk_")]
    assert {k.py_func.__name__ for k in walks} >= {"walk_point", "walk_lipschitz",
                                                  "walk_bounded", "walk_rows", "walk_lanes"}
    codes = {k.py_func.__code__.co_code for k in walks}
    assert len(codes) == 1


def test_a_mode_without_a_hook_is_refused():
    broken = W.Mode(**{**POINT_MODE.__dict__, "paint": None})
    with pytest.raises(ValueError, match="lacks the hooks \\['paint'\\]"):
        W.walk(broken)


def test_an_unknown_instruction_kind_is_refused(monkeypatch):
    monkeypatch.setattr(W, "WALKED", W.WALKED - {W.K_ZERO})
    with pytest.raises(ValueError, match="does not run instruction kinds"):
        W.walk(POINT_MODE)


def test_a_walk_called_with_the_wrong_types_names_the_argument():
    import numba
    import numpy as np

    from blobtree.engine.point import eval_point

    @numba.njit
    def wrong(prog, vs):
        return eval_point(prog, (0.0, 0.0, 0.0, 0), (vs, vs))

    prog = blobtree.Point().program()
    with pytest.raises(Exception, match="argument 0"):
        wrong(prog.arrays[:3], np.zeros((4, 9)))
