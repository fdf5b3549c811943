"""Modelling live: the explorer's controls drive the spec and the picture, the watcher renders a
spec file again when it is saved and survives a broken one (docs/live.md)."""

from __future__ import annotations

import gc
import io
import os
import threading
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import blobtree as bt
from blobtree.checks import Integer, Number
from blobtree.cli.main import main
from blobtree.cli.watch_cmd import Watcher
from blobtree.live import DRAFT, LiveShell, View, slider_range, with_control
from blobtree.models.spec import SHELLS, load_spec
from blobtree.render import tile_side, tiles
from blobtree.runtime.threads import threads

pytest.importorskip("ipywidgets", reason="the test extra installs ipywidgets")

MUREX = SHELLS["murex"]
#: A small shell: two whorls, no opening, plain colours (fast to build and draw).
SMALL = replace(MUREX, whorls=2, table_1=MUREX.table_1[:2], canal_sections=0, table_2=(),
                opening=False, texture="plain", bump_sets=0, varices_down_canal=0.0)


def _png(data: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(data)).convert("RGB"))


@pytest.fixture
def explorer():
    ex = bt.explore(SMALL, size=48, coarse=32, settle=0.0)
    assert ex.wait()
    yield ex
    ex.close()


def test_a_control_changes_the_spec_and_the_picture(explorer):
    before, drawn = explorer.image.value, explorer.pictures
    assert _png(before).shape == (48, 48, 3)
    explorer.controls["whorls.point_scale[0]"].value = 1.6
    assert explorer.wait()
    assert explorer.spec.point_scale[0] == 1.6
    assert explorer.spec == replace(SMALL, point_scale=(1.6, *SMALL.point_scale[1:]))
    assert explorer.pictures == drawn + 2  # coarse, then full size
    assert _png(explorer.image.value).shape == (48, 48, 3)
    assert explorer.image.value != before


def test_the_sharp_picture_is_shown_as_its_tiles_finish(explorer, monkeypatch):
    """After the draft, the sharp picture: while it is drawn, glimpses show its finished tiles
    over the draft scaled to its size; each pixel of a glimpse is the scaled draft's or the
    final picture's, and more of them are the final's with each tile."""
    monkeypatch.setattr(bt.live, "GLIMPSE", 0.0)  # a glimpse for every tile
    assert explorer.passes == [(32, DRAFT), (48, {})]
    shown: list[np.ndarray] = []
    said: list[str] = []
    explorer.image.observe(lambda change: shown.append(_png(change["new"])), names="value")
    explorer.status.observe(lambda change: said.append(change["new"]), names="value")
    explorer.controls["canal.tilt"].value = 40.0
    assert explorer.wait()
    draft, *glimpses, final = shown
    assert draft.shape == (32, 32, 3) and final.shape == (48, 48, 3)
    side = tile_side(48, 48, threads())
    assert len(glimpses) == len(list(tiles(48, 48, side)))
    scaled = np.asarray(Image.fromarray(draft).resize((48, 48), Image.Resampling.BILINEAR))
    done = [(g == final).all(axis=2) for g in glimpses]
    for g, d in zip(glimpses, done, strict=True):
        assert (d | (g == scaled).all(axis=2)).all()
    counts = [d.sum() for d in done]
    assert counts == sorted(counts) and done[-1].all()
    assert not done[0].all()
    assert [f"48x48: {k} of {len(glimpses)} tiles" in text for k, text in
            enumerate(said[-len(glimpses) - 1:-1], 1)] == [True] * len(glimpses)


def test_an_unchanged_control_gives_no_new_work(explorer):
    drawn, built = explorer.pictures, dict(explorer.live._kept)
    explorer.controls["canal.tilt"].value = SMALL.canal_tilt
    explorer.controls["turn"].value = 0.0
    assert explorer.wait() and explorer.pictures == drawn
    assert list(explorer.live._kept) == list(built)  # nothing built, nothing dropped
    assert all(explorer.live._kept[k] is v for k, v in built.items())


