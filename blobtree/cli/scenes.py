"""SCENE arguments: a JSON scene file, a TOML shell spec or the name of a built-in model."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path

import click

from .. import models
from ..io import SceneError, load
from ..nodes import Node
from ..render.camera import Camera, framed_camera

#: Built-in models by name: each a function of no arguments returning a tree.
BUILTIN: dict[str, Callable[[], Node]] = {
    "whorl126": models.whorl126,
    "murex": models.murex,
    **{name: partial(models.shell, name) for name in models.SHELLS if name != "murex"},
    **{f"figure{key}": fig.build for key, fig in models.FIGURES.items()},
}


#: Built-in models seen best from a figure's viewpoint (the shell's apex is at -y, see murex.py).
VIEWS = {"murex": models.FIGURES["14"], **{f"figure{k}": f for k, f in models.FIGURES.items()}}


def scene_view(name: str, tree: Node) -> tuple[tuple, tuple, float] | None:
    """(up, view, fov) a scene is best seen from: its figure's, or the view the tree carries
    (``Node.shown``, as shells do), or None."""
    fig = VIEWS.get(name)
    if fig is not None:
        return fig.up, fig.view, fig.fov
    up, view = tree.display
    return None if view is None else (up, view, 30.0)


def scene_up(name: str, tree: Node) -> tuple[float, float, float]:
    """The direction a scene is up: its figure's, else the tree's own (``Node.shown``: a shell's
    apex), else +y."""
    fig = VIEWS.get(name)
    return fig.up if fig is not None else tree.display[0]


def scene_camera(name: str, tree: Node, prog, width: int, height: int) -> Camera | None:
    """The camera a scene is best seen from (see :func:`scene_view`), framed, or None."""
    seen = scene_view(name, tree)
    if seen is None:
        return None
    up, view, fov = seen
    return framed_camera(prog, width, height, view=view, up=up, fov=fov)


def scene_spec(name: str) -> models.ShellSpec:
    """The shell spec SCENE names: a shipped species or a .toml spec file (what ``grow``
    films); a usage error naming SCENE otherwise."""
    if name in models.SHELLS:
        return models.SHELLS[name]
    if Path(name).suffix.lower() == ".toml":
        try:
            return models.load_spec(name)
        except ValueError as e:
            raise click.BadParameter(str(e), param_hint="SCENE") from None
    raise click.BadParameter(f"{name!r} is not a shell: a shipped species "
                             f"({', '.join(sorted(models.SHELLS))}) or a .toml spec file",
                             param_hint="SCENE")


def resolve_scene(name: str) -> Node:
    """Load ``name`` as a scene file if it is one, else build the built-in model of that name."""
    if name in BUILTIN:
        return BUILTIN[name]()
    path = Path(name)
    if path.suffix.lower() == ".toml":
        if not path.is_file():
            raise click.BadParameter(f"no such shell spec: {name}", param_hint="SCENE")
        try:
            return models.shell(models.load_spec(path))
        except ValueError as e:
            raise click.BadParameter(str(e), param_hint="SCENE") from None
    if path.suffix.lower() == ".json" or path.exists():
        if not path.is_file():
            raise click.BadParameter(f"no such scene file: {name}", param_hint="SCENE")
        try:
            return load(path)
        except SceneError as e:
            raise click.BadParameter(f"{name}: {e}", param_hint="SCENE") from None
    raise click.BadParameter(
        f"{name!r} is neither a scene file (.json), a shell spec (.toml) nor a built-in model "
        f"({', '.join(sorted(BUILTIN))})", param_hint="SCENE")
