"""Scale-out on Dask: same image and mesh as the local engine, a lost worker, checkpoints."""

from __future__ import annotations

import importlib
import os
import signal
import socket
import time

import numpy as np
import pytest
from click.testing import CliRunner

import blobtree as bt
import blobtree.distributed as bd
from blobtree.cli.main import main
from blobtree.render import LOOKS, RenderSettings, tiles
from blobtree.render.camera import default_camera
from blobtree.render.checkpoint import Checkpoint
from blobtree.render.shade import default_lights

distributed = pytest.importorskip("distributed")
pytestmark = pytest.mark.cluster
#: the module (``blobtree.render`` is also the name of the function)
br = importlib.import_module("blobtree.render")

TIMEOUT = 60.0  # bound on every wait for the cluster


def scene() -> bt.Node:
    """A small coloured scene: two blended points and a torus."""
    blob = (bt.Point(radius=1.0) + bt.Point(radius=1.0).translate(0.8, 0, 0)).color((0.8, 0.3, 0.2))
    return blob | bt.Torus(major_radius=1.0, radius=0.3).rotate("x", 30)


@pytest.fixture(scope="module")
def client():
    """A local cluster of two single-threaded worker processes."""
    with bd.connect(workers=2) as c:
        c.wait_for_workers(2, timeout=TIMEOUT)
        yield c


RENDER = dict(width=72, height=48, samples=2, tile=16)


@pytest.fixture(scope="module")
def local_image() -> np.ndarray:
    return bt.render(scene(), **RENDER)


def test_image_equals_local_byte_for_byte(client, local_image):
    assert np.array_equal(bt.render(scene(), **RENDER, scheduler=client), local_image)
    # by address too, with a tile size that cuts the image differently
    address = client.scheduler.address
    img = bt.render(scene(), **{**RENDER, "tile": 20}, scheduler=address)
    assert np.array_equal(img, local_image)


def canonical(mesh: bt.Mesh) -> tuple[np.ndarray, np.ndarray]:
    """Vertices sorted, and the faces on them as sorted rows (each rotated to start at its
    smallest index, so orientation is kept)."""
    order = np.lexsort(mesh.vertices.T[::-1])
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    faces = rank[mesh.faces]
    faces = np.array([np.roll(f, -int(np.argmin(f))) for f in faces])
    return mesh.vertices[order], faces[np.lexsort(faces.T[::-1])]


def test_mesh_equals_local_up_to_vertex_order(client):
    tree = scene()
    # fine enough that batches exceed GRID_MIN_POINTS and are split across the workers
    local = bt.polygonize(tree, resolution=160)
    assert len(local.vertices) > 2 * bd.GRID_MIN_POINTS
    remote = bt.polygonize(tree, resolution=160, scheduler=client)
    v0, f0 = canonical(local)
    v1, f1 = canonical(remote)
    assert np.array_equal(v0, v1) and np.array_equal(f0, f1)
    assert np.array_equal(local.colors[np.lexsort(local.vertices.T[::-1])],
                          remote.colors[np.lexsort(remote.vertices.T[::-1])])


def test_killed_worker_does_not_change_the_image():
    tree = bt.models.whorl126()
    settings = RenderSettings(width=96, height=96, samples=4, **LOOKS["studio"])
    camera = default_camera(tree.program(), 96, 96)
    lights = default_lights(camera)
    expected = bt.render(tree, 96, 96, camera=camera, lights=lights, samples=4)
    rects = list(tiles(96, 96, 8))
    img = np.zeros_like(expected)
    with bd.connect(workers=2) as c:
        c.wait_for_workers(2, timeout=TIMEOUT)
        pids = c.run(os.getpid)
        victim_address, victim = next(iter(pids.items()))
        received = 0
        for (x0, y0, x1, y1), pixels in bd.remote_tiles(c, tree, camera, lights, settings, rects):
            img[y0:y1, x0:x1] = pixels
            received += 1
            if received == 1:  # mid-render: the other tiles are queued or running
                os.kill(victim, signal.SIGKILL)
        assert received == len(rects)
        # the killed process left the cluster (its nanny may have started a new one)
        deadline = time.monotonic() + TIMEOUT
        while victim in c.run(os.getpid).values():
            assert time.monotonic() < deadline, "the killed worker is still listed"
            time.sleep(0.1)
    assert np.array_equal(img, expected)


class Interrupted(Exception):
    """A crash simulated after some tiles."""


def count_tiles(monkeypatch) -> list[tuple]:
    """Make the local engine record each tile it renders."""
    calls: list[tuple] = []
    trace_rect = br.trace_rect

    def spy(prog, cam, lights, settings, x0, y0, x1, y1, *stop):
        calls.append((x0, y0, x1, y1))
        return trace_rect(prog, cam, lights, settings, x0, y0, x1, y1, *stop)

    monkeypatch.setattr(br, "trace_rect", spy)
    return calls


def interrupt_after(monkeypatch, k: int) -> None:
    """Make a checkpointed render crash once ``k`` tiles are saved."""
    save = Checkpoint.save

    def crash(self, rect, pixels):
        if len(list(self.directory.glob("tile-*.npy"))) >= k:
            raise Interrupted
        save(self, rect, pixels)

    monkeypatch.setattr(Checkpoint, "save", crash)


