"""Scene files: a versioned JSON format that round-trips every node type exactly.

A scene file is data: loading builds nodes from a fixed table of types and never executes code.
Every error names the JSON path of the problem, e.g. ``$.root.children[3].params.radius``.
"""

from __future__ import annotations

import json
import math
import os
from typing import Any

from .files import atomic_path
from .nodes import NODE_TYPES, Node, Operator, Primitive, Unary
from .texture import HelicoSurface, image_from_text

FORMAT = "blobtree-scene"
VERSION = 1

# Parameter kinds per node type (the file format's schema).
_NUM, _VEC, _STR, _AXIS, _PAIRS = "number", "3-vector", "string", "axis", "list of index pairs"
_MAP = "mapping ('primitive' or {\"helico\": {...}})"
_PRIM = {"radius": _NUM, "falloff": _STR}
SCHEMA: dict[str, dict[str, str]] = {
    "point": {"center": _VEC, **_PRIM},
    "segment": {"a": _VEC, "b": _VEC, **_PRIM},
    "cone": {"a": _VEC, "b": _VEC, "radius_a": _NUM, "radius_b": _NUM, "falloff": _STR},
    "torus": {"major_radius": _NUM, "center": _VEC, **_PRIM},
    "disc": {"disc_radius": _NUM, "center": _VEC, **_PRIM},
    "cylinder": {"a": _VEC, "b": _VEC, "cylinder_radius": _NUM, **_PRIM},
    "blend": {}, "union": {}, "intersection": {}, "difference": {},
    "super_blend": {"n": _NUM},
    "controlled_blend": {"pairs": _PAIRS},
    "translate": {"offset": _VEC},
    "scale": {"factors": _VEC},
    "rotate": {"axis": _AXIS, "degrees": _NUM},
    "bend": {"degrees": _NUM, "length": _NUM, "axis": _STR, "toward": _STR},
    "twist": {"degrees_per_unit": _NUM, "axis": _STR},
    "taper": {"rate": _NUM, "axis": _STR},
    "color": {"rgb": _VEC},
    "texture": {"image": _STR, "mapping": _MAP, "wrap": _STR},
}
assert set(SCHEMA) == set(NODE_TYPES)


class SceneError(ValueError):
    """A scene file that cannot be loaded; the message starts with the JSON path."""


def to_dict(tree: Node) -> dict[str, Any]:
    """The scene document of a tree."""
    return {"format": FORMAT, "version": VERSION, "root": _node_dict(tree)}


def _node_dict(node: Node) -> dict[str, Any]:
    out: dict[str, Any] = {"type": node.TYPE, "params": node.params()}
    if node.children:
        out["children"] = [_node_dict(c) for c in node.children]
    return out


def dumps(tree: Node) -> str:
    return json.dumps(to_dict(tree), allow_nan=False, separators=(",", ":"))


def save(tree: Node, path: str | os.PathLike) -> None:
    """Write ``tree`` as a JSON scene file, atomically."""
    if not isinstance(tree, Node):
        raise ValueError(f"tree must be a BlobTree node, got {type(tree).__name__}")
    text = dumps(tree)
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def _reject_constant(name: str) -> Any:
    raise SceneError(f"$: {name} is not allowed in a scene file (numbers must be finite)")


def loads(text: str) -> Node:
    """Build a tree from scene-file text."""
    try:
        doc = json.loads(text, parse_constant=_reject_constant)
    except json.JSONDecodeError as e:
        raise SceneError(f"$: not valid JSON: {e}") from None
    return from_dict(doc)


def load(path: str | os.PathLike) -> Node:
    """Read a JSON scene file written by :func:`save` (or by hand)."""
    try:
        with open(path, encoding="utf-8") as fh:
            text = fh.read()
    except UnicodeDecodeError:
        raise SceneError(f"$: {path} is not a UTF-8 text file") from None
    return loads(text)


