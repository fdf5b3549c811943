"""Checkpoints of long renders: finished tiles kept in a directory, so an interrupted job resumes
without redoing them (locally or on a cluster)."""

from __future__ import annotations

import hashlib
import io
import json
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..output import write_file

if TYPE_CHECKING:
    from .camera import Camera
    from .shade import Light
    from .tiles import RenderSettings

Rect = tuple[int, int, int, int]


def job_key(prog, camera: Camera, lights: Sequence[Light],
            settings: RenderSettings) -> str:
    """A hash of everything that decides a render's pixels: program, camera, lights, settings."""
    h = hashlib.sha256()
    for a in (*prog.arrays, *prog.bounds):
        h.update(np.ascontiguousarray(a).tobytes())
    h.update(repr((prog.depth, camera, list(lights), settings)).encode())
    return h.hexdigest()


class Checkpoint:
    """Finished tiles of one render in a directory: ``tile-X0-Y0-X1-Y1.npy`` per tile (written
    atomically) and ``manifest.json`` naming the job, so tiles of another job are never used,
    and the tile side, so a resumed render cuts its image as the interrupted one did (the
    default side depends on the cores: :func:`blobtree.render.tile_side`).  ``tile`` is the side
    this render uses: the held one (:attr:`held_tile`) unless it chose its own."""

    MANIFEST = "manifest.json"

    def __init__(self, directory: str | Path, job: str, resume: bool = False):
        self.directory = Path(directory)
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ValueError(f"checkpoint directory {str(directory)!r}: {exc}") from None
        self.job = job
        self.manifest = self.directory / self.MANIFEST
        self.started = self.manifest.exists()
        self.held_tile: int | None = None
        self.tile: int | None = None
        if self.started:
            manifest = json.loads(self.manifest.read_text())
            held = manifest.get("job")
            if isinstance(manifest.get("tile"), int) and manifest["tile"] >= 1:
                self.held_tile = manifest["tile"]
            if not resume:
                raise ValueError(
                    f"checkpoint directory {str(directory)!r} already holds a render; resume it "
                    "(resume=True, --resume) or use an empty directory")
            if held != job:
                raise ValueError(
                    f"checkpoint directory {str(directory)!r} holds another job (scene, camera, "
                    "lights or settings differ); use an empty directory")

    def _path(self, rect: Rect) -> Path:
        return self.directory / "tile-{}-{}-{}-{}.npy".format(*rect)

    def restore(self, img: np.ndarray, rects: Sequence[Rect]) -> list[Rect]:
        """Copy the finished tiles among ``rects`` into ``img``; return the others."""
        todo = []
        for rect in rects:
            x0, y0, x1, y1 = rect
            path = self._path(rect)
            pixels = np.load(path) if path.exists() else None
            if pixels is not None and pixels.shape == img[y0:y1, x0:x1].shape \
                    and pixels.dtype == img.dtype:
                img[y0:y1, x0:x1] = pixels
            else:
                todo.append(rect)
        return todo

    def save(self, rect: Rect, pixels: np.ndarray) -> None:
        """Keep one finished tile (the manifest is written with the first one)."""
        if not self.started:
            write_file(self.manifest, json.dumps({"job": self.job, "tile": self.tile}).encode())
            self.started = True
        buffer = io.BytesIO()
        np.save(buffer, pixels)
        write_file(self._path(rect), buffer.getbuffer())