def test_a_picture_stops_when_the_controls_change(explorer):
    from blobtree.live import _Stale

    with pytest.raises(_Stale):  # a source for an older change draws nothing
        explorer.live.picture(48, 48, source=explorer._tiles(explorer._wanted - 1))
    sharp = explorer.live.picture(48, 48, source=explorer._tiles(explorer._wanted))
    # ... but a draft is drawn whole (while a slider is dragged, each one shows it moving)
    draft = explorer.live.picture(48, 48, source=explorer._tiles(explorer._wanted - 1, False))
    assert (draft == sharp).all()
    drawing = explorer._stop  # (the flag of the picture just drawn, as of one being drawn)
    assert drawing[0] == 1  # (set as its tiles were closed)
    drawing[0] = 0
    explorer.controls["canal.tilt"].value = 41.0
    assert drawing[0] == 1  # a change stops the tiles being traced at their next packet
    assert explorer.wait()


def test_closing_stops_the_picture_being_drawn():
    ex = bt.explore(SMALL, size=48, coarse=32, settle=0.0)
    assert ex.wait()
    drawing = ex._stop
    drawing[0] = 0  # (as while a picture is drawn)
    ex.close()
    assert drawing[0] == 1 and not ex._thread.is_alive()


def test_an_idle_explorer_collects_garbage(explorer):
    """Full collections fall while nothing is drawn, not in the next change's picture."""
    full: list[str] = []

    def seen(phase: str, info: dict) -> None:
        if phase == "start" and info["generation"] == 2:
            full.append(threading.current_thread().name)

    gc.callbacks.append(seen)
    try:
        explorer.controls["canal.tilt"].value = SMALL.canal_tilt + 5.0
        assert explorer.wait()
        deadline = time.monotonic() + 10.0
        while "blobtree-explore" not in full and time.monotonic() < deadline:
            time.sleep(0.01)
    finally:
        gc.callbacks.remove(seen)
    assert "blobtree-explore" in full


def test_what_an_idle_explorer_keeps_is_left_out_of_collections_until_closed():
    """The idle collection freezes what survives it (the next one walks only what is new);
    closing the explorer hands it back to the collector."""
    gc.unfreeze()
    ex = bt.explore(SMALL, size=48, coarse=32, settle=0.0)
    try:
        assert ex.wait()
        deadline = time.monotonic() + 10.0
        while gc.get_freeze_count() == 0 and time.monotonic() < deadline:
            time.sleep(0.01)
        frozen = gc.get_freeze_count()
        assert frozen > 0
        ex.controls["canal.tilt"].value = SMALL.canal_tilt + 5.0
        assert ex.wait()
        while gc.get_freeze_count() == frozen and time.monotonic() < deadline:
            time.sleep(0.01)
        assert gc.get_freeze_count() > frozen  # (the new build's survivors frozen too)
    finally:
        ex.close()
    assert gc.get_freeze_count() == 0


def test_the_view_turns_without_rebuilding_the_shell(explorer):
    before = explorer.image.value
    explorer.controls["turn"].value = 90.0
    assert explorer.wait()
    assert explorer.live.timings["tree"] == 0.0 and explorer.live.timings["program"] == 0.0
    assert explorer.image.value != before


def test_a_refused_value_is_shown_and_the_picture_kept(explorer):
    drawn, spec = explorer.pictures, explorer.spec
    explorer.controls["opening.previous_whorl[1]"].value = 0  # first > last
    assert explorer.wait() and explorer.pictures == drawn and explorer.spec == spec
    assert "opening.previous_whorl must be (first, last)" in explorer.status.value


def test_controls_cover_the_spec_grouped_by_table_and_save_it(explorer, tmp_path):
    c = explorer.controls
    assert c["spiral.beta"].min == 0.1 and c["spiral.beta"].max == 90.0  # the kind's range
    assert type(c["bumps.join"]).__name__ == "Dropdown"
    assert list(c["bumps.join"].options) == ["super_elliptic", "gradient"]
    assert type(c["canal.fuse"]).__name__ == "Checkbox"
    assert type(c["look.colours[0]"]).__name__ == "ColorPicker"
    c["look.colours[0]"].value = "#ff0000"
    assert explorer.wait() and explorer.spec.colours[0] == (1.0, 0.0, 0.0)
    titles = explorer.widget.children[1].children[-1].titles
    assert titles[:3] == ("spiral", "whorls", "canal")
    path = explorer.save(tmp_path / "mine.toml")
    assert load_spec(path) == explorer.spec
    with pytest.raises(ValueError, match="path must end in .toml"):
        explorer.save(tmp_path / "mine.txt")


