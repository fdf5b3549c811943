"""The compiled engine against the numpy reference evaluator, finite differences and bounds."""

from __future__ import annotations

import os

import numpy as np
from hypothesis import example, given
from hypothesis import strategies as st

import blobtree as bt
from tests.conftest import examples
from tests.trees import box_bounds_setup, check_box_bounds, sample_points, trees


@given(trees(), st.integers(0, 2**31))
def test_engine_equals_reference(tree, seed):
    P = sample_points(tree, 400, seed)
    f, g, c = tree.program().evaluate(P)
    fr, gr, cr = tree.reference(P)
    scale = max(1.0, np.abs(gr).max())
    np.testing.assert_allclose(f, fr, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(g, gr, rtol=1e-9, atol=1e-9 * scale)
    live = fr > 1e-9
    np.testing.assert_allclose(c[live], cr[live], rtol=1e-9, atol=1e-9)
    assert np.all((f >= 0.0) & (f <= 1.0 + 1e-12)) or not _is_sum_free(tree)


def test_csg_ties_pick_the_first_child_in_engine_and_reference():
    """Where two children's fields agree up to rounding, a union and an intersection take the
    first child's colour, in the engine and in the reference alike (hypothesis found the two
    picking differently): cones whose end caps coincide (both fields the falloff of |p| where
    y, z < 0), and collinear cones drawn in opposite directions, whose caps meet at the origin
    (fields there down to 0, where rounding is large next to the field)."""
    a = bt.Cone((0, 0, 0), (0, 1, 0), radius_a=1.0, radius_b=1.0)
    b = bt.Cone((0, 0, 1), (0, 0, 0), radius_a=1.0, radius_b=1.0).color((0.0, 0.0, 0.0))
    rng = np.random.default_rng(3)
    P = rng.uniform((-0.6, -0.6, -0.6), (0.6, -0.01, -0.01), (2000, 3))
    cases = [(a & b, P), (a | b, P), (b & a, P)]
    c1 = bt.Cone((0, 0, 0.92), (0, 0, 0), radius_a=1.0, radius_b=1.0)
    c2 = bt.Cone((0, 0, 0), (0, 0, 1), radius_a=1.0, radius_b=1.0).color((0.0, 0.0, 0.0))
    Q = rng.uniform((-1.0, -1.0, -1.0), (1.0, 1.0, -0.01), (4000, 3))  # the shared cap
    cases += [(c1 & c2, Q), (c1 | c2, Q)]
    for tree, P in cases:
        _, _, c = tree.program().evaluate(P)
        _, _, cr = tree.reference(P)
        first = tree.children[0].reference(P)[2]
        np.testing.assert_array_equal(c, cr)
        np.testing.assert_array_equal(cr, first)


def _is_sum_free(tree: bt.Node) -> bool:
    """Trees without blends stay in [0, 1]; sums may exceed 1."""
    sums = bt.Blend | bt.SuperBlend | bt.ControlledBlend | bt.GradientBlend
    return not any(isinstance(n, sums) for n in tree.walk())


@given(trees(smooth_only=True), st.integers(0, 2**31))
def test_gradient_matches_finite_differences(tree, seed):
    P = sample_points(tree, 300, seed, grow=0.0)
    g = tree.gradient(P)

    def fd(h):
        out = np.empty_like(P)
        for k in range(3):
            e = np.zeros(3)
            e[k] = h
            out[:, k] = (tree.field(P + e) - tree.field(P - e)) / (2 * h)
        return out

    g1, g2 = fd(1e-5), fd(5e-6)
    # where two step sizes agree the field is smooth there (no clamp or box edge in reach)
    smooth = np.all(np.abs(g1 - g2) <= 1e-5 * (1 + np.abs(g1)), axis=1)
    assert smooth.mean() > 0.5
    np.testing.assert_allclose(g[smooth], g2[smooth], rtol=1e-4, atol=1e-4)


@given(trees(), st.integers(0, 2**31))
def test_bounds_contain_support(tree, seed):
    P = sample_points(tree, 2000, seed, grow=0.5)
    lo, hi = tree.bounds()
    f = tree.reference(P)[0]
    inside = np.all((P >= lo - 1e-9) & (P <= hi + 1e-9), axis=1)
    assert not np.any((f > 0) & ~inside)


@given(trees(max_leaves=3), st.integers(0, 2**31))
def test_warp_boxes_contain_the_deformed_child(tree, seed):
    """A warp's box is computed from the forward deformation; check it against the child's own
    (unmasked) field at the warped query points."""
    for w in (n for n in tree.walk() if isinstance(n, bt.nodes.Warp)):
        lo, hi = w.own_box
        if np.any(lo > hi):  # an empty child: nothing to contain
            continue
        pad = 0.5 * (hi - lo) + 1e-3
        P = np.random.default_rng(seed).uniform(lo - pad, hi + pad, (3000, 3))
        q, _ = w.warp_points(P)
        f = w.child.reference(q)[0]
        inside = np.all((P >= lo - 1e-9) & (P <= hi + 1e-9), axis=1)
        if isinstance(w, bt.nodes.Bend):  # the bend's query map folds far behind its centre
            c = np.zeros(3)
            c[w.index[1]] = w.sign / w.k
            near = np.linalg.norm(P - c, axis=1) < 2.0 / w.k
            f = np.where(near, f, 0.0)
        assert not np.any((f > 0) & ~inside)


def test_whorl126_engine_matches_reference_everywhere():
    tree = bt.models.whorl126()
    P = sample_points(tree, 5000, 3)
    f, g, _ = tree.program().evaluate(P)
    fr, gr, _ = tree.reference(P)
    np.testing.assert_allclose(f, fr, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(g, gr, rtol=1e-9, atol=1e-9)


def test_lipschitz_bounds_the_gradient():
    tree = (bt.Point(radius=1.0) + bt.Cone((0, 0, 0), (2, 0, 0), 0.6, 0.2).bend(40, 2.0)
            - bt.Point(radius=0.5, center=(0.3, 0.2, 0)))
    prog = tree.program()
    P = sample_points(tree, 20000, 5)
    gn = np.linalg.norm(tree.gradient(P), axis=1)
    assert gn.max() <= prog.lipschitz_global
    lo, hi = prog.bounds
    cells = np.random.default_rng(2).uniform(lo, hi, (200, 3))
    size = 0.2 * (hi - lo)
    local = prog.lipschitz(cells, cells + size)
    for c, lip in zip(cells, local, strict=True):
        Q = np.random.default_rng(0).uniform(c, c + size, (500, 3))
        assert np.linalg.norm(tree.gradient(Q), axis=1).max() <= lip + 1e-12


def test_super_blend_bound_is_the_n_norm_of_its_childrens():
    """A super-elliptic blend is the n-norm of its children's fields, so its Lipschitz bound is
    the n-norm of theirs: near their largest for the paper's n = 400, not their sum; and it
    still bounds the gradient."""
    kids = [bt.Point(radius=1.0, center=(0.2 * i, 0.1 * (i % 3), 0.0)) for i in range(12)]
    tree = bt.super_blend(*kids, n=400.0)
    prog = tree.program()
    lo, hi = np.array([[-0.5, -0.5, -0.5]]), np.array([[2.5, 0.7, 0.5]])
    largest = max(k.program().lipschitz(lo, hi)[0] for k in kids)
    bound = prog.lipschitz(lo, hi)[0]
    assert bound <= largest * 12 ** (1 / 400) * (1 + 1e-12)
    Q = np.random.default_rng(3).uniform(lo[0], hi[0], (20000, 3))
    assert np.linalg.norm(tree.reference(Q)[1], axis=1).max() <= bound
    assert bt.super_blend(*kids, n=2.0).program().lipschitz(lo, hi)[0] <= np.sqrt(
        sum(k.program().lipschitz(lo, hi)[0] ** 2 for k in kids)) * (1 + 1e-12)


def test_engine_skips_far_subtrees():
    """Points far from every box evaluate to exactly 0."""
    tree = bt.models.whorl126()
    P = np.array([[100.0, 0, 0], [0, -50, 0]])
    assert np.all(tree.field(P) == 0.0)


@examples(0.25)
@given(trees(), st.integers(0, 2**31))
def test_specialised_cells_equal_reference(tree, seed):
    """Large batches run per-cell specialised programs (specialize.py): still exact."""
    from blobtree.engine import GRID_MIN_POINTS as BINNED_MIN

    P = sample_points(tree, BINNED_MIN + 5000, seed)
    f, g, c = tree.program().evaluate(P)
    fr, gr, cr = tree.reference(P)
    np.testing.assert_allclose(f, fr, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(g, gr, rtol=1e-9, atol=1e-9 * max(1.0, np.abs(gr).max()))
    live = fr > 1e-9
    np.testing.assert_allclose(c[live], cr[live], rtol=1e-9, atol=1e-9)


@examples(0.25)
@given(trees(), st.integers(0, 2**31))
def test_cell_sorted_batches_equal_reference(tree, seed):
    """Large field-only batches are partitioned by cell and vectorised (batch.py): still exact."""
    from blobtree.engine import GRID_MIN_POINTS

    P = sample_points(tree, GRID_MIN_POINTS + 5000, seed)
    np.testing.assert_allclose(tree.program().field(P), tree.reference(P)[0], rtol=1e-9,
                               atol=1e-12)


def test_cell_sorted_blocks_and_order(monkeypatch):
    """Many partition blocks (the last one partial), points outside the grid, points in cells
    whose program is a lone zero (answered while partitioning) and any order of the points give
    the values of the one-point-at-a-time path: field, gradient and colour."""
    from blobtree.engine import GRID_MIN_POINTS, batch
    from blobtree.engine.specialize import cell_of

    monkeypatch.setattr(batch, "PARTITION_BLOCK", 4096)
    tree = (bt.models.whorl126().bend(30.0, 2.0) | bt.Cone((0, 0, 0), (0, 3, 0), 0.5, 0.2)
            ) - bt.Torus(1.0, radius=0.4)
    prog = tree.program()
    P = sample_points(tree, 50_001, 3, grow=0.5)
    chunks = range(0, len(P), GRID_MIN_POINTS - 1)  # below the grid's threshold: point by point
    one_by_one = [np.concatenate(r) for r in zip(*(prog.evaluate(P[a:a + GRID_MIN_POINTS - 1])
                                                   for a in chunks), strict=True)]
    cells, inside = np.array([cell_of(*p, *prog.grid.frame) for p in P]).T
    dead = inside & (prog.grid.live[cells] == 0)
    assert np.count_nonzero(dead) > 500 and np.count_nonzero(inside == 0) > 500
    f = prog.field(P)
    np.testing.assert_array_equal(f, one_by_one[0])
    for got, want in zip(prog.evaluate(P), one_by_one, strict=True):
        np.testing.assert_array_equal(got, want)
    perm = np.random.default_rng(4).permutation(len(P))
    np.testing.assert_array_equal(prog.field(P[perm]), f[perm])
    assert np.count_nonzero(f) > 1000 and np.count_nonzero(f == 0.0) > 1000


def test_cell_sorted_batches_take_points_far_outside():
    """Infinite, huge and NaN coordinates in a large batch fall outside the grid (the cell
    lookup converts no such value to an integer): infinite and huge ones get a zero field, NaN
    ones NaN, and every point the one-point path's value."""
    from blobtree.engine import GRID_MIN_POINTS

    prog = bt.models.whorl126().program()
    P = sample_points(bt.models.whorl126(), GRID_MIN_POINTS + 5000, 5)
    far = np.zeros(len(P), dtype=bool)
    for axis, step, value in ((0, 7, np.inf), (1, 11, -1e300), (2, 13, np.nan)):
        P[::step, axis] = value
        far[::step] = True
    f = prog.field(P)
    chunks = [prog.field(P[a:a + GRID_MIN_POINTS - 1])
              for a in range(0, len(P), GRID_MIN_POINTS - 1)]
    np.testing.assert_array_equal(f, np.concatenate(chunks))  # (NaN where NaN)
    nan = np.isnan(P).any(axis=1)
    assert np.isnan(f[nan]).all() and np.all(f[far & ~nan] == 0.0)
    assert np.count_nonzero(f[~far]) > 1000


@examples(0.25)
@given(trees(), st.integers(0, 2**31))
def test_points_grouped_by_region_equal_reference(tree, seed):
    """Points grouped by boxes of their own (the mesher's blocks) run each box's specialised
    program, with no sorting (Program.regions, Program.field_grouped): still exact."""
    prog = tree.program()
    P = sample_points(tree, 3000, seed, grow=0.2)
    rng = np.random.default_rng(seed)
    lo, hi = P.min(axis=0), P.max(axis=0)
    # boxes on a random lattice, some holding no point, and the points grouped by box
    dims = rng.integers(1, 5, size=3)
    size = np.maximum(hi - lo, 1e-9) / dims
    cell = np.minimum(((P - lo) / size).astype(np.int64), dims - 1)
    code = (cell[:, 0] * dims[1] + cell[:, 1]) * dims[2] + cell[:, 2]
    index = np.stack(np.meshgrid(*(np.arange(n) for n in dims), indexing="ij"), -1)
    box_lo = lo + index.reshape(-1, 3) * size
    order = np.argsort(code, kind="stable")
    first = np.searchsorted(code[order], np.arange(len(box_lo) + 1))
    f = prog.field_grouped(prog.regions(box_lo, box_lo + size), P[order], first)
    np.testing.assert_allclose(f, tree.reference(P[order])[0], rtol=1e-9, atol=1e-12)


def test_specialised_difference_keeps_its_cap():
    """A difference is min(f_0, 1 - f_1): where the subtrahend is specialised away the result is
    still capped at 1 when the first child's blend exceeds 1 (found by hypothesis)."""
    from blobtree.engine import GRID_MIN_POINTS

    body = bt.Point(radius=1.0) + bt.Point(radius=1.0)
    tree = body - bt.Point(center=(0.3, 0.0, 0.0), radius=0.2)
    P = sample_points(tree, GRID_MIN_POINTS + 5000, 0)
    ref = tree.reference(P)[0]
    assert ref.max() == 1.0 and body.reference(P)[0].max() > 1.5
    np.testing.assert_allclose(tree.program().field(P), ref, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(tree.program().evaluate(P)[0], ref, rtol=1e-9, atol=1e-12)


def _specialised(prog, lo, hi):
    """The program specialised to [lo, hi], as (code, boxes)."""
    from blobtree.engine import specialize as S

    n = len(prog)
    oc, ob, ol = np.empty((n, 4), dtype=np.int64), np.empty((n, 6)), np.empty(n)
    m = S.region_specialize(prog.arrays, np.asarray(lo, float), np.asarray(hi, float),
                            (oc, ob, ol), S.specialize_work(prog.code))
    return oc[:m], ob[:m]


def test_specialised_program_is_short_for_a_small_cell():
    prog = bt.models.whorl126().program()
    lo, hi = prog.bounds
    c = 0.5 * (lo + hi) + np.array([0.9, 0.0, 0.0])
    code, _ = _specialised(prog, c - 0.05, c + 0.05)
    assert 0 < len(code) < len(prog) // 10


def test_specialisation_drops_what_only_an_outer_box_reaches():
    """A ball whose box, not whose support, reaches the region's corner, and a bent cone turned
    45 degrees whose outer box, not its own frame's, holds the region, are dropped; points there
    still evaluate as the reference says (0 from both)."""
    from blobtree.engine import point
    from blobtree.engine.dispatch import OP_ZERO

    ball = bt.Point(radius=1.0)
    spine = bt.Cone((0.0, 0.0, 0.0), (4.0, 0.0, 0.0), radius_a=0.3, radius_b=0.1).bend(
        30.0, 4.0, axis="x", toward="y").rotate("z", 45.0)
    for tree, lo, hi in ((ball, (0.8, 0.8, 0.8), (0.95, 0.95, 0.95)),
                         (spine, (2.2, 0.2, -0.1), (2.4, 0.4, 0.1))):
        prog = tree.program()
        box_lo, box_hi = prog.boxes[0, :3], prog.boxes[0, 3:]
        assert np.all(box_lo <= lo) and np.all(hi <= box_hi), "the outer box holds the region"
        code, boxes = _specialised(prog, lo, hi)
        assert len(code) == 1 and code[0, 0] == OP_ZERO
        P = np.random.default_rng(0).uniform(lo, hi, (200, 3))
        assert np.all(tree.reference(P)[0] == 0.0)
        st = point.scratch(prog.depth)
        local = (code, prog.params, boxes, np.zeros(len(code)))
        assert all(point.point_walk(local, (*p, 0), st) == 0.0 for p in P)
        # a region around a point where the field is not 0 keeps the primitive
        Q = sample_points(tree, 2000, 1)
        near = Q[np.argmax(tree.reference(Q)[0])]
        code, _ = _specialised(prog, near - 0.05, near + 0.05)
        assert len(code) >= 1 and OP_ZERO not in code[:, 0]


@given(trees(), st.integers(0, 2**31), st.floats(0.02, 0.6))
def test_local_lipschitz_bounds_hold_on_random_trees(tree, seed, frac):
    """The distance-aware bounds (through warps too) bound |grad f| over every box."""
    prog = tree.program()
    P = sample_points(tree, 40, seed)
    lo, hi = tree.bounds()
    if np.any(lo > hi):
        return
    size = frac * (hi - lo) + 1e-3
    bound = prog.lipschitz(P, P + size)
    rng = np.random.default_rng(seed)
    for corner, lip in zip(P, bound, strict=True):
        Q = rng.uniform(corner, corner + size, (200, 3))
        g = np.linalg.norm(tree.reference(Q)[1], axis=1)
        assert g.max() <= lip * (1 + 1e-9) + 1e-12


@given(trees(), st.integers(0, 2**31), st.floats(0.02, 1.0))
def test_segment_lipschitz_bounds_hold_on_random_trees(tree, seed, frac):
    """The bound along a segment (directional for point primitives) bounds how fast the field
    rises along it, grad f . d, and the field stays on its side of 0.5 as far along it as the
    distances say."""
    from blobtree.engine import bounds as K
    from blobtree.engine.point import scratch

    prog = tree.program()
    lo, hi = tree.bounds()
    if np.any(lo > hi):
        return
    rng = np.random.default_rng(seed)
    starts = sample_points(tree, 30, seed)
    dirs = rng.normal(size=(30, 3))
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    length = frac * float(np.linalg.norm(hi - lo)) + 1e-3
    st = scratch(prog.depth)
    for o, d in zip(starts, dirs, strict=True):
        ts = np.linspace(0.0, length, 200)
        fq, gq, _ = tree.reference(o + ts[:, None] * d)
        for values in (True, False):  # the value-aware pass and the plain one
            f, bound, below, above = K.lipschitz_segment(prog.arrays, tuple(o), tuple(d), length,
                                                         values, st)
            np.testing.assert_allclose(f, fq[0], rtol=1e-9, atol=1e-12)
            assert (gq @ d).max() <= bound * (1 + 1e-9) + 1e-12
            assert np.all(fq[ts < below * (1 - 1e-9)] <= 0.5 + 1e-12)
            assert np.all(fq[ts < above * (1 - 1e-9)] >= 0.5 - 1e-12)


def _cone_directions(rng, axis, m, width):
    """m unit directions about the unit axis (up to ``width`` off it) and the largest distance
    of any from the axis."""
    D = axis + width * rng.uniform(-1.0, 1.0, (m, 3))
    D /= np.linalg.norm(D, axis=1)[:, None]
    return D, float(np.linalg.norm(D - axis, axis=1).max())


@given(trees(), st.integers(0, 2**31), st.floats(0.02, 0.5), st.sampled_from([0.0, 0.05, 0.5]))
def test_rise_bounds_hold_along_cones_on_random_trees(tree, seed, frac, width):
    """Over boxes, both passes' bounds on how fast the field rises along a cone of unit
    directions (``bound_box_at`` with a spread, the packet tracer's) are at least grad f . d at
    points of the box for directions d of the cone, never above the pass's bound without the
    cone, and the field stays below 0.5 along those directions as far as they say."""
    from blobtree.engine import bounds as K

    setup = box_bounds_setup(tree, seed, frac)
    if setup is None:
        return
    arrays, st, rng, size = setup
    for corner in sample_points(tree, 20, seed):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        D, spread = _cone_directions(rng, axis, 300, width)
        x = rng.uniform(corner, corner + size)
        Q = rng.uniform(corner, corner + size, (300, 3))
        g = tree.reference(Q)[1]
        slope = max(np.einsum("ij,ij->i", g, D).max(), (g @ axis).max())
        box = (*corner, *(corner + size))
        for values in (True, False):
            plain = K.bound_box_at(arrays, box, tuple(x), (*axis, -1.0), values, st)[1]
            f, rise, below, _ = K.bound_box_at(arrays, box, tuple(x), (*axis, spread), values, st)
            assert slope <= rise * (1 + 1e-9) + 1e-12 and rise <= plain
            s = rng.uniform(0.0, 1.0, 300) * min(below, float(np.linalg.norm(size)))
            P = x + s[:, None] * D
            inside = np.all((P >= corner) & (P <= corner + size), axis=1) & (s < below)
            assert np.all(tree.reference(P[inside])[0] <= 0.5 + 1e-12)


def _rise(tree, box, d, values, spread=0.0):
    """Both bound passes' rise over the box along unit direction d (and the cone about it)."""
    from blobtree.engine import bounds as K
    from blobtree.engine.point import scratch

    prog = tree.program()
    centre = 0.5 * (np.array(box[:3]) + np.array(box[3:]))
    return K.bound_box_at(prog.arrays, tuple(float(v) for v in box), tuple(centre),
                          (*(float(v) for v in d), float(spread)), values,
                          scratch(prog.depth))[1]


def test_rays_leaving_a_blend_of_points_are_bounded_by_nothing_it_falls_from():
    """Rays that leave every point of a blend have no rise bound in the plain pass (the tracer
    crosses their segments in one step) though the field's slope there is not 0, and rays that
    pass them sideways a small one.  A difference rises where its first child does or its
    carving falls: leaving the carving it rises, and its bound says so; away from the carving
    it rises as its first child does.  The value-aware pass keeps its plain bound."""
    blob = bt.Blend(bt.Point(radius=1.0), bt.Point(radius=1.0, center=(0.6, 0.0, 0.0)))
    carved = bt.Difference(bt.Point(radius=2.5, center=(2.0, 0.0, 0.0)), blob)
    near = (1.0, -0.1, -0.1, 1.2, 0.1, 0.1)  # beyond the blob's centres along +x
    far = (2.5, -0.1, -0.1, 2.7, 0.1, 0.1)  # beyond the blob's support and carved's centre
    for tree, box in ((blob, near), (carved, near), (carved, far)):
        Q = np.random.default_rng(0).uniform(box[:3], box[3:], (500, 3))
        g = tree.reference(Q)[1]
        for values in (True, False):
            plain = _rise(tree, box, (1.0, 0.0, 0.0), values, -1.0)
            out = _rise(tree, box, (1.0, 0.0, 0.0), values, 0.05)
            back = _rise(tree, box, (-1.0, 0.0, 0.0), values)
            assert np.abs(g[:, 0]).max() > 0.1 and plain > 0.1
            assert g[:, 0].max() <= out * (1 + 1e-9) + 1e-12 and out <= plain
            assert (-g[:, 0]).max() <= back * (1 + 1e-9) + 1e-12 and back <= plain
            if values:
                assert out == back == plain
            elif tree is blob:  # leaving: 0; moving in: as fast as the field rises
                assert out == 0.0 and back >= (-g[:, 0]).max() > 0.1
                side = _rise(tree, box, (0.0, 1.0, 0.0), values)
                assert g[:, 1].max() <= side < 0.5 * plain
            else:  # leaving the carving it rises; away from it, it leaves (2, 0, 0): 0
                assert out > 0.1 if box == near else out == 0.0


@given(st.sampled_from(["soft_object", "cubic"]), st.floats(0.3, 3.0), st.integers(0, 2**31))
def test_point_directional_bound_is_the_largest_slope(falloff, radius, seed):
    """For a lone (scaled, rotated) point primitive the segment bound is |df/dt|'s maximum along
    the segment itself: at least every sampled slope, and within 1% of the largest; the rise
    bound (what the tracer steps by) is at least every sampled df/dt and at most that."""
    from blobtree.engine import bounds as K
    from blobtree.engine.point import scratch

    tree = bt.Point(radius=radius, falloff=falloff).scale(1.0, 0.7, 1.3).rotate((1, 2, 3), 40)
    prog = tree.program()
    rng = np.random.default_rng(seed)
    st = scratch(prog.depth)
    for _ in range(20):
        o = rng.uniform(-1.5, 1.5, 3) * radius
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        length = rng.uniform(0.05, 3.0) * radius
        e = o + length * d
        bound, rise = K.lipschitz_walk(prog.arrays, (*np.minimum(o, e), *np.maximum(o, e), *o,
                                                     *d, length, 0.0, 1.0), st)
        Q = o + np.linspace(0.0, length, 4001)[:, None] * d
        slopes = tree.reference(Q)[1] @ d
        slope = np.abs(slopes).max()
        assert slope <= bound * (1 + 1e-9) + 1e-12
        assert bound <= slope * 1.01 + 1e-9
        assert slopes.max() <= rise * (1 + 1e-9) + 1e-12 and rise <= bound


def test_concurrent_evaluation_from_python_threads_is_safe():
    """Several Python threads evaluating (and rendering) at once get what one thread gets:
    kernels run in blobtree's own pool, not a numba threading layer (docs/limits.md)."""
    from concurrent.futures import ThreadPoolExecutor

    tree = bt.models.whorl126()
    prog = tree.program()
    pts = sample_points(tree, 50_000, 0)
    alone = prog.evaluate(pts)
    image = bt.render(tree, 24, 16)
    with ThreadPoolExecutor(4) as pool:
        fields = list(pool.map(lambda _: prog.evaluate(pts), range(4)))
        images = list(pool.map(lambda _: bt.render(tree, 24, 16), range(4)))
    for got in fields:
        for a, b in zip(got, alone, strict=True):
            np.testing.assert_array_equal(a, b)
    for got in images:
        np.testing.assert_array_equal(got, image)


def test_an_equal_tree_built_again_reuses_the_compiled_program():
    import gc

    from blobtree.nodes.node import _PROGRAMS

    def build(r):
        return bt.blend(bt.Point(radius=r), bt.Cone((0, 0, 0), (1, 0, 0), 0.5, 0.2))

    a = build(1.0)
    assert build(1.0).program() is a.program()  # a notebook cell run twice
    assert build(1.1).program() is not a.program()
    key = a.key
    del a
    gc.collect()
    assert key not in _PROGRAMS  # kept only while a tree holds it


def test_a_subtrahend_absent_here_does_not_paint():
    """Where a blend above 1 meets a subtrahend with no field, the difference is capped at 1 and
    keeps the blend's colour, in the reference, the full program and specialised cells alike
    (a regression: the reference painted with the absent subtrahend's colour)."""
    from blobtree.engine import GRID_MIN_POINTS

    c0 = bt.Cone((0, 0, 0), (0, 0, 1), radius_a=1.0, radius_b=1.0).color((0.9, 0.2, 0.1))
    c1 = bt.Cone((0, 0, 0), (0, 0, -1), radius_a=1.0, radius_b=1.0).color((0.9, 0.2, 0.1))
    tree = bt.difference(bt.blend(c0, c1), bt.Segment((0, 0, 0), (0, 0, 1), radius=0.5)
                         .color((0.0, 0.0, 0.0)))
    P = sample_points(tree, GRID_MIN_POINTS + 5000, 0)
    f, _, c = tree.program().evaluate(P)
    fr, _, cr = tree.reference(P)
    capped = (fr == 1.0) & (bt.Segment((0, 0, 0), (0, 0, 1), radius=0.5).field(P) == 0.0)
    assert capped.sum() > 20
    np.testing.assert_allclose(cr[capped], [[0.9, 0.2, 0.1]] * capped.sum())
    live = fr > 1e-9
    np.testing.assert_allclose(c[live], cr[live], rtol=1e-9, atol=1e-9)


@given(trees(), st.integers(0, 2**31), st.floats(0.02, 0.6))
def test_value_aware_bounds_hold_on_random_trees(tree, seed, frac):
    """With the field values at a point of the box, CSG operators drop the bounds of children
    that cannot set the result there: the field it returns is the field at the point, and the
    bound still bounds |grad f| over the whole box."""
    check_box_bounds(tree, seed, frac, 30)


def test_parallel_for_cuts_coarse_items_into_parts_for_every_thread(monkeypatch):
    """A range of a few large items (a batch's slabs of 8192 points) is still cut into a part per
    thread or more when ``grain=1``; by default parts hold at least MIN_PART items.  Either way
    the parts cover the range once, in order."""
    from blobtree.runtime import threads as parallel

    monkeypatch.setattr(parallel, "threads", lambda: 2)
    for n, grain, fewest in ((25, 1, 2), (25, parallel.MIN_PART, 1), (1000, 1, 8)):
        parts: list[tuple[int, int]] = []
        parallel.parallel_for(lambda a, b, out=parts: out.append((a, b)), n, grain=grain)
        parts.sort()
        assert len(parts) >= fewest
        assert parts[0][0] == 0 and parts[-1][1] == n
        assert all(b0 == a1 for (_, b0), (a1, _) in zip(parts[:-1], parts[1:], strict=True))
        if grain == parallel.MIN_PART:
            assert len(parts) == 1


def test_nan_and_infinite_points_agree_on_both_paths():
    """A point with a NaN coordinate has a NaN field and gradient, one at infinity 0, whether a
    batch is small (one point at a time) or large (the grid of specialised programs)."""
    from blobtree.engine import GRID_MIN_POINTS

    prog = bt.models.whorl126().program()
    P = np.tile([0.0, 2.0, 0.0], (GRID_MIN_POINTS + 7, 1))
    P[3, 1], P[4, 2], P[5, 0], P[6] = np.nan, np.inf, -np.inf, np.nan
    for n in (7, len(P)):
        f, g, c = prog.evaluate(P[:n])
        assert np.isnan(f[[3, 6]]).all() and np.isnan(g[[3, 6]]).all()
        assert (f[[4, 5]] == 0.0).all() and (g[[4, 5]] == 0.0).all()
        assert np.isfinite(f[7:]).all() and np.isfinite(g[7:]).all()
        assert (c[3:7] == c[3]).all()


def test_thread_count_is_numbas_without_starting_numbas_pool():
    """``threads.threads`` is NUMBA_NUM_THREADS in a fresh process without starting numba's own
    pool of threads (which costs a command 17-28 ms), and follows ``numba.set_num_threads``."""
    import subprocess
    import sys

    code = ("import numba; from numba.np.ufunc import parallel as p;"
            "from blobtree.runtime import threads; n = threads.threads();"
            "print(n, p._is_initialized); numba.set_num_threads(1);"
            "print(threads.threads())")
    for count in ("1", "2"):
        env = {**os.environ, "NUMBA_NUM_THREADS": count}
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                             text=True, check=True).stdout.split()
        assert out == [count, "False", "1"]


def test_box_hierarchy_cuts_where_fewest_boxes_hold_a_point():
    """An associative operator's children are grouped by the volume heuristic: a cluster of 24
    children and one of 8 far from it, given interleaved, are cut apart at the top (a cut at
    the median of the centres would put 8 of the 24 with the far ones), and
    children whose boxes are all alike still give a balanced tree (a stack only logarithmically
    deep) and the exact sum."""
    near = [bt.Point(radius=0.5, center=(0.01 * i, 0.0, 0.0)) for i in range(24)]
    far = [bt.Point(radius=0.5, center=(10.0 + 0.01 * i, 0.0, 0.0)) for i in range(8)]
    tree = bt.blend(*[c for pair in zip(near[:8], far, strict=True) for c in pair], *near[8:])
    prog = tree.program()
    first, second = 1, int(prog.code[1, 2])  # the root's two groups: BOX heads
    extents = sorted(float(prog.boxes[i, 3] - prog.boxes[i, 0]) for i in (first, second))
    assert extents[1] < 2.0, extents  # each group holds one cluster only
    same = bt.blend(*[bt.Point(radius=1.0) for _ in range(64)])
    p = same.program()
    assert p.depth <= 12, p.depth
    np.testing.assert_allclose(p.field(np.array([[0.1, 0.2, 0.3]])),
                               64 * bt.Point(radius=1.0).field(np.array([[0.1, 0.2, 0.3]])),
                               rtol=1e-12)


def _cheapest_cut(boxes):
    """The cut of the boxes _split should make, by plain loops: on each axis, the boxes in the
    order of their centres, each cut's cost (the boxes on each side times the volume of their
    box, every side grown by a hundredth of the whole box's largest side); the cheapest within
    a hair, the most even of those, the first axis of equals."""
    finite = [[[v if np.isfinite(v) else 0.0 for v in side] for side in box] for box in boxes]
    lo = [b[0] for b in finite]
    hi = [[max(h, v) for h, v in zip(b[1], b[0], strict=True)] for b in finite]
    n = len(boxes)
    grow = 0.01 * max(max(h[c] for h in hi) - min(v[c] for v in lo) for c in range(3))

    def volume(group):
        sides = [max(hi[j][c] for j in group) - min(lo[j][c] for j in group) + grow
                 for c in range(3)]
        return sides[0] * sides[1] * sides[2]

    best = (np.inf, None)
    for axis in range(3):
        order = sorted(range(n), key=lambda j: lo[j][axis] + hi[j][axis])
        cost = [volume(order[:i + 1]) * (i + 1) + volume(order[i + 1:]) * (n - i - 1)
                for i in range(n - 1)]
        near = [i for i in range(n - 1) if cost[i] <= min(cost) * (1.0 + 1e-9)]
        i = min(near, key=lambda i: abs(2 * (i + 1) - n))
        if cost[i] < best[0]:
            best = (cost[i], (order[:i + 1], order[i + 1:]))
    return best[1]


@given(st.lists(st.tuples(st.tuples(*[st.integers(-4, 4)] * 3),
                          st.tuples(*[st.integers(0, 3)] * 3)), min_size=2, max_size=24),
       st.booleans())
@example([((0, 0, 0), (1, 1, 1))] * 7, False)  # all alike: every cut ties, the evenest wins
@example([((k, 0, 0), (1, 1, 1)) for k in range(9)], True)
def test_a_group_is_split_where_the_volume_heuristic_says(boxes, empty_first):
    """The box hierarchy's split (``program._split``) against the heuristic it implements,
    computed by plain loops: boxes on a coarse grid, so that ties (and their evenest cut) and
    boxes all alike come up; an empty box counts as a point at the origin."""
    from blobtree.engine.program import _split

    arrays = [(np.array(c, float) - h, np.array(c, float) + h) for c, h in boxes]
    if empty_first:
        arrays[0] = (np.full(3, np.inf), np.full(3, -np.inf))
    head, tail = _split(arrays)
    expected = _cheapest_cut(arrays)
    assert list(head) == expected[0] and list(tail) == expected[1]
