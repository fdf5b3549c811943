"""Writing outputs the way Unix tools do (blobtree/output.py): a symlink's target is written
whole or not at all and the link kept; a FIFO or a device is written into, never replaced;
``-o -`` is standard output, with nothing else on it; a write error is one line and exit code 1.
Every command and every save function goes through the same code, so each case is checked
through all of them."""

from __future__ import annotations

import os
import stat
import threading
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import blobtree as bt
from blobtree.cli.main import main
from blobtree.mesh.web import save_page
from blobtree.output import write_file

FULL = Path("/dev/full")
needs_dev_full = pytest.mark.skipif(not FULL.exists() or not FULL.is_char_device(),
                                    reason="no /dev/full (a device that is always full) here")


class Reader(threading.Thread):
    """Reads a FIFO to its end, as another program would (started before the writer opens it:
    opening a FIFO waits for the other end)."""

    def __init__(self, path: Path):
        super().__init__(daemon=True)
        self.path, self.data = path, b""

    def run(self) -> None:
        with open(self.path, "rb") as fh:
            self.data = fh.read()

    def result(self) -> bytes:
        self.join(timeout=120)
        assert not self.is_alive(), "the writer never opened the FIFO"
        return self.data


def fifo(tmp_path: Path, name: str = "pipe") -> tuple[Path, Reader]:
    path = tmp_path / name
    os.mkfifo(path)
    reader = Reader(path)
    reader.start()
    return path, reader


def linked(tmp_path: Path, name: str) -> tuple[Path, Path]:
    """A symlink ``name`` to ``real/name`` (which does not exist yet)."""
    (tmp_path / "real").mkdir()
    link, target = tmp_path / name, tmp_path / "real" / name
    link.symlink_to(target)
    return link, target


# --- write_file itself -------------------------------------------------------------------------

def test_a_symlink_is_followed_and_kept(tmp_path):
    link, target = linked(tmp_path, "out.bin")
    write_file(link, b"first")  # a link to a file not there yet creates it
    write_file(link, b"second")
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert target.read_bytes() == b"second"
    assert sorted(p.name for p in target.parent.iterdir()) == ["out.bin"]  # no temporary left


def test_a_symlinks_target_is_written_whole_or_not_at_all(tmp_path, monkeypatch):
    link, target = linked(tmp_path, "out.bin")
    target.write_bytes(b"old")

    def interrupted(src, dst):
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        write_file(link, b"new")
    assert link.is_symlink() and target.read_bytes() == b"old"
    assert sorted(p.name for p in target.parent.iterdir()) == ["out.bin"]


def test_a_link_into_a_missing_folder_is_refused_naming_both(tmp_path):
    link = tmp_path / "out.png"
    link.symlink_to(tmp_path / "gone" / "x.png")
    with pytest.raises(ValueError, match=r"path '.*out\.png' \(a link to '.*gone/x\.png'\) is "
                                         r"in '.*gone', which does not exist"):
        write_file(link, b"data")
    assert link.is_symlink()


def test_a_fifo_is_written_into_and_stays_a_fifo(tmp_path):
    path, reader = fifo(tmp_path)
    data = bytes(range(256)) * 4096  # 1 MiB: more than a pipe holds at once
    write_file(path, data)
    assert reader.result() == data
    assert stat.S_ISFIFO(os.stat(path).st_mode)


@needs_dev_full
def test_a_full_device_reports_its_error_and_stays_a_device():
    with pytest.raises(OSError, match="cannot write /dev/full: No space left on device"):
        write_file(FULL, b"x" * 100_000)
    assert FULL.is_char_device()


def test_a_dash_is_standard_output(capsysbinary):
    write_file("-", b"\x00bytes\xff")
    assert capsysbinary.readouterr().out == b"\x00bytes\xff"


# --- every save function ---------------------------------------------------------------------

@pytest.fixture(scope="module")
def small_mesh() -> bt.Mesh:
    return bt.polygonize(bt.Point(radius=1.0), resolution=12)


#: save(path) for each save function: bt.save, save_image, Mesh.save, the 3D page
SAVERS = {
    "scene": lambda mesh, path: bt.save(bt.Point(radius=1.0), path),
    "image": lambda mesh, path: bt.save_image(np.full((4, 5, 3), 7, np.uint8), path, "png"),
    "mesh": lambda mesh, path: mesh.save(path, "stl"),
    "page": lambda mesh, path: save_page(mesh, path),
}


