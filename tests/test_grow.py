"""Films of a shell growing (``blobtree grow``, blobtree.film): the last frame is the render,
films decode to their frames, an interrupted film resumes to the same film, and a cluster (with
a worker killed mid-film) makes the same film as this machine."""

from __future__ import annotations

import math
import os
import signal
import time

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import blobtree as bt
from blobtree.cli.main import main
from blobtree.film import Film, FrameStore, encode_film, local_frames, make_film
from blobtree.render.camera import seen_camera

SIZE = ["--size", "48x48"]


def grow(*args: str) -> None:
    result = CliRunner().invoke(main, ["grow", *args, "--quiet"])
    assert result.exit_code == 0, result.output


@pytest.fixture(scope="module")
def frames(tmp_path_factory):
    """Three 48x48 frames of the Murex growing, in a folder (-o DIR/)."""
    folder = tmp_path_factory.mktemp("film") / "frames"
    grow("murex", "-o", f"{folder}/", "--frames", "3", *SIZE)
    return folder


def small_film(frames: int = 3, orbit: float = 0.0) -> Film:
    """A film of the Oliva (the quickest shell to build) at 32x32."""
    spec = bt.models.SHELLS["oliva"]
    whole = bt.models.shell(spec, 0)
    camera = seen_camera(whole, whole.program(), 32, 32)
    return Film(spec, 0, frames, 32, 32, camera, orbit=orbit)


@pytest.mark.slow
def test_the_last_frame_is_the_render(frames, tmp_path):
    image = tmp_path / "render.png"
    result = CliRunner().invoke(main, ["render", "murex", "-o", str(image), *SIZE, "--quiet"])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in frames.glob("*.png")) == [
        "frame-0001.png", "frame-0002.png", "frame-0003.png"]
    assert (frames / "frame-0003.png").read_bytes() == image.read_bytes()
    # the shell grows: fewer pixels differ from the backdrop in earlier frames
    corner = np.asarray(Image.open(image))[0, 0].astype(int)
    covered = [int((np.abs(np.asarray(Image.open(frames / f"frame-000{k}.png")).astype(int)
                           - corner).sum(axis=2) > 30).sum()) for k in (1, 2, 3)]
    assert covered[0] < covered[1] < covered[2], covered


def decode(path) -> list[np.ndarray]:
    """A film's frames, decoded by another library than the one that wrote it where there is
    one (PyAV for MP4, Pillow for GIF and WebP)."""
    if path.suffix == ".mp4":
        import av

        with av.open(str(path)) as container:
            return [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]
    with Image.open(path) as im:
        out = []
        for k in range(im.n_frames):
            im.seek(k)
            out.append(np.asarray(im.convert("RGB")))
        return out


@pytest.mark.slow
@pytest.mark.parametrize("ext", ["mp4", "gif", "webp"])
def test_a_film_decodes_to_its_frames(frames, tmp_path, ext):
    film = tmp_path / f"grows.{ext}"
    # the frames of the folder are reused: the same film, so nothing is rendered again
    grow("murex", "-o", str(film), "--frames", "3", *SIZE, "--checkpoint", str(frames),
         "--resume")
    decoded = decode(film)
    assert len(decoded) == 3 and all(f.shape == (48, 48, 3) for f in decoded)
    last = np.asarray(Image.open(frames / "frame-0003.png")).astype(int)
    assert np.abs(decoded[-1].astype(int) - last).mean() < 6.0  # lossy, but this frame


def test_the_default_frame_folder_goes_once_the_film_is_written(tmp_path):
    film = tmp_path / "o.gif"
    grow("oliva", "-o", str(film), "--frames", "2", "--size", "24x24")
    assert len(decode(film)) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o.gif"]