def test_with_control_and_slider_ranges():
    assert with_control(MUREX, "canal.base[1]", 0.5).canal_base == (MUREX.canal_base[0], 0.5)
    assert with_control(MUREX, "spiral.rho", 1.5).spiral.rho == 1.5
    fewer = with_control(MUREX, "whorls.count", 5)
    assert fewer.whorls == 5 and fewer.table_1 == MUREX.table_1[:5]
    more = with_control(MUREX, "whorls.count", 8)
    assert more.table_1 == MUREX.table_1 + MUREX.table_1[-1:]
    with pytest.raises(ValueError, match=r"spiral.beta must be a finite number >= 0.1"):
        with_control(MUREX, "spiral.beta", 0.0)
    with pytest.raises(ValueError, match="control must be one of"):
        with_control(MUREX, "varices.table", ())
    assert slider_range(Number(1.0, 89.0), 30.0) == (1.0, 89.0)
    assert slider_range(Number(1e-6, 1e6), 0.5) == (1e-6, 2.0)
    assert slider_range(Integer(0, 10_000), 108) == (0, 216)
    with pytest.raises(ValueError, match="explore takes coarse, settle and path"):
        bt.explore(SMALL, shadows=False)


def test_a_view_turns_about_the_axis_and_tilts_toward_the_apex():
    up, along = (0.0, 1.0, 0.0), (1.0, 0.0, 0.0)
    assert np.allclose(View().direction(up, along), along)
    assert np.allclose(View(turn=90.0).direction(up, along), (0.0, 0.0, -1.0))
    assert np.allclose(View(tilt=30.0).direction(up, along), (0.866025, -0.5, 0.0), atol=1e-6)
    with pytest.raises(ValueError, match="tilt must be a finite number >= -80 and <= 80"):
        View(tilt=90.0)


def test_live_shell_keeps_what_it_built():
    live = LiveShell(SMALL)
    live.picture(24, 24, shadows=False)
    assert live.timings["tree"] > 0.0
    assert not live.set(SMALL)
    live.picture(24, 24, View(turn=40.0), shadows=False)
    assert live.timings["tree"] == live.timings["program"] == 0.0


def test_the_draft_is_the_sharp_picture_but_for_the_thinnest_features(explorer):
    """The first picture of a change takes a whole pixel as a camera ray's smallest step, where
    the sharp ones take half a pixel: features thinner than that along a ray may go, and only
    they (a few pixels differ; a step of 8 pixels loses far more)."""
    assert explorer.passes[0] == (32, DRAFT) and DRAFT["step"] == 1.0
    live = LiveShell(SMALL)
    sharp = live.picture(64, 64, shadows=False).astype(int)

    def off(step: float) -> int:
        img = live.picture(64, 64, shadows=False, step=step).astype(int)
        return int((np.abs(img - sharp).max(axis=2) > 8).sum())

    assert off(0.5) == 0
    assert off(DRAFT["step"]) <= 0.002 * 64 * 64 < off(8.0)


def test_a_program_compiled_with_reuse_is_the_one_compiled_afresh():
    from blobtree.engine.program import Reuse, compile_tree

    textured = replace(SMALL, texture="paper")  # with images, whose places copies rely on
    reuse = Reuse()
    compile_tree(bt.models.shell(textured), reuse)
    for spec, seed in ((replace(textured, spine_length=1.0), 0),
                       (replace(textured, point_radius=1.3), 0),
                       (replace(textured, spine_length=1.0), 1)):  # other images: no copies
        reused = compile_tree(bt.models.shell(spec, seed), reuse)
        fresh = compile_tree(bt.models.shell(spec, seed))
        for name in ("code", "params", "boxes", "lips"):
            assert np.array_equal(getattr(reused, name), getattr(fresh, name)), name
        for a, b in zip(reused.bounds, fresh.bounds, strict=True):
            assert np.array_equal(a, b)
        assert reused.depth == fresh.depth and len(reuse.spans) > 10


