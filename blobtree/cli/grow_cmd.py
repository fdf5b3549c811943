"""``blobtree grow SCENE -o grows.mp4``: a film of a shell growing (docs/films.md)."""

from __future__ import annotations

import functools
import os
import sys
import tempfile
import time
from pathlib import Path

import click

from ..film import FILM_FORMATS, MAX_FRAMES, Film, FrameStore, check_size, encode_film, make_film
from ..models import shell
from ..output import display_name, write_file
from ..render import warming
from . import checked_output, compile_notice, format_option
from .cluster import cluster, cluster_options
from .render_cmd import _size, command_camera, look_options
from .scenes import scene_spec


def _folder(output: str) -> bool:
    """Whether ``-o`` names a folder of PNG frames (it ends with a slash)."""
    return output.endswith(("/", os.sep))


@click.command("grow")
@click.argument("scene")
@click.option("-o", "--output", default="grows.mp4", show_default=True,
              help="Film file (.mp4, .gif, .webp), - for standard output (with --format), or a "
                   "folder ending in / for numbered PNG frames.")
@format_option(FILM_FORMATS)
@click.option("--frames", default=120, show_default=True, type=click.IntRange(1, MAX_FRAMES),
              help="Number of frames: frame i of N shows the shell at age i / (N - 1).")
@click.option("--size", default="640x640", show_default=True, callback=_size,
              help="Frame size WIDTHxHEIGHT in pixels.")
@click.option("--fps", default=24.0, show_default=True, type=click.FloatRange(0.1, 240.0),
              help="Frames per second of the film.")
@click.option("--orbit", default=0.0, show_default=True, type=click.FloatRange(-3600, 3600),
              help="Turn the camera DEGREES about the shell axis over the film, ending at "
                   "render's view.")
@click.option("--seed", default=0, show_default=True, type=click.IntRange(0, 2**63 - 1),
              help="The shell's seed (bumps, canal spines, textures).")
@look_options
@click.option("--checkpoint", type=click.Path(file_okay=False),
              help="Directory keeping each finished frame  [default: OUTPUT.frames beside the "
                   "film, removed once it is written].")
@click.option("--resume", is_flag=True,
              help="Reuse the frames an interrupted run of this film left.")
@cluster_options
@click.option("--quiet", is_flag=True, help="No progress bar or timing.")
def grow(scene, output, fmt, frames, size, fps, orbit, seed, samples, no_shadows, look,
         background, checkpoint, resume, scheduler, dask_workers, quiet) -> None:
    """Film SCENE (a shell: a shipped species or a .toml spec) growing from its first
    instance to the whole shell, with the camera and look of `blobtree render SCENE`."""
    width, height = size
    start = time.perf_counter()
    spec = scene_spec(scene)
    folder = _folder(output)
    if folder:
        if checkpoint is not None:
            raise click.BadParameter("a folder -o keeps the frames itself: drop --checkpoint",
                                     param_hint="--checkpoint")
        film_format = None
    else:
        film_format = checked_output(output, FILM_FORMATS, fmt)
        try:
            check_size(film_format, width, height)
        except ValueError as exc:
            raise click.BadParameter(str(exc), param_hint="--size") from None
    with compile_notice(quiet), warming(scheduler is None):  # (the tracer loads meanwhile)
        tree = shell(spec, seed)  # the whole shell, as `render` builds it
        camera = command_camera(scene, tree, tree.program(), width, height)
    film = Film(spec, seed, frames, width, height, camera, orbit=orbit, look=look,
                samples=samples, shadows=not no_shadows, background=background)
    with tempfile.TemporaryDirectory(prefix="blobtree-grow-") as scratch:
        # where the frames go: the folder output, --checkpoint, OUTPUT.frames beside a film
        # file, or (for standard output) a directory removed at the end
        kept = output != "-" or checkpoint is not None
        directory = output if folder else checkpoint or (f"{output}.frames" if kept else scratch)
        store = FrameStore(directory, film, resume=resume)
        try:
            with compile_notice(quiet), cluster(scheduler, dask_workers, quiet) as client:
                source = None
                if client is not None:
                    from ..distributed import remote_frames

                    source = functools.partial(remote_frames, client)
                make_film(film, store, source, progress=not quiet)
        except KeyboardInterrupt:
            where = f"kept in {directory} (--resume)" if kept else "lost (no --checkpoint)"
            click.echo(f"interrupted; {len(store.done())} of {frames} finished frames {where}",
                       err=True)
            sys.exit(130)
        if not folder:
            write_file(output, encode_film((store.load(i) for i in range(frames)), film_format,
                                           fps))
            if directory == f"{output}.frames":  # the default frame folder: done with
                for path in store.files():
                    path.unlink()
                Path(directory).rmdir()
    if not quiet:
        click.echo(f"{display_name(output)}: {frames} frames of {width}x{height}, "
                   f"{time.perf_counter() - start:.2f} s", err=True)