def test_bad_arguments_are_refused_by_name(tmp_path):
    for args, words in [
        (["whorl126", "-o", str(tmp_path / "w.gif")], "not a shell"),
        (["murex", "-o", str(tmp_path / "m.mp4"), "--size", "47x48"], "even width"),
        (["murex", "-o", f"{tmp_path}/d/", "--checkpoint", str(tmp_path / "c")],
         "--checkpoint"),
        (["murex", "-o", str(tmp_path / "m.avi")], "extension"),
        (["murex", "-o", str(tmp_path / "m.gif"), "--frames", "0"], "--frames"),
    ]:
        result = CliRunner().invoke(main, ["grow", *args, "--quiet"])
        assert result.exit_code != 0 and words in result.output, (args, result.output)
    assert list(tmp_path.iterdir()) == []


def test_the_orbit_ends_at_the_render_camera():
    film = small_film(5, orbit=90.0)
    assert film.camera_at(4) == film.camera
    eye, first = np.array(film.camera.eye), np.array(film.camera_at(0).eye)
    turned = math.degrees(math.atan2(-first[2], first[0]) - math.atan2(-eye[2], eye[0]))
    assert (turned + 180.0) % 360.0 - 180.0 == pytest.approx(90.0)  # right-handed about y
    assert first[1] == pytest.approx(eye[1])


def test_frames_are_rendered_in_a_mixed_order():
    for n in (1, 2, 3, 10, 120):
        order = small_film(n).order()
        assert sorted(order) == list(range(n))
    order = small_film(120).order()
    assert max(order[:12]) > 90 and min(order[:12]) < 30  # early and late frames from the start


class Crash(Exception):
    """A crash simulated after some frames."""


@pytest.mark.slow
def test_an_interrupted_film_resumes_to_the_same_film(tmp_path):
    film = small_film()
    whole = FrameStore(tmp_path / "whole", film)
    make_film(film, whole)

    def crash_after_one(film, indices):
        frames = local_frames(film, indices)
        yield next(frames)
        raise Crash

    store = FrameStore(tmp_path / "cut", film)
    with pytest.raises(Crash):
        make_film(film, store, crash_after_one)
    assert len(store.done()) == 1
    with pytest.raises(ValueError, match="already holds a film"):
        FrameStore(tmp_path / "cut", film)
    with pytest.raises(ValueError, match="another film"):
        FrameStore(tmp_path / "cut", small_film(4), resume=True)
    make_film(film, FrameStore(tmp_path / "cut", film, resume=True))
    for i in range(film.frames):
        assert store.path(i).read_bytes() == whole.path(i).read_bytes()
    films = [encode_film([s.load(i) for i in range(film.frames)], "GIF", 10.0)
             for s in (store, whole)]
    assert films[0] == films[1]


@pytest.mark.cluster
def test_a_cluster_with_a_killed_worker_makes_the_same_film(tmp_path):
    from blobtree import distributed as bd

    film = small_film(6)
    local = dict(local_frames(film, list(range(film.frames))))
    got = {}
    with bd.connect(workers=2) as client:
        client.wait_for_workers(2, timeout=60.0)
        victim = next(iter(client.run(os.getpid).values()))
        for i, img in bd.remote_frames(client, film, film.order()):
            got[i] = img
            if len(got) == 1:  # mid-film: the other frames are queued or running
                os.kill(victim, signal.SIGKILL)
        deadline = time.monotonic() + 60.0
        while victim in client.run(os.getpid).values():
            assert time.monotonic() < deadline, "the killed worker is still listed"
            time.sleep(0.1)
        assert sorted(got) == list(range(film.frames))
        assert all(np.array_equal(got[i], local[i]) for i in local)
        # the command line on the same cluster: the same film file as made locally
        grow("oliva", "-o", str(tmp_path / "here.gif"), "--frames", "3", "--size", "24x24")
        grow("oliva", "-o", str(tmp_path / "there.gif"), "--frames", "3", "--size", "24x24",
             "--scheduler", client.scheduler.address)
    assert (tmp_path / "here.gif").read_bytes() == (tmp_path / "there.gif").read_bytes()
