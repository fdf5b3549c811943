"""Group controlled blends (beyond the paper's pairs, its Section 4): groups of any size, each
blended by the super-elliptic blend of its own exponent; the field is the max over the groups."""

import numpy as np
import pytest

import blobtree as bt

P = np.random.default_rng(3).uniform(-1.5, 2.5, (3000, 3))
KIDS = [bt.Point(radius=1.2, center=c).color(rgb) for c, rgb in [
    ((0.0, 0.0, 0.0), (1, 0, 0)), ((0.9, 0.0, 0.0), (0, 1, 0)), ((0.0, 0.9, 0.0), (0, 0, 1)),
    ((0.9, 0.9, 0.3), (1, 1, 0)), ((2.0, 2.0, 0.0), (0, 1, 1))]]
F = np.stack([k.field(P) for k in KIDS])  # each child's own field


def superelliptic(fs: np.ndarray, n: float) -> np.ndarray:
    """Eq. 4, straight from the formula."""
    return (fs ** n).sum(axis=0) ** (1.0 / n)


def test_groups_follow_the_formula_and_children_in_none_stand_alone():
    tree = bt.controlled_blend(KIDS, groups=[(0, 1, 2), ((2, 3), 4.0)], n=2.0)
    expect = np.max([superelliptic(F[[0, 1, 2]], 2.0), superelliptic(F[[2, 3]], 4.0), F[4]],
                    axis=0)
    np.testing.assert_allclose(tree.field(P), expect, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(tree.reference(P)[0], expect, rtol=1e-12, atol=1e-15)


def test_pairs_are_groups_of_two_with_n_1_and_keep_the_pairs_fields_exactly():
    pairs = bt.controlled_blend(KIDS, pairs=[(0, 1), (1, 2), (3, 4)])
    groups = bt.controlled_blend(KIDS, groups=[(0, 1), (1, 2), (3, 4)])
    expect = np.max([F[0] + F[1], F[1] + F[2], F[3] + F[4]], axis=0)
    assert np.array_equal(pairs.field(P), expect)
    assert np.array_equal(groups.field(P), pairs.field(P))


def test_a_group_with_a_large_exponent_tends_to_the_union():
    union = np.max(F[:4], axis=0)
    f = bt.controlled_blend(KIDS[:4], groups=[((0, 1, 2, 3), 400.0)]).field(P)
    assert np.all(f >= union - 1e-12) and np.all(f <= union * 4 ** (1 / 400) + 1e-12)


def test_colour_is_weighted_by_f_to_the_n_within_the_winning_group():
    tree = bt.controlled_blend(KIDS[:2], groups=[((0, 1), 3.0)])
    c = tree.albedo(P)
    w = F[:2] ** 3.0
    live = w.sum(axis=0) > 1e-9
    expect = (w[0][:, None] * np.array([1, 0, 0]) + w[1][:, None] * np.array([0, 1, 0])) \
        / w.sum(axis=0)[:, None].clip(1e-300)
    np.testing.assert_allclose(c[live], expect[live], rtol=1e-9, atol=1e-9)


def test_gradient_matches_finite_differences():
    tree = bt.controlled_blend(KIDS, groups=[((0, 1, 2), 3.0), (3, 4)])
    Q = P[tree.field(P) > 0.05][:200]
    h = 1e-6
    numeric = np.stack([(tree.field(Q + h * e) - tree.field(Q - h * e)) / (2 * h)
                        for e in np.eye(3)], axis=1)
    np.testing.assert_allclose(tree.gradient(Q), numeric, rtol=1e-4, atol=1e-5)


def test_a_scene_file_keeps_the_groups():
    tree = bt.controlled_blend(KIDS, groups=[(0, 1, 2), ((2, 3), 4.0)], n=2.0)
    assert bt.io.loads(bt.io.dumps(tree)) == tree


@pytest.mark.parametrize("groups, words", [
    ([(0, 7)], "groups[0] must be different child indices in [0, 5)"),
    ([(1, 1)], "groups[0] must be different child indices"),
    ([()], "groups[0] must be a non-empty list"),
    ([((0, 1), 0.5)], "groups[0] exponent must be"),
    ("01", "groups must be a list of index groups"),
    ([("a", 1)], "groups[0] must be a non-empty list of child indices"),
])
def test_bad_groups_are_refused_by_name(groups, words):
    with pytest.raises(ValueError, match=words.replace("[", r"\[").replace("(", r"\(")
                       .replace(")", r"\)")):
        bt.controlled_blend(KIDS, groups=groups)
