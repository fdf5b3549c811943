"""The figure models of blobtree.models.figures: one tree per figure, camera and caption."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

import blobtree as bt
from blobtree.models import figures as F
from blobtree.render.camera import framed_camera

# the module, not the murex() function a package export may shadow it with
M = importlib.import_module("blobtree.models.murex")


def count(node: bt.Node, kind: type) -> int:
    return sum(isinstance(n, kind) for n in node.walk())


def test_registry_covers_the_paper_figures_that_show_a_model():
    assert list(F.FIGURES) == ["3", "4", "5", "6", "7", "8", "9", "10", "11", "14"]
    paper = open_paper()
    for number, fig in F.FIGURES.items():
        assert fig.caption
        # the caption is the paper's (symbols spelt out): its first words are in the paper
        assert " ".join(fig.caption.split()[:6]) in paper, number


def open_paper() -> str:
    from pathlib import Path

    for base in Path(__file__).resolve().parents:
        p = base / "shared" / "paper" / "murex-cabritii-blobtree.md"
        if p.exists():
            return " ".join(p.read_text().split())
    pytest.skip("paper not found beside the repository")


@pytest.mark.parametrize("number", ["3", "4", "5", "6", "7", "8", "9", "10"])
def test_each_figure_builds_a_tree_its_camera_frames(number):
    fig = F.FIGURES[number]
    tree = fig.build()
    assert isinstance(tree, bt.Node)
    cam = framed_camera(tree.program(), 64, 64, view=fig.view, up=fig.up, fov=fig.fov)
    lo, hi = tree.bounds()
    assert np.all((np.array(cam.target) > lo) & (np.array(cam.target) < hi))
    eye = np.array(cam.eye)
    assert np.any((eye < lo) | (eye > hi))  # outside the model
    assert 0 < cam.fov < 90
    # the model is not empty: its skeleton points are inside
    P = np.random.default_rng(0).uniform(lo, hi, (20000, 3))
    assert np.any(tree.field(P) >= 0.5)


def test_figure_3_blends_pairs_with_n_1_to_10():
    sbs = [n for n in F.figure_3().walk() if isinstance(n, bt.SuperBlend)]
    assert sorted(s.n for s in sbs) == list(range(1, 11))
    assert all(count(s, bt.Point) == 2 for s in sbs)


def test_figure_4_six_points_with_growing_field():
    tree = F.figure_4()
    radii = sorted({p.radius for p in tree.walk() if isinstance(p, bt.Point)})
    assert len(radii) == 3 and count(tree, bt.Point) == 18


def test_figure_5_all_blend_versus_controlled():
    left, right = (c.child for c in F.figure_5().children)
    assert isinstance(left, bt.Blend) and isinstance(right, bt.ControlledBlend)
    assert len(left.children) == len(right.children) == 21


def test_figure_7_four_stages_of_a_varix():
    tree = F.figure_7()
    assert count(tree, bt.Torus) == 6  # stages 2-4
    assert count(tree, bt.Cone) == 4 * len(M.TABLE_1[7])


def test_figure_8_plain_versus_super_blend_400():
    tree = F.figure_8()
    sbs = [n for n in tree.walk() if isinstance(n, bt.SuperBlend)]
    assert len(sbs) == 1 and sbs[0].n == 400
    assert count(tree, bt.Point) == 2 * 12 + 2 * 5 * 9


def test_figure_9_straight_versus_bent_canal_spines():
    from blobtree.nodes import Bend

    left, right = (c.child for c in F.figure_9().children)
    assert count(right, Bend) - count(left, Bend) >= 17


def test_figures_11_and_14_are_the_shell():
    assert count(F.figure_14(), bt.Primitive) == count(M.murex(0), bt.Primitive)
    left, right = (c.child for c in F.figure_11().children)
    assert left.key == M.murex(0, inside=False).key  # Eq. 14 only
    assert right.key == M.murex(0).key  # with the inside wall, Eq. 15
    assert count(right, bt.Primitive) > count(left, bt.Primitive)


def test_walls_figure_shows_both_forms_of_eq_15():
    left, right = (c.child for c in F.walls_figure().children)
    assert left.key == M.murex(0, textured=False).key  # clipped, the shipped spec's
    assert right.key == M.murex(0, textured=False, wall_join="union").key
    assert left.key != right.key


def test_canal_figure_adds_only_the_ridges():
    left, right = (c.child for c in F.canal_figure().children)
    ridges = count(right, bt.Cone) - count(left, bt.Cone)
    assert ridges == 4 * len(M.DEFAULT.tori)  # the four canal sections' varices, a cone per torus
    assert count(left, bt.Torus) == count(right, bt.Torus) == 4 * len(M.DEFAULT.tori)
