"""``blobtree watch SPEC.toml -o preview.png``: render a shell spec again each time it is saved.

The file is polled (its modification time and size, every ``--interval`` seconds) rather than
watched through the system's file events: polling needs no dependency, works the same on every
system and on network drives, and catches editors that save by writing a new file and renaming
it over the old one, which event watchers of the old file miss.  A poll costs one ``stat``.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path

import click

from .. import models
from ..live import LiveShell
from ..output import display_name
from ..render import save_image, warming
from ..render.image import IMAGE_FORMATS
from . import checked_output, compile_notice
from .render_cmd import _size, look_options


class Watcher:
    """Renders ``spec_path`` to ``output`` whenever the file changes (:meth:`poll`); a file
    the spec reader refuses is reported through ``say`` in one line and the last good picture
    is kept."""

    def __init__(self, spec_path: str | Path, output: str | Path, width: int, height: int,
                 say: Callable[[str], None] = print, **render_options) -> None:
        self.spec_path, self.output = Path(spec_path), output
        self.width, self.height = width, height
        self.say, self.options = say, render_options
        self.live: LiveShell | None = None
        self._seen: tuple[int, int] | None = None

    def poll(self) -> bool:
        """Look at the file once; render if it changed since the last look.  True if a
        picture was written."""
        try:
            st = os.stat(self.spec_path)
            stamp = (st.st_mtime_ns, st.st_size)
        except OSError as e:
            stamp = None
            if self._seen is not None or self.live is None:
                self.say(f"{self.spec_path}: {e.strerror or e}; waiting for it")
        if stamp == self._seen:
            return False
        self._seen = stamp
        if stamp is None:
            return False
        try:
            spec = models.load_spec(self.spec_path)
        except ValueError as e:
            kept = f"; keeping {display_name(self.output)}" if self.live else ""
            self.say(f"{str(e).splitlines()[0]}{kept}")
            return False
        if self.live is None:
            self.live = LiveShell(spec)
        elif not self.live.set(spec):
            return False  # saved without a change to the spec
        start = time.perf_counter()
        img = self.live.picture(self.width, self.height, **self.options)
        save_image(img, self.output)
        self.say(f"{display_name(self.output)}: {self.width}x{self.height}, "
                 f"{time.perf_counter() - start:.2f} s")
        return True


@click.command("watch")
@click.argument("spec", type=click.Path(dir_okay=False))
@click.option("-o", "--output", default="preview.png", show_default=True,
              help="Image file (.png, .jpg, .tif, .bmp, .ppm), written again on each change.")
@click.option("--size", default="512x512", show_default=True, callback=_size,
              help="Image size WIDTHxHEIGHT in pixels.")
@look_options
@click.option("--interval", default=0.25, show_default=True, type=click.FloatRange(0.01, 60),
              help="Seconds between looks at the file.")
def watch(spec, output, size, samples, no_shadows, look, background, interval) -> None:
    """Render the shell spec SPEC (a .toml file) to an image, and again each time it is saved,
    until Ctrl-C; a bad edit prints its error and keeps the last good picture."""
    if Path(spec).suffix.lower() != ".toml":
        raise click.BadParameter(f"expected a shell spec file (.toml), got {spec!r}",
                                 param_hint="SPEC")
    if output == "-":
        raise click.BadParameter("watch writes a file again and again: give a file name, not -",
                                 param_hint="-o")
    checked_output(output, IMAGE_FORMATS, None)
    watcher = Watcher(spec, output, *size, say=lambda m: click.echo(m, err=True),
                      samples=samples, shadows=not no_shadows, look=look, background=background)
    click.echo(f"watching {spec} (Ctrl-C stops)", err=True)
    try:
        with compile_notice(), warming():
            while True:
                watcher.poll()
                time.sleep(interval)
    except KeyboardInterrupt:  # the way out: the last picture stays
        click.echo("stopped", err=True)
