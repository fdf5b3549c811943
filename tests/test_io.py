"""Scene files: exact round trips and errors that name the JSON path."""

from __future__ import annotations

import base64
import json

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import blobtree as bt
from blobtree.io import SceneError, dumps, loads
from blobtree.texture.mapping import HelicoSurface
from tests.conftest import examples
from tests.trees import sample_points, trees


@examples(0.7)
@given(trees(), st.integers(0, 2**31))
def test_round_trip_is_exact(tree, seed):
    text = dumps(tree)
    back = loads(text)
    assert dumps(back) == text
    P = sample_points(tree, 200, seed)
    np.testing.assert_array_equal(back.field(P), tree.field(P))


def test_every_node_type_round_trips(tmp_path):
    a = bt.Point(radius=1.0, falloff="cubic")
    parts = [
        a, bt.Segment((0, 0, 0), (1, 0, 0), 0.5), bt.Cone((0, 0, 0), (1, 0, 0), 0.5, 0.2),
        bt.Torus(1.0, 0.3), bt.Disc(1.0, 0.3), bt.Cylinder((0, 0, 0), (0, 1, 0), 0.3, 0.2),
        bt.Ellipsoid((1.0, 0.5, 0.7), (0.1, 0, 0)),
    ]
    tree = bt.union(
        bt.blend(*parts), bt.super_blend(a, a.translate(1, 0, 0), n=400),
        bt.intersection(a, a.scale(2)), bt.difference(a.scale(1, 2, 3), a),
        bt.controlled_blend([a, a, a], pairs=[(0, 1), (1, 2)]),
        bt.gradient_blend(a, parts[1], power=2.0, contact=0.2),
        a.rotate("x", 30).rotate((1, 1, 0), 12.5), parts[2].bend(30, 1.0).twist(20).taper(0.1),
        a.color((0.1, 0.2, 0.3)),
        a.texture(np.arange(24, dtype=np.uint8).reshape(2, 4, 3), wrap="clamp"),
        a.texture(lambda u, v: np.stack([u, v, u * v], -1), mapping=HelicoSurface(u_period=90)),
    )
    assert {n.TYPE for n in tree.walk()} == set(bt.nodes.NODE_TYPES)
    path = tmp_path / "scene.json"
    bt.save(tree, path)
    back = bt.load(path)
    assert dumps(back) == dumps(tree)


def _nested(node, images):
    """A node as version 1 nests it: children inside their parent."""
    out = {"type": node.TYPE, "params": node.params(images)}
    if node.children:
        out["children"] = [_nested(c, images) for c in node.children]
    return out


@examples(0.3)
@given(trees(max_leaves=6))
def test_version_1_files_still_load(tree):
    from blobtree.texture.mapping import image_to_text

    images = {}
    root = _nested(tree, images)
    doc = {"format": "blobtree-scene", "version": 1, "root": root}
    if images:
        doc["images"] = {k: image_to_text(v) for k, v in images.items()}
    assert loads(json.dumps(doc)) == tree
    assert json.loads(dumps(tree))["version"] == 4


def test_files_older_than_a_parameter_give_it_its_default():
    """The controlled blend's groups and n came with version 3: a version-2 file has neither
    and loads with their defaults; a version-3 file without them is refused by name."""
    a, b = bt.Point(radius=1.0), bt.Point(radius=1.0, center=(0.8, 0.0, 0.0))
    tree = bt.controlled_blend([a, b], pairs=[(0, 1)])
    doc = json.loads(dumps(tree))
    for node in doc["nodes"]:
        if node["type"] == "controlled_blend":
            del node["params"]["groups"], node["params"]["n"]
    with pytest.raises(SceneError, match=r"params.groups: missing"):
        loads(json.dumps(doc))
    doc["version"] = 2
    assert loads(json.dumps(doc)) == tree


def _doc(root):
    return json.dumps({"format": "blobtree-scene", "version": 1, "root": root})