@pytest.mark.parametrize("saver", SAVERS)
def test_every_save_function_writes_through_links_fifos_and_stdout(saver, small_mesh, tmp_path,
                                                                   capsysbinary):
    save = SAVERS[saver]
    save(small_mesh, tmp_path / "plain")
    expected = (tmp_path / "plain").read_bytes()
    link, target = linked(tmp_path, "link")
    save(small_mesh, link)
    assert link.is_symlink() and target.read_bytes() == expected
    path, reader = fifo(tmp_path)
    save(small_mesh, path)
    assert reader.result() == expected and stat.S_ISFIFO(os.stat(path).st_mode)
    capsysbinary.readouterr()
    save(small_mesh, "-")
    assert capsysbinary.readouterr().out == expected


def test_standard_output_needs_a_format(small_mesh):
    with pytest.raises(ValueError, match=r"path '-' \(standard output\) needs format: one of png"):
        bt.save_image(np.zeros((2, 2, 3), np.uint8), "-")
    with pytest.raises(ValueError, match="format 'xyz' is not one of ply, obj, stl, glb, 3mf"):
        small_mesh.save("-", "xyz")


# --- every command -----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def scene(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("scene") / "s.json"
    bt.save(bt.Point(radius=1.0) + bt.Point(radius=1.0, center=(0.8, 0, 0)), path)
    return path


#: each command with its options but -o, and the --format it needs when -o names no format
COMMANDS = {
    "render": (["render", "{scene}", "--size", "12x10", "--no-shadows", "--quiet"], "png"),
    "mesh": (["mesh", "{scene}", "-r", "12"], "ply"),
    "view": (["view", "{scene}", "-r", "8"], None),
    "spec": (["spec", "oliva"], None),
}


def run(command: str, scene: Path, output: str | Path, *extra: str):
    args, fmt = COMMANDS[command]
    args = [a.format(scene=scene) for a in args] + ["-o", str(output), *extra]
    if fmt is not None and Path(output).suffix == "":
        args += ["--format", fmt]
    return CliRunner().invoke(main, args)


@pytest.mark.parametrize("command", COMMANDS)
def test_commands_write_to_standard_output_and_nothing_else(command, scene, tmp_path):
    plain = tmp_path / f"out.{COMMANDS[command][1] or 'x'}"
    assert run(command, scene, plain).exit_code == 0
    r = run(command, scene, "-")
    assert r.exit_code == 0, r.output
    assert r.stdout_bytes == plain.read_bytes()  # the file, and nothing else


@pytest.mark.parametrize("command", ["render", "mesh"])
def test_standard_output_without_a_format_is_refused_by_name(command, scene):
    r = CliRunner().invoke(main, [a.format(scene=scene) for a in COMMANDS[command][0]]
                           + ["-o", "-"])
    assert r.exit_code == 2 and "'-' (standard output) needs --format: one of" in r.output
    assert r.stdout_bytes == b""


@pytest.mark.parametrize("command", COMMANDS)
def test_commands_write_through_links_and_into_fifos(command, scene, tmp_path):
    plain = tmp_path / f"out.{COMMANDS[command][1] or 'x'}"
    assert run(command, scene, plain).exit_code == 0
    link, target = linked(tmp_path, f"link{plain.suffix}")
    assert run(command, scene, link).exit_code == 0
    assert link.is_symlink() and target.read_bytes() == plain.read_bytes()
    path, reader = fifo(tmp_path)
    r = run(command, scene, path)
    assert r.exit_code == 0, r.output
    assert reader.result() == plain.read_bytes() and stat.S_ISFIFO(os.stat(path).st_mode)


@needs_dev_full
@pytest.mark.parametrize("command", COMMANDS)
def test_a_full_device_is_a_one_line_error(command, scene):
    r = run(command, scene, FULL)
    assert r.exit_code == 1
    lines = r.stderr.splitlines()
    assert lines[-1] == "Error: cannot write /dev/full: No space left on device"
    assert [line for line in lines if line.startswith("Error")] == lines[-1:]
    assert "Traceback" not in r.output and r.stdout_bytes == b""
    assert FULL.is_char_device()