@pytest.mark.parametrize("spec, first, then", [
    (SMALL, ("whorls.point_radius", 1.3), ("varices.spine_length", 1.0)),
    (replace(SMALL, bump_sets=1, canal_sections=1), ("bumps.size", 0.2),
     ("whorls.point_radius", 1.3)),
])
def test_what_a_change_compiles_again_does_not_depend_on_the_changes_before(monkeypatch, spec,
                                                                            first, then):
    """A part copied whole by one compile is still there in parts for the next, its groups'
    splits with it: after a change of one control (the varices, or the bumps, copied whole), a
    change of another compiles again what it compiles right after the first change was
    compiled afresh, and splits the same groups."""
    from blobtree.engine import program
    from blobtree.engine.program import Reuse, compile_tree

    made, splits = [], []
    emit_new, split = program._Emitter.emit_new, program._split
    monkeypatch.setattr(program._Emitter, "emit_new",
                        lambda self, node, M, look: made.append(node) or emit_new(self, node, M,
                                                                                   look))
    monkeypatch.setattr(program, "_split", lambda boxes: splits.append(boxes) or split(boxes))
    changed = with_control(spec, *first)
    both = with_control(changed, *then)
    counts = []
    for history in ((spec, changed), (changed,)):
        reuse = Reuse()
        for step in history:
            compile_tree(bt.models.shell(step), reuse)
        made.clear()
        splits.clear()
        compile_tree(bt.models.shell(both), reuse)
        counts.append((len(made), len(splits)))
    assert counts[0] == counts[1]  # the same subtrees emitted anew, the same groups split
    assert counts[0][0] < 0.5 * len(compile_tree(bt.models.shell(both)).code)


def test_boxes_handed_on_do_not_grow_with_the_changes():
    """A spiral changed again and again puts every subtree in new frames: the boxes each compile
    hands to the next stay within (1 + HANDED_BOXES) times what one compile makes, not one more
    set per change."""
    from blobtree.engine.program import HANDED_BOXES, Reuse, compile_tree

    def boxes(tree) -> int:  # entries of the distinct box memos of the tree's nodes
        memos = {id(m): m for m in (n.box_memo() for n in tree.unique())}
        return sum(len(m) for m in memos.values())

    reuse, totals = Reuse(), []
    for k in range(8):
        tree = bt.models.shell(with_control(SMALL, "spiral.beta", 20.0 + k))
        compile_tree(tree, reuse)
        totals.append(boxes(tree))
    assert max(totals) <= (1 + HANDED_BOXES) * totals[0]



def test_kept_parts_placed_anew_do_not_gather_frames():
    """A spiral changed again and again places the very nodes of the parts kept (the pieces
    in their local frames) in new frames: tidied between changes (as the explorer and the
    watcher do while idle), their memos by frame hold the frames of the last compiles, not one
    more set per change; the program is still the one compiled afresh."""
    from blobtree.engine.program import compile_tree
    from blobtree.nodes.node import FRAME_MEMOS

    def frames(tree) -> int:  # entries of the distinct memos by frame of the tree's nodes
        memos = {id(m): m for n in tree.unique() for name in FRAME_MEMOS
                 if (m := n.__dict__.get(name)) is not None}
        return sum(isinstance(key, bytes) for m in memos.values() for key in m)

    live, totals = LiveShell(SMALL), []
    for k in range(6):
        live.set(with_control(SMALL, "spiral.beta", 20.0 + k))
        live.camera(32, 32)
        live.tidy()
        built = live._built((live.spec, live.seed))
        totals.append(frames(built.tree))
    fresh = compile_tree(bt.models.shell(live.spec))
    for name in ("code", "params", "boxes", "lips"):
        assert np.array_equal(getattr(built.prog, name), getattr(fresh, name)), name
    assert max(totals) <= 1.05 * totals[0]


def test_tidying_keeps_the_frames_asked_for_since_the_mark():
    """Of a memo by frame touched since the mark, the frames asked for since stay (asked
    again or new), the others go; an untouched memo keeps them all."""
    from blobtree import geometry as geo
    from blobtree.nodes.node import drop_older_frames, frames_kept, mark_frames

    moved = [geo.affine(np.eye(3), (float(k), 0.0, 0.0)) for k in range(3)]
    touched, left = bt.Point(radius=1.0), bt.Point(radius=2.0)
    for node in (touched, left):
        for M in moved[:2]:
            node.box(M)
    memos = mark_frames([touched, left])
    assert frames_kept(left.box_memo()) == 2  # (the mark is not a frame)
    touched.box(moved[0])  # asked again
    touched.box(moved[2])  # new
    drop_older_frames(memos)
    assert list(touched.box_memo()) == [moved[0].tobytes(), moved[2].tobytes()]
    assert list(left.box_memo()) == [moved[0].tobytes(), moved[1].tobytes()]
    assert np.array_equal(touched.box(moved[1])[0], [0.0, -1.0, -1.0])