@pytest.mark.parametrize("text, where", [
    ("{not json", "$: not valid JSON"),
    (json.dumps({"format": "blobtree-scene", "version": 99, "root": {}}), "$.version"),
    (json.dumps({"format": "other", "version": 1}), "$.format"),
    (_doc({"type": "sphere"}), "$.root.type"),
    (_doc({"type": "blend", "children": [{"type": "point", "params": {"center": [0, 0, 0],
          "falloff": "soft_object"}}]}), "$.root.children[0].params.radius"),
    (_doc({"type": "point", "params": {"center": [0, 0], "radius": 1,
          "falloff": "soft_object"}}), "$.root.params.center"),
    (_doc({"type": "point", "params": {"center": [0, 0, 0], "radius": "1",
          "falloff": "soft_object"}}), "$.root.params.radius"),
    (_doc({"type": "point", "params": {"center": [0, 0, 0], "radius": -1,
          "falloff": "soft_object"}}), "$.root.params.radius: radius must be"),
    ('{"format": "blobtree-scene", "version": 1, "root": {"type": "point", "params": '
     '{"center": [NaN, 0, 0], "radius": 1, "falloff": "soft_object"}}}',
     "$.root.params.center[0]: NaN"),
    ("[" * 100_000 + "]" * 100_000, "$: nested too deeply"),
    (_doc({"type": "point", "params": {"center": [0, 0, 0], "radius": int("9" * 400),
          "falloff": "soft_object"}}), "$.root.params.radius: radius must be"),
    ('{"format": "blobtree-scene", "version": 1, "root": ' + "9" * 5000 + "}", "4300"),
    (_doc({"type": "x" * 1_000_000}), "$.root.type: unknown node type 'xxx"),
    (_doc({"type": "translate", "params": {"offset": [0, 0, 0]}, "children": []}),
     "$.root.children"),
    (_doc({"type": "point", "params": {"center": [0, 0, 0], "radius": 1,
          "falloff": "soft_object", "code": "import os"}}), "$.root.params.code"),
])
def test_malformed_files_name_the_path(text, where):
    with pytest.raises(SceneError) as e:
        loads(text)
    assert where in str(e.value)
    assert len(str(e.value)) < 500  # values are quoted shortened, never whole


def test_save_is_atomic(tmp_path, monkeypatch):
    path = tmp_path / "scene.json"
    path.write_text("old")

    def boom(*a, **k):
        raise RuntimeError("disk full")

    monkeypatch.setattr("blobtree.io.dumps", boom)
    with pytest.raises(RuntimeError):
        bt.save(bt.Point(), path)
    assert path.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["scene.json"]


def test_load_never_executes_code(tmp_path):
    path = tmp_path / "evil.json"
    path.write_text(_doc({"type": "__import__('os').system('touch x')"}))
    with pytest.raises(SceneError, match="unknown node type"):
        bt.load(path)


def _png_header(width: int, height: int) -> bytes:
    """A PNG whose header claims width x height pixels (its data is a few bytes)."""
    import struct
    import zlib

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2,
                                                                0, 0, 0))
            + chunk(b"IDAT", zlib.compress(b"\x00" * 16)) + chunk(b"IEND", b""))


@pytest.mark.parametrize("change, where", [
    (lambda d, m, k: m.pop("spiral"), "mapping: a helico mapping needs exactly the fields"),
    (lambda d, m, k: m["spiral"].pop("rho"), "spiral must be an object with exactly"),
    (lambda d, m, k: m.update(theta_max=1e300), "theta_max must be a finite number >= 1e-06"),
    (lambda d, m, k: m.update(max_steps=10**400), "max_steps must be an integer in"),
    (lambda d, m, k: d["images"].update({k: base64.b64encode(_png_header(100_000, 100_000))
                                         .decode()}), "image must have sides in [1, 4096]"),
    (lambda d, m, k: d["images"].update({k: base64.b64encode(_png_header(5000, 1)).decode()}),
     "got 5000x1"),
])
def test_bad_textures_in_scene_files_are_refused(change, where):
    """A bounding-surface mapping with a field missing or out of range, or an image whose header
    claims more pixels than allowed, is a SceneError naming the path, before any decoding."""
    tree = bt.Texture(bt.Point(radius=1.0), image=np.zeros((4, 4, 3)),
                      mapping=HelicoSurface())
    doc = json.loads(dumps(tree))
    node = next(n for n in doc["nodes"] if n["type"] == "texture")
    change(doc, node["params"]["mapping"]["helico"], next(iter(doc["images"])))
    with pytest.raises(SceneError) as e:
        loads(json.dumps(doc))
    assert where in str(e.value) and str(e.value).startswith("$.")
