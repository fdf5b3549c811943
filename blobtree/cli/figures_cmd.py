"""``blobtree figures``: every figure of the paper that shows a model, as PNGs."""

from __future__ import annotations

import inspect
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click

from ..models.figures import BEYOND, FIGURES, TEXTURE_FIGURES, GridFigure, TextureFigure
from ..render import LOOKS, render, save_image, warming
from ..render.camera import framed_camera
from ..render.image import labelled_grid
from . import compile_notice

#: The paper's figures by number, then those beyond the paper by name.
ALL = [*sorted([*FIGURES, *TEXTURE_FIGURES], key=int), *BEYOND]


def _seeded(make: Callable[..., Any], seed: int) -> Any:
    """``make(seed)`` where the figure's model draws random numbers (bumps, canal spine bends,
    textures: its builder takes a seed), else ``make()``."""
    return make(seed) if "seed" in inspect.signature(make).parameters else make()


@click.command()
@click.option("-o", "--out", "out_dir", required=True,
              type=click.Path(file_okay=False, path_type=Path),
              help="Directory for figure-N.png (created if missing).")
@click.option("--height", default=480, show_default=True, type=click.IntRange(16, 8192),
              help="Image height in pixels; the width follows each figure's shape.")
@click.option("--samples", default=2, show_default=True, type=click.IntRange(1, 64),
              help="Anti-aliasing samples per pixel.")
@click.option("--shadows/--no-shadows", default=True, show_default=True)
@click.option("--look", type=click.Choice(sorted(LOOKS)), default="studio", show_default=True,
              help="paper: the plain white style of the paper's own figures.")
@click.option("--only", multiple=True, type=click.Choice(ALL),
              help="Only these figure numbers (repeatable).")
@click.option("--seed", default=0, show_default=True, help="Seed of the shell's randomness.")
def figures(out_dir: Path, height: int, samples: int, shadows: bool, look: str,
            only: tuple[str, ...], seed: int) -> None:
    """Render the paper's figures (3-11 and 14 ray traced; 12, the textures, drawn) and those
    beyond it (species, grown spines, varices down the canal, Eq. 15's two forms, joins, group
    blends, Raup's cube, pigment patterns)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    figures = {**FIGURES, **TEXTURE_FIGURES, **BEYOND}
    traced = any(not isinstance(figures[key], TextureFigure) for key in only or ALL)
    # (the tracer loads, or on a first run compiles, while the first figure's tree is built)
    with compile_notice(), warming(traced):
        for key in only or ALL:
            _figure(key, figures[key], out_dir, height, samples, shadows, look, seed)


def _figure(key: str, fig: Any, out_dir: Path, height: int, samples: int, shadows: bool,
            look: str, seed: int) -> None:
    """Draw one figure into ``out_dir``."""
    start = time.perf_counter()
    path = out_dir / f"figure-{key}.png"
    if isinstance(fig, TextureFigure):
        save_image(_seeded(fig.draw, seed), path)
    elif isinstance(fig, GridFigure):
        cells = fig.cells()
        side = max(16, height // len(cells))
        images = [[render(tree, side, side, camera=framed_camera(
            tree.program(), side, side, view=fig.view, up=fig.up, fov=fig.fov),
            samples=samples, shadows=shadows, look=look) for _, tree in row]
            for row in cells]
        save_image(labelled_grid(images, [[name for name, _ in row] for row in cells]),
                   path)
    else:
        tree = _seeded(fig.build, seed)
        aspect = fig.aspect(tree)
        width = max(16, round(height * aspect))
        camera = framed_camera(tree.program(), width, height, view=fig.view, up=fig.up,
                               fov=fig.fov)
        img = render(tree, width, height, camera=camera, samples=samples, shadows=shadows,
                     look=look)
        save_image(img, path)
    click.echo(f"figure {key}: {path} ({time.perf_counter() - start:.1f} s)")
