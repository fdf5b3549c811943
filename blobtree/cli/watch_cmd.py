"""``blobtree watch SPEC.toml -o preview.png``: render a shell spec again each time it is saved.

The file is polled (its modification time and size, every ``--interval`` seconds) rather than
watched through the system's file events: polling needs no dependency, works the same on every
system and on network drives, and catches editors that save by writing a new file and renaming
it over the old one, which event watchers of the old file miss.  A poll costs one ``stat``.
"""

from __future__ import annotations

import contextlib
import os
import threading
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path

import click
import numpy as np

from .. import models
from ..live import LiveShell
from ..output import display_name
from ..render import Stopped, local_tiles, save_image, stop_flag, warming
from ..render.image import IMAGE_FORMATS
from ..runtime.threads import threads as parallel_threads
from . import checked_output, compile_notice
from .render_cmd import _size, look_options


class Watcher:
    """Renders ``spec_path`` to ``output`` whenever the file changes (:meth:`poll`); a file
    the spec reader refuses is reported through ``say`` in one line and the last good picture
    is kept.  While a picture is drawn the file is looked at every ``interval`` seconds too: a
    save stops the picture (nothing is written) and the next poll draws the new spec."""

    def __init__(self, spec_path: str | Path, output: str | Path, width: int, height: int,
                 say: Callable[[str], None] = print, interval: float = 0.25,
                 **render_options) -> None:
        self.spec_path, self.output = Path(spec_path), output
        self.width, self.height = width, height
        self.say, self.interval, self.options = say, interval, render_options
        self.live: LiveShell | None = None
        self._seen: tuple[int, int] | None = None

    def _stamp(self) -> tuple[int, int]:
        """The file's modification time and size; OSError if it cannot be read."""
        st = os.stat(self.spec_path)
        return st.st_mtime_ns, st.st_size

    def _stop_on_save(self, stamp: tuple[int, int], stop: np.ndarray, done: threading.Event
                      ) -> None:
        """Until ``done``: set ``stop`` once the file is no longer as ``stamp`` says."""
        while not done.wait(self.interval):
            with contextlib.suppress(OSError):
                if self._stamp() == stamp:
                    continue
            stop[0] = 1
            return

    def poll(self) -> bool:
        """Look at the file once; render if it changed since the last look.  True if a
        picture was written."""
        try:
            stamp = self._stamp()
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
        stop, done = stop_flag(), threading.Event()
        looking = threading.Thread(target=self._stop_on_save, args=(stamp, stop, done),
                                   name="blobtree-watch", daemon=True)
        looking.start()
        try:
            img = self.live.picture(self.width, self.height, source=partial(
                local_tiles, threads=parallel_threads(), stop=stop), **self.options)
        except Stopped:
            self.say(f"{self.spec_path}: saved again while drawn; drawing the new one")
            return False
        finally:
            done.set()
            looking.join()
        save_image(img, self.output)
        self.live.tidy()
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
                      interval=interval, samples=samples, shadows=not no_shadows, look=look,
                      background=background)
    click.echo(f"watching {spec} (Ctrl-C stops)", err=True)
    try:
        with compile_notice(), warming():
            while True:
                watcher.poll()
                time.sleep(interval)
    except KeyboardInterrupt:  # the way out: the last picture stays
        click.echo("stopped", err=True)
