"""``blobtree view SCENE -o shell.html``: a 3D page of the scene anyone can open offline."""

from __future__ import annotations

import time
from pathlib import Path

import click

from ..api import polygonize
from ..mesh.export import import_trimesh
from ..mesh.web import page
from ..output import display_name, write_file
from . import checked_output, compile_notice, direction
from .scenes import resolve_scene, scene_view


@click.command()
@click.argument("scene")
@click.option("-o", "--output", default="view.html", show_default=True,
              type=click.Path(dir_okay=False, path_type=Path),
              help="HTML file: the mesh and the viewer in one file; it loads nothing from the "
                   "network.  - writes it to standard output.")
@click.option("-r", "--resolution", type=click.IntRange(8, 1024), default=128,
              show_default=True,
              help="Mesh cells across the scene (128: about 4 MB for the Murex; the page "
                   "grows with the square of it).")
@click.option("--up", callback=direction,
              help="Direction shown up, x,y,z (default: a built-in model's own, else +y).")
def view(scene: str, output: Path, resolution: int, up) -> None:
    """Write SCENE as a self-contained 3D page: drag to turn, wheel to zoom, right-drag to pan."""
    checked_output(output)
    import_trimesh()  # before the work (Ctrl-C-safe, see import_trimesh)
    tree = resolve_scene(scene)
    start = time.perf_counter()
    seen = scene_view(scene, tree)
    options = {} if seen is None else {"up": seen[0], "view": seen[1]}
    if up is not None:
        options["up"] = up
    with compile_notice():
        mesh = polygonize(tree, resolution=resolution, progress=True)
    html = page(mesh, title=f"blobtree: {Path(scene).name}", **options).encode("utf-8")
    write_file(output, html)
    click.echo(f"{display_name(output)}: {len(mesh.faces)} triangles, {len(html) / 1e6:.1f} MB, "
               f"{time.perf_counter() - start:.2f} s", err=True)
