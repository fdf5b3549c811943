"""``blobtree mesh SCENE -o out.ply``: polygonize a scene and save the mesh."""

from __future__ import annotations

import time
from pathlib import Path

import click

from ..api import polygonize
from ..mesh.export import BUBBLE_MM3, ENCODERS, FORMATS, NOZZLE_MM, import_trimesh
from ..output import display_name
from . import checked_output, compile_notice, direction, format_option, length_mm
from .cluster import cluster, cluster_options
from .scenes import resolve_scene, scene_up


def _vector(v: tuple[float, ...]) -> str:
    """A direction as the summary line shows it: (0, -1, 0)."""
    return "(" + ", ".join(f"{x:g}" for x in v) + ")"


def _count(n: int, thing: str) -> str:
    """"1 bubble", "2 bubbles"."""
    return f"{n} {thing}{'s' if n != 1 else ''}"


@click.command()
@click.argument("scene")
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(dir_okay=False, path_type=Path),
    help=f"Mesh file ({', '.join(FORMATS)}), or - for standard output (with --format).",
)
@format_option(FORMATS)
@click.option(
    "-r",
    "--resolution",
    type=click.IntRange(min=2),
    default=256,
    show_default=True,
    help="Cells across the longest side of the scene's bounds.",
)
@click.option("--height", callback=length_mm,
              help="Scale the mesh so the model is this tall along its up (--up), e.g. 80mm, "
                   "8cm, 3in; a bare number is mm.  Coordinates are then millimetres (3MF says "
                   "so in the file), and an STL is a print file too (see --up).")
@click.option("--up", callback=direction, metavar="X,Y,Z",
              help="The model's up, in its own frame: --height is measured along it; print files "
                   "(3MF, and STL with --height) stand it along +Z on z = 0, centred at x = y = 0; "
                   "GLB turns it to +Y (glTF's up); PLY and OBJ keep the model's frame.  "
                   "[default: a built-in model's own (a shell's apex up), else 0,1,0]")
@click.option("--min-piece", type=click.FloatRange(min=0.0, min_open=True),
              help="Drop separate pieces enclosing less than this volume (in the output's units "
                   "cubed, mm^3 with --height), and say how many; off by default.")
@click.option("--keep-bubbles", is_flag=True,
              help=f"Keep, in print files, the sealed bubbles smaller than a {NOZZLE_MM:g} mm "
                   f"nozzle can print (under {BUBBLE_MM3:.3g} mm^3), which are dropped by "
                   "default: a slicer would see each as a part of its own.")
@cluster_options
def mesh(scene: str, output: Path, fmt: str | None, resolution: int, height: float | None,
         up: tuple[float, float, float] | None, min_piece: float | None, keep_bubbles: bool,
         scheduler: str | None, dask_workers: int | None) -> None:
    """Polygonize SCENE into a watertight triangle mesh with normals and vertex colours."""
    kind = checked_output(output, FORMATS, fmt)
    if kind not in ENCODERS:
        import_trimesh()  # now rather than after the work (and Ctrl-C-safe, see import_trimesh)
    tree = resolve_scene(scene)
    start = time.perf_counter()
    with cluster(scheduler, dask_workers) as client, compile_notice():
        result = polygonize(tree, resolution=resolution, progress=True, scheduler=client)
    notes = []
    up = scene_up(scene, tree) if up is None else up
    printing = kind == "3mf" or (kind == "stl" and height is not None)
    if height is not None and len(result.faces):
        result = result.scaled(height / result.extent(up))
        notes.append(f"{height:g} mm tall")
    if printing and not keep_bubbles:
        result, dropped = result.without_small_pieces(BUBBLE_MM3, bubbles_only=True)
        if dropped:
            notes.append(f"dropped {_count(dropped, 'bubble')} under {BUBBLE_MM3:.3g} mm^3 "
                         "(--keep-bubbles keeps them)")
    if min_piece is not None:
        result, dropped = result.without_small_pieces(min_piece)
        notes.append(f"dropped {_count(dropped, 'piece')} under {min_piece:g}")
    if printing:
        result = result.standing(up)
        notes.append(f"up {_vector(up)} along +Z, on z = 0")
    elif kind == "glb":
        result = result.turned(up)
        notes.append(f"up {_vector(up)} along +Y")
    result.save(output, kind)
    seconds = time.perf_counter() - start
    solids, bubbles = result.solids_and_bubbles()
    sealed = f" (and {_count(bubbles, 'bubble')} sealed inside)" if bubbles else ""
    click.echo(
        f"{display_name(output)}: {len(result.faces)} triangles, {seconds:.2f} s, "
        f"watertight: {'yes' if result.is_watertight else 'no'}, "
        f"solids: {solids}{sealed}" + "".join(f", {n}" for n in notes), err=True
    )
