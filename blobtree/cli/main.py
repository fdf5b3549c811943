"""``blobtree``: inspect, render and mesh BlobTree scenes from the command line."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import click
import numpy as np

from .. import __version__, models
from ..io import SceneError
from ..mesh import polygonize
from ..mesh.export import NOZZLE_MM
from ..mesh.thickness import measure
from ..nodes import Node
from ..output import is_stdout, write_file
from . import checked_output, compile_notice, length_mm, start_command
from .figures_cmd import figures
from .grow_cmd import grow
from .mesh_cmd import mesh
from .render_cmd import render
from .scenes import BUILTIN, resolve_scene, scene_up
from .view_cmd import view
from .watch_cmd import watch

#: What a user's mistake raises (bad values, unreadable or unwritable files, scene documents too
#: deep or too large): reported in one line, never as a traceback.
USER_ERRORS = (ValueError, SceneError, OSError, RecursionError, OverflowError, MemoryError)


class _Commands(click.Group):
    """The command group: a user's mistake is one line on stderr and exit code 1; Ctrl-C stops
    any command with exit code 130 (outputs are written whole or not at all)."""

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt:
            click.echo("interrupted; nothing written", err=True)
            ctx.exit(130)
        except USER_ERRORS as exc:
            message = str(exc) or type(exc).__name__
            if isinstance(exc, OSError) and exc.strerror:  # without "[Errno N]"
                message = exc.strerror + (f": {exc.filename!r}" if exc.filename else "")
            if isinstance(exc, RecursionError):
                message = "the scene is nested too deeply to read"
            raise click.ClickException(message[:2000]) from None


@click.group(cls=_Commands, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="blobtree")
def main() -> None:
    """Structured implicit modelling with the BlobTree.

    SCENE is a JSON scene file (see `blobtree.save`) or a built-in model name.
    """


@main.command()
@click.argument("scene")
@click.option("--height", callback=length_mm, default=None,
              help="Also report the thinnest parts at this print height (e.g. 80mm, 8cm, "
                   "3in): spine tips and walls, measured on the field.")
@click.option("--resolution", default=128, show_default=True, type=click.IntRange(16, 1024),
              help="With --height: the mesh whose vertices are measured.")
def info(scene: str, height: float | None, resolution: int) -> None:
    """Node counts by type (each shared subtree once), bounds and program length of SCENE."""
    tree: Node = resolve_scene(scene)
    counts = Counter(n.TYPE for n in tree.unique())
    prog = tree.program()
    lo, hi = prog.bounds
    click.echo(f"scene: {scene}")
    click.echo(f"nodes: {sum(counts.values())} distinct")
    for name, n in sorted(counts.items(), key=lambda kv: (-kv[1], kv[0])):
        click.echo(f"  {name:<18}{n:>8}")
    np.set_printoptions(precision=4, suppress=True)
    click.echo(f"bounds: {lo} .. {hi}")
    click.echo(f"program: {len(prog)} instructions, stack depth {prog.depth}, "
               f"Lipschitz bound {tree.lipschitz():.4g}")  # (the rule, no kernel to load)
    if height is not None:
        _thin_parts(scene, tree, prog, height, resolution)


#: Surface points measured by ``info --height`` (a random sample of the mesh's vertices).
THIN_SAMPLES = 20_000


def _thin_parts(scene: str, tree: Node, prog, height: float, resolution: int) -> None:
    """The thinnest spine and wall of the tree printed ``height`` mm tall (along its up)."""
    with compile_notice():
        mesh = polygonize(prog, resolution=resolution, progress=True)
    if not len(mesh.vertices):
        raise ValueError(f"{scene} has no surface to measure")
    mm = height / mesh.extent(scene_up(scene, tree))  # millimetres per model unit
    cell = float(np.max(mesh.vertices.max(0) - mesh.vertices.min(0))) / resolution
    rng = np.random.default_rng(0)
    pick = rng.choice(len(mesh.vertices), min(THIN_SAMPLES, len(mesh.vertices)), replace=False)
    th = measure(prog, mesh.vertices[pick], step=cell / 2.0, depth=resolution * cell / 4.0)
    click.echo(f"thin parts at {height:g} mm tall ({len(pick)} surface points of a "
               f"{resolution}-cell mesh, {mm:.4g} mm per unit):")
    for label, mask in (("spine (rod)", th.rods), ("wall (sheet)", th.sheets)):
        found = th.thinnest(mask)
        if found is None:
            click.echo(f"  thinnest {label}: none found")
        else:
            t, where = found
            click.echo(f"  thinnest {label}: {t * mm:.3g} mm at {np.round(where, 3)}")
    edges = th.edges.mean() * 100.0
    click.echo(f"  knife edges (thinner than {th.step * mm:.3g} mm, e.g. carved rims): {edges:.1f}%"
               " of the surface")
    thin = (th.across * mm < NOZZLE_MM).mean() * 100.0
    click.echo(f"  thinner than a {NOZZLE_MM} mm nozzle: {thin:.1f}% of the surface")


@main.command("models")
def list_models() -> None:
    """List the built-in model names usable as SCENE (shells: their species)."""
    for name in sorted(BUILTIN):
        species = models.SHELLS.get(name)
        click.echo(name if species is None else f"{name:<12}{species.name} (shell spec)")


@main.command("spec")
@click.argument("name", type=click.Choice(sorted(models.SHELLS)))
@click.option("-o", "--output", default="-", type=click.Path(dir_okay=False, path_type=Path),
              help="Write the spec here  [default: -, standard output].")
def spec(name: str, output: Path) -> None:
    """Print a shipped shell's whole spec as TOML, every key explained: a file to edit into a
    new species (then `blobtree render my_shell.toml`)."""
    checked_output(output)
    write_file(output, models.spec.to_toml(models.SHELLS[name]).encode("utf-8"))
    if not is_stdout(output):
        click.echo(f"wrote {output}", err=True)


main.add_command(figures)
main.add_command(grow)
main.add_command(mesh)
main.add_command(render)
main.add_command(view)
main.add_command(watch)


def run() -> None:
    """The ``blobtree`` executable: :func:`start_command`, then the command line."""
    start_command()
    main()


if __name__ == "__main__":
    run()
