"""``blobtree``: inspect, render and mesh BlobTree scenes from the command line."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import click
import numpy as np

from .. import __version__, models
from ..files import atomic_path, check_writable
from ..io import SceneError
from ..nodes import Node
from . import start_command
from .figures_cmd import figures
from .mesh_cmd import mesh
from .render_cmd import render
from .scenes import BUILTIN, resolve_scene
from .view_cmd import view

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
def info(scene: str) -> None:
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
               f"Lipschitz bound {prog.lipschitz_global:.4g}")


@main.command("models")
def list_models() -> None:
    """List the built-in model names usable as SCENE (shells: their species)."""
    for name in sorted(BUILTIN):
        species = models.SHELLS.get(name)
        click.echo(name if species is None else f"{name:<12}{species.name} (shell spec)")


@main.command("spec")
@click.argument("name", type=click.Choice(sorted(models.SHELLS)))
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="Write the spec here (default: print it).")
def spec(name: str, output: Path | None) -> None:
    """Print a shipped shell's whole spec as TOML, every key explained: a file to edit into a
    new species (then `blobtree render my_shell.toml`)."""
    text = models.spec.to_toml(models.SHELLS[name])
    if output is None:
        click.echo(text, nl=False)
        return
    check_writable(output, "--output")
    with atomic_path(output) as tmp:
        tmp.write_text(text)
    click.echo(f"wrote {output}")


main.add_command(figures)
main.add_command(mesh)
main.add_command(render)
main.add_command(view)


def run() -> None:
    """The ``blobtree`` executable: :func:`start_command`, then the command line."""
    start_command()
    main()


if __name__ == "__main__":
    run()