def tile_files(directory) -> dict[str, int]:
    return {p.name: p.stat().st_mtime_ns for p in directory.glob("tile-*.npy")}


def test_resume_skips_finished_tiles(tmp_path, monkeypatch, local_image):
    ckpt = tmp_path / "ckpt"
    total = len(list(tiles(RENDER["width"], RENDER["height"], RENDER["tile"])))
    with monkeypatch.context() as m:
        interrupt_after(m, 5)
        with pytest.raises(Interrupted):
            bt.render(scene(), **RENDER, checkpoint=ckpt)
    saved = tile_files(ckpt)
    assert len(saved) == 5
    with pytest.raises(ValueError, match="resume"):  # never silently overwritten
        bt.render(scene(), **RENDER, checkpoint=ckpt)
    with monkeypatch.context() as m:
        redone = count_tiles(m)
        img = bt.render(scene(), **RENDER, checkpoint=ckpt, resume=True)
    assert len(redone) == total - 5
    assert not {"tile-{}-{}-{}-{}.npy".format(*r) for r in redone} & set(saved)
    assert np.array_equal(img, local_image)
    after = tile_files(ckpt)
    assert len(after) == total and all(after[k] == t for k, t in saved.items())


def test_resume_cuts_the_image_as_the_interrupted_render_did(tmp_path, monkeypatch):
    """The default tile side depends on the cores; a render resumed with other cores still cuts
    the image as the interrupted one did (the side is in the manifest), so it redoes only the
    tiles not finished."""
    monkeypatch.setattr(br, "TILE_SIDES", (16, 8))
    monkeypatch.setattr(br, "TILES_PER_THREAD", 4)
    ckpt, size = tmp_path / "ckpt", dict(width=64, height=32)
    assert br.tile_side(64, 32, 1) == 16 and br.tile_side(64, 32, 8) == 8
    with monkeypatch.context() as m:
        interrupt_after(m, 3)
        with pytest.raises(Interrupted):
            bt.render(scene(), **size, threads=1, checkpoint=ckpt)
    with monkeypatch.context() as m:
        redone = count_tiles(m)
        img = bt.render(scene(), **size, threads=8, checkpoint=ckpt, resume=True)
    assert len(redone) == 8 - 3 and all(x1 - x0 == 16 for x0, _, x1, _ in redone)
    assert np.array_equal(img, bt.render(scene(), **size, threads=8))


def test_resume_on_the_cluster(tmp_path, monkeypatch, client, local_image):
    ckpt = tmp_path / "ckpt"
    with monkeypatch.context() as m:
        interrupt_after(m, 4)
        with pytest.raises(Interrupted):
            bt.render(scene(), **RENDER, checkpoint=ckpt, scheduler=client)
    saved = tile_files(ckpt)
    assert len(saved) == 4
    lost = sorted(saved)[0]
    (ckpt / lost).unlink()  # a lost tile is simply redone
    img = bt.render(scene(), **RENDER, checkpoint=ckpt, resume=True, scheduler=client)
    assert np.array_equal(img, local_image)
    after = tile_files(ckpt)
    assert lost in after and all(after[k] == t for k, t in saved.items() if k != lost)


def test_checkpoint_of_another_job_is_refused(tmp_path):
    ckpt = tmp_path / "ckpt"
    bt.render(scene(), 16, 16, tile=8, checkpoint=ckpt)
    with pytest.raises(ValueError, match="another job"):
        bt.render(scene(), 16, 16, tile=8, samples=2, checkpoint=ckpt, resume=True)
    with pytest.raises(ValueError, match="checkpoint"):
        bt.render(scene(), 16, 16, resume=True)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_bad_scheduler_gives_a_clear_error(monkeypatch):
    monkeypatch.setattr(bd, "CONNECT_TIMEOUT", 1.0)
    address = f"tcp://127.0.0.1:{free_port()}"
    with pytest.raises(ValueError, match=f"scheduler '{address}': cannot connect"):
        bt.render(scene(), 16, 16, scheduler=address)
    with pytest.raises(ValueError, match="scheduler must be an address"):
        bt.render(scene(), 16, 16, scheduler=8786)
    with pytest.raises(ValueError, match="needs a BlobTree node"):
        bt.render(scene().program(), 16, 16, scheduler=address)
    result = CliRunner().invoke(main, ["render", "whorl126", "--size", "16x16",
                                       "--scheduler", address, "-o", "x.png"])
    assert result.exit_code != 0 and "cannot connect" in result.output


def test_cli_on_a_cluster_with_checkpoint(tmp_path, client, local_image):
    scene_file = tmp_path / "scene.json"
    bt.save(scene(), scene_file)
    out = tmp_path / "out.png"
    args = ["render", str(scene_file), "--size", "72x48", "--samples", "2", "--tile", "16",
            "-o", str(out), "--scheduler", client.scheduler.address,
            "--checkpoint", str(tmp_path / "ckpt")]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    assert f"cluster: {client.scheduler.address}, 2 workers" in result.output
    from PIL import Image

    assert np.array_equal(np.asarray(Image.open(out)), local_image)
    resumed = CliRunner().invoke(main, [*args, "--resume"])
    assert resumed.exit_code == 0, resumed.output
    result = CliRunner().invoke(main, ["render", "whorl126", "--resume", "-o", str(out)])
    assert result.exit_code != 0 and "--checkpoint" in result.output