def from_dict(doc: Any) -> Node:
    if not isinstance(doc, dict):
        raise SceneError(f"$: expected an object, got {_kind(doc)}")
    if doc.get("format") != FORMAT:
        raise SceneError(f"$.format: expected {FORMAT!r}, got {doc.get('format')!r}")
    version = doc.get("version")
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        raise SceneError(f"$.version: expected a positive integer, got {version!r}")
    if version > VERSION:
        raise SceneError(
            f"$.version: file version {version} is newer than this blobtree reads ({VERSION}); "
            "upgrade blobtree"
        )
    if "root" not in doc:
        raise SceneError("$.root: missing")
    return _build(doc["root"], "$.root")


def _kind(v: Any) -> str:
    return {dict: "an object", list: "a list", str: "a string", bool: "a boolean",
            type(None): "null"}.get(type(v), "a number")


def _check_value(kind: str, v: Any, path: str) -> Any:
    def is_num(x: Any) -> bool:
        return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)

    ok = {
        _NUM: lambda: is_num(v),
        _VEC: lambda: isinstance(v, list) and len(v) == 3 and all(is_num(x) for x in v),
        _STR: lambda: isinstance(v, str),
        _AXIS: lambda: isinstance(v, str) or (
            isinstance(v, list) and len(v) == 3 and all(is_num(x) for x in v)),
        _MAP: lambda: v == "primitive" or (isinstance(v, dict) and list(v) == ["helico"]
                                           and isinstance(v["helico"], dict)),
        _PAIRS: lambda: isinstance(v, list) and all(
            isinstance(p, list) and len(p) == 2
            and all(isinstance(x, int) and not isinstance(x, bool) for x in p) for p in v),
    }[kind]()
    if not ok:
        raise SceneError(f"{path}: expected {kind}, got {json.dumps(v)[:60]}")
    return v


def _build(d: Any, path: str) -> Node:
    if not isinstance(d, dict):
        raise SceneError(f"{path}: expected a node object, got {_kind(d)}")
    t = d.get("type")
    if t not in NODE_TYPES:
        raise SceneError(f"{path}.type: unknown node type {t!r}; known: {sorted(NODE_TYPES)}")
    extra = set(d) - {"type", "params", "children"}
    if extra:
        raise SceneError(f"{path}: unknown key(s) {sorted(extra)}")
    params = d.get("params", {})
    if not isinstance(params, dict):
        raise SceneError(f"{path}.params: expected an object, got {_kind(params)}")
    schema = SCHEMA[t]
    for key in params:
        if key not in schema:
            raise SceneError(f"{path}.params.{key}: unknown parameter for {t!r}; "
                             f"expected {sorted(schema)}")
    for key, kind in schema.items():
        if key not in params:
            raise SceneError(f"{path}.params.{key}: missing ({kind})")
        _check_value(kind, params[key], f"{path}.params.{key}")
    cls = NODE_TYPES[t]
    raw_children = d.get("children", [])
    if not isinstance(raw_children, list):
        raise SceneError(f"{path}.children: expected a list, got {_kind(raw_children)}")
    if issubclass(cls, Primitive) and raw_children:
        raise SceneError(f"{path}.children: a {t!r} primitive has no children")
    if issubclass(cls, Unary) and len(raw_children) != 1:
        raise SceneError(f"{path}.children: {t!r} takes exactly one child, "
                         f"got {len(raw_children)}")
    children = [_build(c, f"{path}.children[{i}]") for i, c in enumerate(raw_children)]
    try:
        if t == "texture":  # embedded data only: a scene file never names files to read
            params = dict(params, image=image_from_text(params["image"]))
            if params["mapping"] != "primitive":
                params["mapping"] = HelicoSurface.from_dict(params["mapping"]["helico"])
        if issubclass(cls, Operator):
            return cls(*children, **params)
        if issubclass(cls, Unary):
            return cls(children[0], **params)
        return cls(**params)
    except (ValueError, TypeError) as e:
        raise SceneError(f"{path}: {e}") from None
