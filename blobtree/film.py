"""Films of a shell growing: frame i of n is the shell at age i / (n - 1) (Eq. 15 at that age,
:mod:`blobtree.models.age`), ray-traced with one camera and look; frames are independent jobs.

A :class:`Film` describes the job (spec, seed, frames, size, camera, look) and renders any of
its frames; :class:`FrameStore` keeps finished frames as numbered PNG files in a directory, so
an interrupted film resumes where it stopped, on this machine or on a cluster
(``blobtree.distributed.remote_frames``); :func:`make_film` renders the frames a store lacks and
:func:`encode_film` turns the frames into a video (MP4, H.264 by PyAV, the optional extra
``blobtree[film]``) or an animated GIF or WebP (Pillow).  A frame's pixels do not depend on
where or on how many threads it is rendered, so a film is the same bytes wherever it is made.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import re
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from .checks import Choice, Integer, Number
from .models import ShellSpec, shell
from .output import write_file
from .render import LOOKS, Camera, render
from .render.image import encode_png

__all__ = ["FILM_FORMATS", "MAX_FRAMES", "MP4_CRF", "WEBP_QUALITY", "Film", "FrameStore",
           "check_size", "encode_film", "local_frames", "make_film"]

#: Film formats: name (an extension without its dot) -> what encodes it.
FILM_FORMATS = {"mp4": "mp4", "gif": "GIF", "webp": "WEBP"}
#: H.264's constant rate factor for MP4 films (18: visually lossless on these smooth images).
MP4_CRF = 18
#: Quality of lossy WebP frames (Pillow's scale, 0-100).
WEBP_QUALITY = 90
#: Most frames a film may have.
MAX_FRAMES = 100_000


@dataclass(frozen=True)
class Film:
    """A film of ``spec``'s shell (from ``seed``) growing over ``frames`` frames of ``width`` x
    ``height`` pixels, seen by ``camera`` (the whole shell's), turned ``orbit`` degrees about the
    shell axis (y) over the film so that the last frame is seen by ``camera`` itself; ``look``,
    ``samples``, ``shadows`` and ``background`` as for :func:`blobtree.render`."""

    spec: ShellSpec
    seed: int
    frames: int
    width: int
    height: int
    camera: Camera
    orbit: float = 0.0
    look: str = "studio"
    samples: int = 1
    shadows: bool = True
    background: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "frames", Integer(1, MAX_FRAMES).check("frames", self.frames))
        object.__setattr__(self, "orbit", Number(-1e5, 1e5).check("orbit", self.orbit))
        Choice(tuple(LOOKS)).check("look", self.look)

    def age(self, i: int) -> float:
        """The shell's age in frame i (0-based): i / (frames - 1), the last frame the whole
        shell."""
        return 1.0 if self.frames == 1 else i / (self.frames - 1)

    def camera_at(self, i: int) -> Camera:
        """Frame i's camera: ``camera`` turned about the y axis by ``orbit`` times the share of
        the film still to come (none in the last frame)."""
        turn = self.orbit * (1.0 - self.age(i))
        if turn == 0.0:
            return self.camera
        c, s = math.cos(math.radians(turn)), math.sin(math.radians(turn))
        rot = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])  # about y, right-handed
        cam = self.camera
        return replace(cam, eye=tuple(rot @ cam.eye), target=tuple(rot @ cam.target),
                       up=tuple(rot @ cam.up))

    def frame(self, i: int, threads: int | None = None) -> np.ndarray:
        """Frame i (0-based) as an (height, width, 3) uint8 image."""
        tree = shell(self.spec, self.seed, age=self.age(i))
        return render(tree, self.width, self.height, camera=self.camera_at(i),
                      samples=self.samples, shadows=self.shadows, background=self.background,
                      look=self.look, threads=threads)

    @property
    def key(self) -> str:
        """A digest of everything that decides the frames."""
        return hashlib.sha256(repr(self).encode()).hexdigest()

    def order(self) -> list[int]:
        """The frames in the order they are rendered: strided through the film by about
        0.618 of its length (coprime to it), so that early and late frames (small and large
        shells, quick and slow to trace) mix from the start and the rate of the frames done
        so far estimates the rest honestly."""
        n = self.frames
        step = max(1, round(0.618 * n))
        while math.gcd(step, n) != 1:
            step += 1
        return [(k * step) % n for k in range(n)]


#: A frame's file in a store (1-based, as ``frame-0001.png``).
_FRAME = re.compile(r"frame-(\d+)\.png")


class FrameStore:
    """Finished frames of one film in a directory: ``frame-0001.png`` ... (1-based, each
    written whole) and ``film.json`` naming the film, so that frames of another film are
    never used.  A directory that holds a film is refused unless ``resume``."""

    MANIFEST = "film.json"

    def __init__(self, directory: str | Path, film: Film, resume: bool = False):
        self.directory = Path(directory)
        if self.directory.exists() and not self.directory.is_dir():
            raise ValueError(f"frame directory {str(directory)!r} is not a directory")
        self.film = film
        self.digits = max(4, len(str(film.frames)))
        self.manifest = self.directory / self.MANIFEST
        if self.manifest.exists():
            held = json.loads(self.manifest.read_text()).get("film")
            if not resume:
                raise ValueError(f"frame directory {str(directory)!r} already holds a film; "
                                 "resume it (--resume) or use an empty directory")
            if held != film.key:
                raise ValueError(f"frame directory {str(directory)!r} holds another film (scene, "
                                 "frames, size, camera or look differ); use an empty directory")

    def path(self, i: int) -> Path:
        """The file of frame i (0-based)."""
        return self.directory / f"frame-{i + 1:0{self.digits}d}.png"

    def done(self) -> set[int]:
        """The frames (0-based) already in the directory."""
        if not self.manifest.exists():
            return set()
        return {int(m.group(1)) - 1 for p in self.directory.iterdir()
                if (m := _FRAME.fullmatch(p.name)) and 1 <= int(m.group(1)) <= self.film.frames}

    def save(self, i: int, img: np.ndarray) -> None:
        """Keep frame i (the directory and its manifest are made with the first frame)."""
        if not self.manifest.exists():
            try:
                self.directory.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise ValueError(f"frame directory {str(self.directory)!r}: {exc}") from None
            write_file(self.manifest, json.dumps({"film": self.film.key}).encode())
        write_file(self.path(i), encode_png(img))

    def load(self, i: int) -> np.ndarray:
        """Frame i's pixels."""
        from PIL import Image

        with Image.open(self.path(i)) as im:
            return np.asarray(im.convert("RGB"))

    def files(self) -> list[Path]:
        """Every file the store wrote (its frames and its manifest)."""
        return [self.path(i) for i in sorted(self.done())] + [self.manifest]


#: Renders frames somewhere: (film, frame indices) -> (index, pixels)... as they finish.
_FrameSource = Callable[[Film, list[int]], Iterator[tuple[int, np.ndarray]]]


def local_frames(film: Film, indices: list[int]) -> Iterator[tuple[int, np.ndarray]]:
    """Render frames one after another on this machine, each on all its cores."""
    for i in indices:
        yield i, film.frame(i)


def make_film(film: Film, store: FrameStore, source: _FrameSource | None = None,
              progress: bool = False) -> None:
    """Render the frames ``store`` lacks (in :meth:`Film.order`) by ``source`` (default
    :func:`local_frames`), keeping each in the store as it finishes; ``progress`` shows a bar
    over frames.  Interrupted (Ctrl-C, an error), the finished frames stay in the store."""
    done = store.done()
    todo = [i for i in film.order() if i not in done]
    frames = (source or local_frames)(film, todo)
    bar = None
    try:
        for i, img in frames:
            store.save(i, img)
            if progress and bar is None:  # from the first frame: no estimate from compiling
                from tqdm.auto import tqdm

                bar = tqdm(total=film.frames, initial=len(done) + 1, unit="frame", desc="grow",
                           leave=False)
            elif bar is not None:
                bar.update()
    finally:
        close = getattr(frames, "close", None)
        if close is not None:
            close()
        if bar is not None:
            bar.close()


def check_size(fmt: str, width: int, height: int) -> None:
    """Refuse a size the format cannot hold: H.264 (MP4) codes colour at half resolution
    (4:2:0), so its width and height must be even."""
    if fmt == "mp4" and (width % 2 or height % 2):
        raise ValueError(f"size {width}x{height}: an .mp4 film needs an even width and height "
                         "(H.264's 4:2:0 colour); .gif, .webp and PNG folders take any size")


def encode_film(images: Iterable[np.ndarray], fmt: str, fps: float) -> bytes:
    """Frames (each (H, W, 3) uint8, all one size) as the bytes of a film in ``fmt`` (a value
    of :data:`FILM_FORMATS`) at ``fps`` frames a second: MP4 (H.264, yuv420p, CRF
    :data:`MP4_CRF`, by PyAV), animated GIF or WebP (by Pillow), looping."""
    fps = Number(0.01, 1000.0).check("fps", fps)
    if fmt == "mp4":
        return _encode_mp4(images, fps)
    from PIL import Image

    pictures = [Image.fromarray(img, "RGB") for img in images]
    buffer = io.BytesIO()
    options = {"quality": WEBP_QUALITY} if fmt == "WEBP" else {}
    pictures[0].save(buffer, format=fmt, save_all=True, append_images=pictures[1:],
                     duration=round(1000.0 / fps), loop=0, **options)
    return buffer.getvalue()


def _encode_mp4(images: Iterable[np.ndarray], fps: float) -> bytes:
    """H.264 in an MP4 container, by PyAV (FFmpeg's libraries, shipped in its wheels)."""
    try:
        import av
    except ImportError:
        raise ImportError("an .mp4 film needs the optional extra: pip install 'blobtree[film]' "
                          "(or write .gif, .webp or a folder of PNGs)") from None
    from fractions import Fraction

    buffer = io.BytesIO()
    with av.open(buffer, "w", format="mp4") as container:
        stream = None
        for img in images:
            if stream is None:
                check_size("mp4", img.shape[1], img.shape[0])
                stream = container.add_stream("libx264", rate=Fraction(fps).limit_denominator(1001))
                stream.height, stream.width = img.shape[:2]
                stream.pix_fmt = "yuv420p"
                stream.options = {"crf": str(MP4_CRF)}
            container.mux(stream.encode(av.VideoFrame.from_ndarray(img, format="rgb24")))
        if stream is not None:
            container.mux(stream.encode(None))  # flush the encoder's delayed frames
    return buffer.getvalue()
