"""``blobtree render SCENE -o out.png``: ray-trace a scene to an image."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import Any

import click

from ..api import render as render_image
from ..nodes import Node
from ..output import display_name
from ..render import LOOKS, Camera, save_image, warming
from ..render.camera import default_camera, seen_camera
from ..render.image import IMAGE_FORMATS
from ..render.tiles import MAX_SIDE
from . import checked_output, compile_notice, floats, format_option
from .cluster import cluster, cluster_options
from .scenes import resolve_scene, scene_camera


def _size(ctx, param, value):
    try:
        w, h = (int(v) for v in value.lower().split("x"))
    except ValueError:
        raise click.BadParameter(f"expected WIDTHxHEIGHT such as 800x600, got {value!r}") from None
    if not (1 <= w <= MAX_SIDE and 1 <= h <= MAX_SIDE):
        raise click.BadParameter(f"width and height must be in [1, {MAX_SIDE}], got {value!r}")
    return w, h


def look_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """The options of an image's look (rays per pixel, shadows, look, background), shared by
    ``render`` and ``grow``."""
    for option in reversed([
        click.option("--samples", default=1, show_default=True,
                     help="Rays per pixel (anti-aliasing)."),
        click.option("--no-shadows", is_flag=True, help="Skip shadow rays."),
        click.option("--look", type=click.Choice(sorted(LOOKS)), default="studio",
                     show_default=True,
                     help="studio: soft backdrop, soft shadows, ambient occlusion; glossy: the "
                          "same, polished; paper: the plain style of the paper's figures."),
        click.option("--background", callback=floats(3),
                     help="Plain background colour r,g,b in [0, 1] instead of the look's "
                          "backdrop."),
    ]):
        command = option(command)
    return command


def command_camera(scene: str, tree: Node, prog, width: int, height: int,
                   eye: tuple | None = None, target: tuple | None = None,
                   up: tuple = (0.0, 1.0, 0.0), fov: float | None = None) -> Camera:
    """The camera ``render`` uses: the one given by ``eye``, ``target``, ``up`` and ``fov``
    (framed for what is not given), else the scene's own view (a figure's or a shell's), else
    the framed three-quarter view."""
    if eye is None and target is None and fov is None:  # a built-in model's own view
        return scene_camera(scene, tree, prog, width, height) or \
            seen_camera(tree, prog, width, height)
    if eye is None or target is None or fov is None:
        framed = default_camera(prog, width, height)
        eye, target = eye or framed.eye, target or framed.target
        fov = framed.fov if fov is None else fov
    return Camera(eye=eye, target=target, up=up, fov=fov)


@click.command("render")
@click.argument("scene")
@click.option("-o", "--output", default="render.png", show_default=True,
              help="Image file (.png, .jpg, .tif, .bmp, .ppm), or - for standard output (with "
                   "--format).")
@format_option(IMAGE_FORMATS)
@click.option("--size", default="800x800", show_default=True, callback=_size,
              help="Image size WIDTHxHEIGHT in pixels.")
@look_options
@click.option("--eye", callback=floats(3), help="Camera position x,y,z (default: framed view).")
@click.option("--target", callback=floats(3), help="Point looked at x,y,z.")
@click.option("--up", default="0,1,0", show_default=True, callback=floats(3),
              help="Camera up vector x,y,z.")
@click.option("--fov", type=float, default=None, help="Vertical field of view, degrees.")
@click.option("--tile", type=int, default=None,
              help="Tile side in pixels  [default: 128 for large images, else 64].")
@click.option("--checkpoint", type=click.Path(file_okay=False),
              help="Directory keeping each finished tile, so an interrupted render can resume.")
@click.option("--resume", is_flag=True,
              help="Reuse the tiles in --checkpoint left by an interrupted run of this render.")
@cluster_options
@click.option("--quiet", is_flag=True, help="No progress bar or timing.")
def render(scene, output, fmt, size, samples, eye, target, up, fov, no_shadows, look, background,
           tile, checkpoint, resume, scheduler, dask_workers, quiet) -> None:
    """Ray-trace SCENE (a built-in model name or a JSON scene file) into an image."""
    width, height = size
    start = time.perf_counter()
    checked_output(output, IMAGE_FORMATS, fmt)
    if resume and checkpoint is None:
        raise click.BadParameter("--resume needs --checkpoint DIR", param_hint="--resume")
    try:
        with compile_notice(quiet):  # (a first run compiles from the scene's camera on)
            tree = resolve_scene(scene)
            # the kernels load while the program and camera are built
            with warming(scheduler is None):
                prog = tree.program()
                camera = command_camera(scene, tree, prog, width, height, eye, target, up,
                                        fov)
                with cluster(scheduler, dask_workers, quiet) as client:
                    img = render_image(tree, width, height, camera=camera, samples=samples,
                                       shadows=not no_shadows, background=background,
                                       look=look, tile=tile, progress=not quiet,
                                       scheduler=client, checkpoint=checkpoint, resume=resume)
        save_image(img, output, fmt)
    except KeyboardInterrupt:
        kept = f"; finished tiles kept in {checkpoint} (--resume)" if checkpoint else ""
        click.echo(f"interrupted; nothing written{kept}", err=True)
        sys.exit(130)
    if not quiet:
        click.echo(f"{display_name(output)}: {width}x{height}, "
                   f"{time.perf_counter() - start:.2f} s", err=True)
