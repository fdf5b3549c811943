"""Fuzzing the public surface: every call either works or raises the documented error.

Hypothesis draws API calls (node constructors, ``render``, ``polygonize``, cameras, lights) with
parameters mixing good values and hostile ones (NaN, infinities, 400-digit integers, bools,
strings, megabyte strings, wrong shapes, numpy scalars and arrays), and scene documents (good
scenes with one part replaced, removed or added; truncated text; deep and wide trees).  Each
example must either succeed (and then give a sound result: finite fields and bounds, an image
of the asked size, a closed mesh, a scene that saves and loads back equal) or raise ValueError
(SceneError for scene files) without hanging (``HANG``).  A TypeError is allowed only for an unknown
keyword, as Python itself raises it.

The example counts scale with the hypothesis profile (``ci``: about 10,600 in all; see
``FUZZ_EXAMPLES``).
"""

from __future__ import annotations

import functools
import json
import math
from datetime import timedelta

import numpy as np
import pytest
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st

import blobtree as bt
from blobtree.io import SceneError, dumps, loads
from blobtree.nodes import REGISTRY
from blobtree.nodes.node import MAX_DEPTH
from tests.trees import trees, value

#: examples per fuzz test under the ``ci`` profile (scaled for ``quick`` and ``thorough``)
FUZZ_EXAMPLES = {"nodes": 4000, "render": 600, "polygonize": 600, "camera": 1500,
                 "scene": 3500, "shape": 400}
_SCALE = settings.default.max_examples / 60


#: Per example: catches a hang, far above any example's normal time (under a second), so that a
#: busy machine does not fail it.
HANG = timedelta(seconds=60)


def fuzz(name: str) -> settings:
    """Settings for one fuzz test: its share of the examples, a hang deadline per example."""
    return settings(max_examples=max(10, round(FUZZ_EXAMPLES[name] * _SCALE)),
                    deadline=HANG,
                    suppress_health_check=list(HealthCheck))


@pytest.fixture(scope="module", autouse=True)
def _compiled():
    """Compile the kernels before the deadlines start counting."""
    tree = bt.blend(bt.Point(radius=1.0), bt.Point(radius=1.0, center=(0.5, 0.0, 0.0)))
    for samples, shadows in ((1, True), (2, False)):
        bt.render(tree, 4, 4, samples=samples, shadows=shadows, threads=2)
    bt.polygonize(tree, 4)
    bt.polygonize(tree, 4, bounds=((-1.0, -1.0, -1.0), (1.5, 1.0, 1.0)))


JUNK = st.one_of(
    st.none(), st.booleans(), st.just(math.nan), st.just(math.inf), st.just(-math.inf),
    st.integers(-10, 10), st.just(10**400), st.just(-(10**400)),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([1e-300, 1e300, -1e300, 5e-324, 0.0, -0.0, 1e7, 1e-7]),
    st.text(max_size=4), st.just("x" * 1_000_000), st.just(b"bytes"), st.just(1 + 2j),
    st.lists(st.floats(allow_nan=True), max_size=5),
    st.lists(st.lists(st.integers(-3, 3), max_size=3), max_size=3),
    st.dictionaries(st.text(max_size=3), st.integers(), max_size=2),
    st.sampled_from([np.float32(1.5), np.int64(3), np.bool_(True), np.float64("nan"),
                     np.zeros((0, 4, 3)), np.ones((2, 2, 2, 2)), np.ones(3, dtype=object),
                     np.full(3, np.inf), np.array([1.0, 2.0]), np.ones((5000, 1, 3))]),
)


@st.composite
def one_bad(draw, **good: st.SearchStrategy) -> dict:
    """Arguments drawn from ``good``, but for one of them (in about two calls of three) junk:
    so that both working calls and each kind of refusal are reached."""
    names = sorted(good)
    bad = draw(st.sampled_from([None, *names]) if names else st.none())
    if bad is not None and draw(st.integers(0, 2)) == 0:
        bad = None
    return {n: draw(JUNK if n == bad else good[n]) for n in names}


def _point(r: float = 1.0, x: float = 0.0) -> bt.Node:
    return bt.Point(radius=r, center=(x, 0.0, 0.0))


def _sound(tree: bt.Node) -> None:
    """A built tree's bounds are finite or empty, its field finite and non-negative (zero
    wherever the box is empty: a warp of an empty child has the box (inf, -inf))."""
    lo, hi = tree.bounds()
    pts = np.random.default_rng(0).uniform(-2.0, 2.0, (16, 3))
    f = tree.program().field(pts)
    assert np.all(np.isfinite(f)) and np.all(f >= 0.0)
    if np.any(lo > hi):
        assert np.all(f == 0.0)
    else:
        assert np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))