# ----- blobtree watch ------------------------------------------------------------------------
def _write(path: Path, text: str) -> None:
    path.write_text(text)
    stamp = path.stat().st_mtime_ns + 10_000_000  # as a later save (coarse file clocks)
    os.utime(path, ns=(stamp, stamp))


def test_the_watcher_renders_on_a_change_and_survives_a_broken_file(tmp_path):
    spec, out, said = tmp_path / "mine.toml", tmp_path / "preview.png", []
    _write(spec, bt.models.spec.to_toml(SMALL))
    w = Watcher(spec, out, 48, 40, say=said.append, shadows=False)
    assert w.poll() and np.asarray(Image.open(out)).shape == (40, 48, 3)
    assert not w.poll()  # no change, no work
    first = out.read_bytes()
    _write(spec, spec.read_text().replace("tilt = 55.0", "tilt = 55.0\ntilt = 1"))
    assert not w.poll()
    assert said[-1].startswith(f"{spec}: not valid TOML") and said[-1].endswith(
        f"; keeping {out}") and "\n" not in said[-1]
    _write(spec, spec.read_text().replace("\ntilt = 1", "").replace(
        "sets = 0", "sets = -1"))
    assert not w.poll() and "bumps.sets must be an integer in [0, 64], got -1" in said[-1]
    assert out.read_bytes() == first  # the last good picture kept
    _write(spec, bt.models.spec.to_toml(replace(SMALL, point_radius=1.3)))
    assert w.poll() and out.read_bytes() != first
    _write(spec, bt.models.spec.to_toml(replace(SMALL, point_radius=1.3)))
    assert not w.poll()  # saved again without a change to the spec


def test_a_save_while_the_watcher_draws_stops_the_picture(tmp_path, monkeypatch):
    """The file saved again while its picture is drawn: the picture stops (nothing written),
    the watcher says so, and the next poll draws the new spec."""
    import blobtree.cli.watch_cmd as watch_module

    spec, out, said = tmp_path / "mine.toml", tmp_path / "preview.png", []
    _write(spec, bt.models.spec.to_toml(SMALL))
    load, tiles_of = watch_module.models.load_spec, watch_module.local_tiles

    def load_then_save(path):  # the editor saves just after the watcher read the file
        loaded = load(path)
        _write(spec, bt.models.spec.to_toml(replace(SMALL, point_radius=1.3)))
        return loaded

    def slow_tiles(*job, threads, stop):  # a picture that takes until the watcher stops it
        deadline = time.monotonic() + 30.0
        while stop[0] == 0 and time.monotonic() < deadline:
            time.sleep(0.005)
        return tiles_of(*job, threads, stop)

    monkeypatch.setattr(watch_module.models, "load_spec", load_then_save)
    monkeypatch.setattr(watch_module, "local_tiles", slow_tiles)
    w = Watcher(spec, out, 48, 40, say=said.append, interval=0.01, shadows=False)
    assert not w.poll() and not out.exists()
    assert said[-1] == f"{spec}: saved again while drawn; drawing the new one"
    monkeypatch.setattr(watch_module.models, "load_spec", load)
    monkeypatch.setattr(watch_module, "local_tiles", tiles_of)
    assert w.poll() and w.live.spec.point_radius == 1.3 and out.exists()


def test_watch_command_refuses_bad_arguments_and_stops_on_ctrl_c(tmp_path, monkeypatch):
    r = CliRunner().invoke(main, ["watch", "scene.json"])
    assert r.exit_code == 2 and "expected a shell spec file (.toml)" in r.output
    r = CliRunner().invoke(main, ["watch", "x.toml", "-o", "-"])
    assert r.exit_code == 2 and "give a file name, not -" in r.output
    spec, out = tmp_path / "s.toml", tmp_path / "p.png"
    spec.write_text(bt.models.spec.to_toml(SMALL))

    def interrupt(_):
        raise KeyboardInterrupt

    monkeypatch.setattr("blobtree.cli.watch_cmd.time.sleep", interrupt)
    r = CliRunner().invoke(main, ["watch", str(spec), "-o", str(out), "--size", "32x32",
                                  "--no-shadows"])
    assert r.exit_code == 0, r.output
    assert "p.png: 32x32" in r.output and r.output.rstrip().endswith("stopped")
    assert np.asarray(Image.open(out)).shape == (32, 32, 3)
