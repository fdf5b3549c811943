"""The package's layers: imports flow one way (docs/architecture.md), with no cycles at all,
imports inside functions included."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "blobtree"

#: Layers from the bottom up; a module may import its own layer and those below.
LAYERS = [
    {"runtime", "output", "checks"},
    {"geometry", "fields", "helico", "texture", "nodes"},
    {"io", "models"},
    {"engine"},
    {"render", "mesh", "film"},
    {"distributed"},
    {"api", "live"},
    {"cli"},
]


_API = next(i for i, layer in enumerate(LAYERS) if "api" in layer)


def _module(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imports() -> dict[str, set[str]]:
    """Module -> the package modules it imports (anywhere in its code)."""
    out: dict[str, set[str]] = {}
    for path in PACKAGE.rglob("*.py"):
        name = _module(path)
        package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
        found: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                found |= {a.name for a in node.names if a.name.startswith("blobtree")}
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")
                    base = base[:len(base) - (node.level - 1)]
                    mod = ".".join(base + ([node.module] if node.module else []))
                else:
                    mod = node.module or ""
                if not mod.startswith("blobtree"):
                    continue
                # "from . import x" imports the submodule x when x is one
                for a in node.names:
                    sub = f"{mod}.{a.name}"
                    if (PACKAGE.parent / sub.replace(".", "/")).with_suffix(".py").exists() or \
                            (PACKAGE.parent / sub.replace(".", "/") / "__init__.py").exists():
                        found.add(sub)
                    else:
                        found.add(mod)
        out[name] = found - {name}
    return out


def _layer(module: str) -> int:
    parts = module.split(".")
    if len(parts) == 1:
        return _API  # the package itself is the public API
    for i, layer in enumerate(LAYERS):
        if parts[1] in layer:
            return i
    raise AssertionError(f"{module} is in no layer: add it to LAYERS")


def test_no_module_is_in_an_import_cycle():
    graph = _imports()
    # a package's __init__ is reached by importing any module below it; the root's __init__
    # (the public API) imports everything, so only edges to it are cycles we forbid below
    seen: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> None:
        seen[m] = 1
        stack.append(m)
        for n in sorted(graph.get(m, ())):
            if n == "blobtree":
                continue
            if seen.get(n) == 1:
                cycle = stack[stack.index(n):] + [n]
                pytest.fail("import cycle: " + " -> ".join(cycle))
            if n not in seen:
                visit(n)
        stack.pop()
        seen[m] = 2

    for m in sorted(graph):
        if m not in seen:
            visit(m)


def test_imports_flow_down_the_layers():
    graph = _imports()
    wrong = []
    for m, targets in graph.items():
        lm = _layer(m)
        for t in targets:
            lt = _layer(t)
            if lt > lm:
                wrong.append(f"{m} imports {t}")
    assert not wrong, "imports against the layers:\n" + "\n".join(sorted(wrong))


def test_the_model_does_not_need_the_engine():
    """The model's modules import nothing from the engine, the renderer or the mesher."""
    graph = _imports()
    model = [m for m in graph if _layer(m) <= 2]
    assert model and not [(m, t) for m in model for t in graph[m] if _layer(t) >= 3]