@st.composite
def node_calls(draw):
    """A registered node type with children (sometimes wrong) and parameters (sometimes
    junk)."""
    cls = draw(st.sampled_from(sorted(REGISTRY.values(), key=lambda c: c.TYPE)))
    lo, hi = cls.ARITY
    n = 0 if hi == 0 else draw(st.integers(max(lo, 1), min(hi or 4, 4)))
    if draw(st.integers(0, 9)) == 0:
        n = draw(st.integers(0, 5))  # a wrong count, sometimes
    kids = [draw(st.one_of(st.builds(_point, st.floats(0.3, 1.5), st.floats(-1.0, 1.0)),
                           st.just(_point()), JUNK) if draw(st.integers(0, 9)) == 0
                 else st.builds(_point, st.floats(0.3, 1.5), st.floats(-1.0, 1.0)))
            for _ in range(n)]
    kwargs = draw(one_bad(**{p.name: value(p.kind, max(n, 2)) for p in cls.PARAMS}))
    if kwargs and draw(st.integers(0, 19)) == 0:  # a missing parameter, sometimes
        del kwargs[draw(st.sampled_from(sorted(kwargs)))]
    return cls, kids, kwargs


@fuzz("nodes")
@given(node_calls())
def test_node_constructors_work_or_refuse(call):
    cls, kids, kwargs = call
    try:
        tree = cls(*kids, **kwargs)
    except ValueError:
        event("refused: ValueError")
        return
    except TypeError as e:  # only Python's own for a call's shape (a missing argument, one
        # given twice), named by the type
        assert str(e).startswith(f"{cls.__name__}: ") and "argument" in str(e), e
        event("refused: TypeError (call shape)")
        return
    event("built")
    _sound(tree)
    assert loads(dumps(tree)) == tree


SMALL_TREE = bt.blend(_point(0.8), _point(0.8, 0.6)).color((0.2, 0.6, 0.9))


@fuzz("render")
@given(one_bad(width=st.integers(1, 6), height=st.integers(1, 6), samples=st.integers(1, 2),
               shadows=st.booleans(), background=st.tuples(*[st.floats(0.0, 1.0)] * 3),
               tile=st.integers(1, 8), threads=st.integers(1, 2), tree=st.just(SMALL_TREE),
               look=st.sampled_from(["studio", "glossy", "paper"]),
               occlusion=st.floats(0.0, 1.0), light_radius=st.floats(0.0, 30.0),
               sky=st.floats(0.0, 1.0), occlusion_radius=st.floats(0.001, 1.0)))
def test_render_works_or_refuses(args):
    try:
        img = bt.render(**args)
    except ValueError:
        event("refused")
        return
    event("rendered")
    assert img.shape == (args["height"], args["width"], 3) and img.dtype == np.uint8


@fuzz("polygonize")
@given(one_bad(resolution=st.one_of(st.none(), st.integers(2, 10), st.just(10**9)),
               cell_size=st.none(),  # (good only without resolution: junk tries it)
               bounds=st.one_of(st.none(), st.none(), st.just(((-1.0, -1.0, -1.0),
                                                                (1.5, 1.0, 1.0)))),
               max_memory=st.one_of(st.none(), st.integers(0, 10**9)),
               tree=st.just(SMALL_TREE)))
def test_polygonize_works_or_refuses(args):
    try:
        mesh = bt.polygonize(**args)
    except ValueError:
        event("refused")
        return
    event("meshed")
    assert len(mesh.faces) == 0 or mesh.is_watertight
    assert np.all(np.isfinite(mesh.vertices))


VEC = st.tuples(*[st.floats(-5.0, 5.0)] * 3)
COLOUR = st.tuples(*[st.floats(0.0, 1.0)] * 3)


@fuzz("camera")
@given(st.one_of(
    st.tuples(st.just(bt.Camera), one_bad(eye=VEC, target=VEC, up=VEC,
                                          fov=st.floats(1.0, 170.0))),
    st.tuples(st.just(bt.Light), one_bad(direction=VEC, color=COLOUR,
                                         intensity=st.floats(0.0, 3.0))),
    st.tuples(st.just(bt.Light), one_bad(position=VEC, intensity=st.floats(0.0, 3.0))),
    st.tuples(st.just(bt.RenderSettings), one_bad(
        width=st.integers(1, 64), height=st.integers(1, 64), samples=st.integers(1, 4),
        shadows=st.booleans(), background=COLOUR,
        background_bottom=st.one_of(st.none(), COLOUR), occlusion=st.floats(0.0, 1.0),
        light_radius=st.floats(0.0, 30.0), sky=st.floats(0.0, 1.0)))))
def test_cameras_lights_and_settings_work_or_refuse(call):
    """Either the value is made, keeping every argument as a finite value of its own, or it is
    refused with a ValueError that names one of the arguments it was given."""
    make, kwargs = call
    try:
        made = make(**kwargs)
    except ValueError as e:
        event(f"{make.__name__} refused")
        assert any(name in str(e) for name in kwargs), f"{e} names none of {sorted(kwargs)}"
        return
    event(f"{make.__name__} made")
    assert isinstance(made, make)
    for name in kwargs:
        value = getattr(made, name)
        if value is not None and not isinstance(value, bool):
            assert np.all(np.isfinite(np.asarray(value, dtype=float))), (name, value)


