"""SCENE arguments: a JSON scene file or the name of a built-in model."""

from __future__ import annotations

from collections.abc import Callable
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
    **{f"figure{key}": fig.build for key, fig in models.FIGURES.items()},
}


#: Built-in models seen best from a figure's viewpoint (the shell's apex is at -y, see murex.py).
VIEWS = {"murex": models.FIGURES["14"], **{f"figure{k}": f for k, f in models.FIGURES.items()}}


def scene_camera(name: str, prog, width: int, height: int) -> Camera | None:
    """The camera a built-in model is best seen from (its figure's view, framed), or None."""
    fig = VIEWS.get(name)
    if fig is None:
        return None
    return framed_camera(prog, width, height, view=fig.view, up=fig.up, fov=fig.fov)


def resolve_scene(name: str) -> Node:
    """Load ``name`` as a scene file if it is one, else build the built-in model of that name."""
    if name in BUILTIN:
        return BUILTIN[name]()
    path = Path(name)
    if path.suffix.lower() == ".json" or path.exists():
        if not path.is_file():
            raise click.BadParameter(f"no such scene file: {name}", param_hint="SCENE")
        try:
            return load(path)
        except SceneError as e:
            raise click.BadParameter(f"{name}: {e}", param_hint="SCENE") from None
    raise click.BadParameter(
        f"{name!r} is neither a scene file nor a built-in model "
        f"({', '.join(sorted(BUILTIN))})", param_hint="SCENE")
