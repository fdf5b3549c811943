"""``blobtree mesh SCENE -o out.ply``: polygonize a scene and save the mesh."""

from __future__ import annotations

import time
from pathlib import Path

import click

from ..api import polygonize
from ..files import check_writable
from ..mesh.export import FORMATS, import_trimesh
from . import compile_notice
from .cluster import cluster, cluster_options
from .scenes import resolve_scene


@click.command()
@click.argument("scene")
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(dir_okay=False, path_type=Path),
    help=f"Mesh file; the format follows the extension ({', '.join(FORMATS)}).",
)
@click.option(
    "-r",
    "--resolution",
    type=click.IntRange(min=2),
    default=256,
    show_default=True,
    help="Cells across the longest side of the scene's bounds.",
)
@cluster_options
def mesh(scene: str, output: Path, resolution: int, scheduler: str | None,
         dask_workers: int | None) -> None:
    """Polygonize SCENE into a watertight triangle mesh with normals and vertex colours."""
    if output.suffix.lower() not in FORMATS:
        raise click.BadParameter(
            f"extension {output.suffix!r} is not one of {', '.join(FORMATS)}", param_hint="-o"
        )
    try:
        check_writable(output, "--output")
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="-o") from None
    import_trimesh()  # now rather than after the work (and Ctrl-C-safe, see import_trimesh)
    tree = resolve_scene(scene)
    start = time.perf_counter()
    with cluster(scheduler, dask_workers) as client, compile_notice():
        result = polygonize(tree, resolution=resolution, progress=True, scheduler=client)
    result.save(output)
    seconds = time.perf_counter() - start
    click.echo(
        f"{output}: {len(result.faces)} triangles, {seconds:.2f} s, "
        f"watertight: {'yes' if result.is_watertight else 'no'}"
    )