# ----- scene documents --------------------------------------------------------------------------

JSON_JUNK = st.one_of(
    st.none(), st.booleans(), st.integers(-3, 40), st.just(10**400), st.just(-1),
    st.floats(allow_nan=False, allow_infinity=False), st.sampled_from([1e300, -1e300, 1e-300]),
    st.text(max_size=6), st.just("x" * 100_000), st.sampled_from(sorted(REGISTRY)),
    st.lists(st.floats(-2.0, 2.0), max_size=4), st.lists(st.integers(-2, 5), max_size=4),
    st.builds(dict), st.builds(list), st.builds(lambda: {"type": "point"}),  # fresh each time
)


def _paths(doc, prefix=()):
    """Every (container, key) position in a JSON document."""
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield doc, k
            yield from _paths(v, (*prefix, k))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield doc, i
            yield from _paths(v, (*prefix, i))


@functools.cache
def _good_scenes() -> list[str]:
    """Good scenes to mutate: a few random trees of every node type, and the paper's whorl."""
    found = []
    find_trees = settings(max_examples=40, database=None, derandomize=True, deadline=None,
                          suppress_health_check=list(HealthCheck))(given(trees(max_leaves=5))(
                              lambda t: found.append(dumps(t))))
    find_trees()
    return [*found, dumps(bt.models.whorl126())]


@st.composite
def mutated_scenes(draw):
    """The text of a good scene with one to three parts replaced, removed or added, or cut."""
    scenes = _good_scenes()
    doc = json.loads(scenes[draw(st.integers(0, len(scenes) - 1))])
    for _ in range(draw(st.integers(1, 3))):
        spots = list(_paths(doc))
        container, key = draw(st.sampled_from(spots))
        action = draw(st.sampled_from(["scale", "scale", "replace", "remove", "add"]))
        number = isinstance(container[key], float | int) and not isinstance(container[key], bool)
        if action == "scale" and number:  # a plausible edit: likely still loads, or is refused
            factor = draw(st.sampled_from([-1, 0.5, 2, 10, 1e3]))
            container[key] = container[key] * (factor if abs(container[key]) < 1e300 else 1)
        elif action in ("replace", "scale"):
            container[key] = draw(JSON_JUNK)
        elif action == "remove":
            del container[key]
        elif isinstance(container, dict):
            container[draw(st.text(max_size=5))] = draw(JSON_JUNK)
        else:
            container.insert(key, draw(JSON_JUNK))
    text = json.dumps(doc)
    if draw(st.integers(0, 9)) == 0:
        text = text[:draw(st.integers(0, len(text)))]
    return text


# CI drew a twist of an empty intersection: its box is the empty (inf, -inf)
EMPTY_TWIST = json.dumps({
    "format": "blobtree-scene", "version": 4, "root": 3, "nodes": [
        {"type": "point", "params": {"radius": 1.0, "center": [0.0, 0.0, 0.0]}},
        {"type": "point", "params": {"radius": 1.0, "center": [5.0, 0.0, 0.0]}},
        {"type": "intersection", "params": {}, "children": [0, 1]},
        {"type": "twist", "params": {"degrees_per_unit": 1e-229, "axis": "y"}, "children": [2]}]})


@fuzz("scene")
@given(mutated_scenes())
@example(EMPTY_TWIST)
def test_mutated_scenes_load_or_raise_scene_errors(text):
    try:
        tree = loads(text)
    except SceneError as e:
        assert str(e).startswith("$") and len(str(e)) < 1000, str(e)
        event("refused")
        return
    event("loaded")
    _sound(tree)
    assert loads(dumps(tree)) == tree


@fuzz("shape")
@given(depth=st.integers(1, MAX_DEPTH + 60), width=st.integers(1, 60),
       shared=st.sampled_from([0, 0, 5, 10, 40]))
def test_deep_and_wide_trees_build_save_and_load_or_refuse(depth, width, shared):
    """What builds saves and loads back; what would not is refused when built.  The first
    ``shared`` levels use the tree below twice (2**shared copies in the program)."""
    tree = bt.blend(*[_point(0.5, 0.01 * i) for i in range(width)])
    try:
        for i in range(depth):
            tree = bt.blend(tree, tree) if i < shared else tree.translate((0.0, 0.001, 0))
    except ValueError as e:
        assert "levels deep" in str(e) and depth + 2 > MAX_DEPTH, e  # (+ blend + points)
        return
    assert loads(dumps(tree)) == tree
    try:
        program = tree.program()
    except ValueError as e:  # 2**40 copies: refused before compiling
        assert "instructions" in str(e) and shared == 40, e
        return
    assert np.isfinite(program.field(np.zeros((1, 3)))).all()
