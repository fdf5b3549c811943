"""The node registry: every type is complete, covered by the generated trees, and a value."""

from __future__ import annotations

import inspect
import json
import pickle

import numpy as np
import pytest
from hypothesis import Phase, find, given, settings
from hypothesis import strategies as st
from hypothesis.errors import NoSuchExample

import blobtree as bt
from blobtree.engine import dispatch
from blobtree.io import dumps, loads, schema
from blobtree.nodes import REGISTRY
from blobtree.nodes.node import register
from blobtree.nodes.params import REQUIRED
from tests.trees import node_of, trees

TYPES = sorted(REGISTRY)
#: Search without shrinking: the first example found will do.
FIRST = settings(phases=[Phase.generate], max_examples=2000, database=None)


@pytest.mark.parametrize("name", TYPES)
def test_every_registered_type_appears_in_the_generated_trees(name):
    """The strategies come from the registry: a type they cannot build fails here."""
    try:
        tree = find(trees(), lambda t: any(n.TYPE == name for n in t.walk()), settings=FIRST)
    except NoSuchExample:
        pytest.fail(f"the generated trees never contain a {name!r} node")
    assert any(type(n) is REGISTRY[name] for n in tree.walk())


@pytest.mark.parametrize("name", TYPES)
def test_every_type_declares_a_complete_spec(name):
    cls = REGISTRY[name]
    assert cls.__doc__ and cls.TYPE == name
    sig = inspect.signature(cls)
    for p in cls.PARAMS:
        assert p.name in sig.parameters, f"{name}: {p.name} is not a constructor argument"
        assert isinstance(p.kind.schema, str)
    assert schema()[name] == {p.name: p.kind.schema for p in cls.PARAMS}
    if cls.KIND in ("primitive", "operator", "warp", "paint"):
        assert cls in dispatch.OPCODE  # the engine has its kernels
    if cls.KIND == "primitive":
        assert callable(cls.KERNELS.s) and callable(cls.KERNELS.uv)
        assert cls.LAYOUT.size == len(cls.pack(_example(cls)))


@pytest.mark.parametrize("name", TYPES)
def test_constructor_binds_as_its_signature_does(name):
    """Children and parameters by position and by name give the node the signature binds; an
    unknown, a repeated or a missing argument is Python's TypeError, naming the type."""
    cls = REGISTRY[name]
    node = find(node_of(cls, st.just(bt.Point(radius=0.5))), lambda n: True, settings=FIRST)
    values = node.values()
    assert cls(*node.children, **values) == node
    if cls._positional:  # unary and leaf types take their parameters by position too
        assert cls(*node.children, *values.values()) == node
        first = cls.PARAMS[0].name
        with pytest.raises(TypeError, match=f"{cls.__name__}: .*{first}"):
            cls(*node.children, values[first], **{first: values[first]})
    with pytest.raises(TypeError, match=f"{cls.__name__}: .*nonsense"):
        cls(*node.children, nonsense=1.0, **values)
    required = [p.name for p in cls.PARAMS if p.default is REQUIRED]
    if required:
        del values[required[0]]
        with pytest.raises(TypeError, match=f"{cls.__name__}: .*{required[0]}"):
            cls(*node.children, **values)


def _example(cls):
    return find(node_of(cls, None), lambda n: True, settings=FIRST)


def test_opcodes_are_grouped_by_kind_and_unknown_types_are_refused():
    kinds = [dispatch.KIND[dispatch.OPCODE[c]] for c in dispatch.TYPES]
    assert kinds == sorted(kinds)
    assert dispatch.OP_BOX == len(dispatch.TYPES)

    class Stray(bt.Point):
        """Not registered."""

        TYPE = "stray"

    with pytest.raises(TypeError, match="not a registered node type"):
        Stray()


def test_registering_after_the_engine_is_built_is_refused():
    class Late(bt.Point):
        """Too late."""

        TYPE = "late"

    with pytest.raises(RuntimeError, match="registered after the engine was built"):
        register(Late)
    assert "late" not in REGISTRY


def test_nodes_are_immutable_and_replace_makes_a_new_one():
    p = bt.Point(radius=2.0)
    x = np.array([[0.5, 0.0, 0.0]])
    before = p.field(x)
    with pytest.raises(AttributeError, match="immutable"):
        p.radius = 4.0
    with pytest.raises(ValueError, match="read-only"):
        p.center[0] = 1.0
    q = p.replace(radius=4.0)
    assert p.radius == 2.0 and q.radius == 4.0
    np.testing.assert_array_equal(p.field(x), before)  # the cached program is still right
    np.testing.assert_allclose(q.field(x), q.reference(x)[0])
    assert q.field(x) > before
    with pytest.raises(TypeError, match="no parameter"):
        p.replace(colour=1)


@given(trees(max_leaves=5))
def test_equal_trees_are_equal_values(tree):
    again = loads(dumps(tree))
    assert again == tree and hash(again) == hash(tree) and again.key == tree.key
    assert pickle.loads(pickle.dumps(tree)) == tree
    if tree.PARAMS:
        changed = {p.name: getattr(tree, p.name) for p in tree.PARAMS}
        assert tree.replace(**changed) == tree


def test_a_shared_subtree_is_stored_once_and_compiled_by_its_uses():
    b = bt.Cone((0, 0, 0), (1, 0, 0), 0.3, 0.1).bend(30, 1.0)
    tree = bt.blend(*(b.rotate("y", 30 * i) for i in range(12)))
    doc = json.loads(dumps(tree))
    assert sum(1 for n in doc["nodes"] if n["type"] == "cone") == 1
    assert sum(1 for n in doc["nodes"] if n["type"] == "bend") == 1
    assert loads(dumps(tree)) == tree
    # structurally equal subtrees built separately are merged too
    twice = bt.blend(bt.Point(radius=2.0).translate(1, 0, 0), bt.Point(radius=2.0))
    assert sum(1 for n in json.loads(dumps(twice))["nodes"] if n["type"] == "point") == 1


def test_idempotent_operators_evaluate_a_repeated_child_once():
    """union(n, n) is n: repeated 40 times over it stays one program, not 2^40."""
    n = bt.Point(radius=1.0)
    for _ in range(40):
        n = bt.union(n, n)
    prog = n.program()
    assert len(prog) < 200
    x = np.random.default_rng(0).uniform(-1, 1, (50, 3))
    np.testing.assert_allclose(n.field(x), bt.Point(radius=1.0).field(x))


@settings(max_examples=max(5, settings.default.max_examples // 3))
@given(trees(max_leaves=5))
def test_a_shared_subtree_compiles_to_the_same_program_as_copies_of_it(t):
    """The compiler emits a subtree met again in the same frame as a copy of its first
    instructions (jumps and parameter offsets moved): the program is exactly the one separately
    built copies give, where every node is met once."""
    shared = bt.blend(t, t.translate(1.0, 0.0, 0.0), bt.union(t, t.scale(2.0)), t)
    a, b, c, d = (loads(dumps(t)) for _ in range(4))
    copies = bt.blend(a, b.translate(1.0, 0.0, 0.0), bt.union(c, t.scale(2.0)), d)
    assert a is not b  # (each load builds its own nodes)
    p, q = shared.program(), copies.program()
    for name in ("code", "params", "boxes", "lips"):
        np.testing.assert_array_equal(getattr(p, name), getattr(q, name), err_msg=name)


def test_a_tree_too_large_to_expand_is_refused_with_its_size():
    n = bt.Point(radius=1.0)
    for _ in range(40):
        n = bt.blend(n, n)  # a sum: each copy counts
    with pytest.raises(ValueError, match="expands to about"):
        n.program()
