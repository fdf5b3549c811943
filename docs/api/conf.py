"""Sphinx configuration of blobtree's API reference: every public name of ``blobtree`` and
``blobtree.models`` (their ``__all__``), from the docstrings.  Built with the tests
(tests/test_api_reference.py): a broken cross-reference or a public name without a docstring
fails the build.

``.. public-names:: PACKAGE`` in a page stands for one autodoc entry per name of the package's
``__all__``: classes and functions under their public path (``blobtree.Point``), data where it is
defined (its ``#:`` comment is its docstring there), modules by their docstring."""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from sphinx.pycode import ModuleAnalyzer  # noqa: E402
from sphinx.util import logging  # noqa: E402

import blobtree  # noqa: E402

log = logging.getLogger(__name__)

project = "blobtree"
release = version = blobtree.__version__
extensions = ["sphinx.ext.autodoc"]
exclude_patterns = ["_build"]
html_theme = "alabaster"

autodoc_default_options = {"members": True, "undoc-members": True}
autodoc_member_order = "bysource"
autodoc_typehints = "none"
nitpicky = True  # every cross-reference must resolve
# Names of other projects (no intersphinx: the reference is built offline).
nitpick_ignore_regex = [(r"py:.*", r"(np|numpy|numba|trimesh|PIL|distributed|click)\..*")]


def _home(name: str, value: object) -> str:
    """The module of the package that defines the data ``name`` with a ``#:`` comment."""
    for info in pkgutil.walk_packages(blobtree.__path__, "blobtree."):
        module = importlib.import_module(info.name)
        if getattr(module, name, None) is value and \
                ("", name) in ModuleAnalyzer.for_module(info.name).find_attr_docs():
            return f"{info.name}.{name}"
    log.warning(f"{name}: no module of blobtree documents it with a #: comment")
    return ""


def _entries(package: str) -> list[str]:
    """autodoc directives for every name of ``package.__all__``."""
    module = importlib.import_module(package)
    out = []
    for name in module.__all__:
        value = getattr(module, name)
        if inspect.ismodule(value):
            out.append(f".. automodule:: {value.__name__}\n   :no-members:\n   :no-index:")
        elif inspect.isclass(value):
            out.append(f".. autoclass:: {package}.{name}")
        elif callable(value):
            out.append(f".. autofunction:: {package}.{name}")
        else:
            home = _home(name, value)
            if home:
                out.append(f".. autodata:: {home}")
    return out


def _expand(app, docname: str, source: list[str]) -> None:
    lines = []
    for line in source[0].splitlines():
        if line.startswith(".. public-names:: "):
            lines.extend(e + "\n" for e in _entries(line.split("::", 1)[1].strip()))
        else:
            lines.append(line)
    source[0] = "\n".join(lines) + "\n"


def _require_docstring(app, what, name, obj, options, lines) -> None:
    """A public name without a docstring is an error."""
    if not any(line.strip() for line in lines) and not name.rsplit(".", 1)[-1].startswith("_"):
        log.warning(f"{name} ({what}) has no docstring")


def setup(app) -> None:
    """Expand ``public-names`` and refuse undocumented public names."""
    app.connect("source-read", _expand)
    app.connect("autodoc-process-docstring", _require_docstring)
