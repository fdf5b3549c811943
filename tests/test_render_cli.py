"""``blobtree render``: scenes to images from the command line."""

from __future__ import annotations

import sys

import numpy as np
from click.testing import CliRunner
from PIL import Image

import blobtree as bt
from blobtree.cli.main import main


def test_render_builtin_model(tmp_path):
    out = tmp_path / "w.png"
    r = CliRunner().invoke(main, ["render", "whorl126", "-o", str(out), "--size", "40x30",
                                  "--quiet"])
    assert r.exit_code == 0, r.output
    img = np.asarray(Image.open(out))
    assert img.shape == (30, 40, 3)
    assert (img != 255).any()  # something besides the white background


def test_render_scene_file_with_camera_options(tmp_path):
    scene = tmp_path / "s.json"
    bt.save(bt.Point(radius=2.0).color((0.0, 1.0, 0.0)), scene)
    out = tmp_path / "s.png"
    r = CliRunner().invoke(main, ["render", str(scene), "-o", str(out), "--size", "33x33", "--eye",
                                    "0,0,4", "--target", "0,0,0", "--fov", "40", "--background",
                                    "0,0,0", "--samples", "2", "--no-shadows", "--quiet"])
    assert r.exit_code == 0, r.output
    img = np.asarray(Image.open(out)).astype(int)
    assert (img[0, 0] == 0).all()
    assert img[16, 16, 1] > 100 and img[16, 16, 0] < 60


def test_render_bad_arguments_are_clear_errors(tmp_path):
    out = tmp_path / "x.png"
    for args, words in [
        (["--size", "20x0"], "height"),
        (["--size", "big"], "WIDTHxHEIGHT"),
        (["--fov", "200"], "fov"),
        (["--eye", "1,2"], "3 comma-separated"),
        (["--background", "255,0,0"], "background"),
        (["--samples", "0"], "samples"),
    ]:
        r = CliRunner().invoke(main, ["render", "whorl126", "-o", str(out), "--quiet", *args])
        assert r.exit_code != 0 and words in r.output, (args, r.output)
    assert not out.exists()
    r = CliRunner().invoke(main, ["render", "no-such-model", "-o", str(out), "--quiet"])
    assert r.exit_code != 0 and "whorl126" in r.output


def test_progress_and_timing_are_shown_unless_quiet(tmp_path):
    out = tmp_path / "p.png"
    r = CliRunner().invoke(main, ["render", "whorl126", "-o", str(out), "--size", "64x48", "--tile",
                                    "16"])
    assert r.exit_code == 0, r.output
    assert "tile" in r.output  # the progress bar counts tiles
    assert f"{out}: 64x48," in r.output


def test_ctrl_c_stops_the_render_and_writes_nothing(tmp_path, monkeypatch):
    """Ctrl-C in the middle of a render (here: in the third tile) ends the command with code
    130, says so, and leaves no image behind; with --checkpoint it names where the finished
    tiles are kept."""
    render_module = sys.modules["blobtree.render"]  # (bt.render is the function)
    trace_rect = render_module.trace_rect
    done = []

    def interrupted(*args):
        if len(done) >= 2:
            raise KeyboardInterrupt
        done.append(1)
        return trace_rect(*args)

    monkeypatch.setattr(render_module, "trace_rect", interrupted)
    out = tmp_path / "c.png"
    args = ["whorl126", "-o", str(out), "--size", "64x64", "--tile", "16", "--quiet"]
    r = CliRunner().invoke(main, ["render", *args])
    assert r.exit_code == 130 and "interrupted; nothing written" in r.output
    assert not out.exists()
    done.clear()
    r = CliRunner().invoke(main, ["render", *args, "--checkpoint", str(tmp_path / "ck")])
    assert r.exit_code == 130 and "--resume" in r.output and not out.exists()


def test_looks_from_the_command_line(tmp_path):
    """--look picks the style (the studio backdrop fades toward the bottom, the paper look is
    plain white), --background makes any look's backdrop plain, a bad look is refused."""
    scene = tmp_path / "s.json"
    bt.save(bt.Point(radius=2.0).color((0.9, 0.5, 0.2)), scene)

    def corners(*args):
        out = tmp_path / "l.png"
        r = CliRunner().invoke(main, ["render", str(scene), "-o", str(out), "--size", "24x40",
                                      "--quiet", *args])
        assert r.exit_code == 0, r.output
        img = np.asarray(Image.open(out)).astype(int)
        return img[0, 0], img[-1, 0]

    top, bottom = corners()  # studio by default
    assert top.sum() > bottom.sum() + 60
    top, bottom = corners("--look", "paper")
    assert top.tolist() == bottom.tolist() == [255, 255, 255]
    top, bottom = corners("--look", "glossy", "--background", "0.2,0.4,0.6")
    assert top.tolist() == bottom.tolist() == [51, 102, 153]
    r = CliRunner().invoke(main, ["render", str(scene), "--look", "shiny"])
    assert r.exit_code == 2 and "shiny" in r.output


def test_figures_command_takes_a_look(tmp_path):
    r = CliRunner().invoke(main, ["figures", "-o", str(tmp_path), "--only", "3", "--height", "32",
                                  "--samples", "1", "--look", "paper"])
    assert r.exit_code == 0, r.output
    img = np.asarray(Image.open(tmp_path / "figure-3.png"))
    assert img.shape[0] == 32 and img[0, 0].tolist() == [255, 255, 255]
