"""Scene files: a versioned JSON format, derived from the node specs, that round-trips every tree.

A scene file is data: loading builds nodes from the registry of node types and never executes
code.  Every error names the JSON path of the problem, e.g. ``$.nodes[3].params.radius``.

Version 4 (written) is version 3 with the difference's ``smooth``; version 3 is version 2 with
the controlled blend's ``groups`` and ``n``.  A file of an earlier version lacks the parameters
added since (``Param.since``), which take their defaults.

Version 2 lists each distinct node once, children before parents, and refers to
children by their index in that list, so a subtree used in several places (the paper's
P(B, theta) reuses B) is stored once, and no depth of nesting strains the reader::

    {"format": "blobtree-scene", "version": 4, "images": {KEY: BASE64_PNG, ...},
     "nodes": [{"type": "point", "params": {...}}, {"type": "scale", "params": {...},
                "children": [0]}, ...],
     "root": 1}

Version 1 (still read) nests each node's children inside it under ``"root"``.
"""

from __future__ import annotations

import json
import os
from typing import Any

import numpy as np

from .checks import short_repr
from .nodes import REGISTRY, Node
from .nodes.node import arity_words
from .output import write_file
from .texture.mapping import image_from_text, image_to_text

FORMAT = "blobtree-scene"
VERSION = 4


class SceneError(ValueError):
    """A scene file that cannot be loaded; the message starts with the JSON path."""


def schema() -> dict[str, dict[str, str]]:
    """Every node type's parameters and their kinds, as the scene file spells them."""
    return {name: {p.name: p.kind.schema for p in cls.PARAMS} for name, cls in REGISTRY.items()}


def to_dict(tree: Node) -> dict[str, Any]:
    """The scene document of a tree (the current version)."""
    images: dict[str, np.ndarray] = {}
    entries: list[dict[str, Any]] = []
    index: dict[int, int] = {}
    by_key: dict[str, int] = {}
    for node in tree.unique():
        k = by_key.get(node.key)
        if k is None:
            entry: dict[str, Any] = {"type": node.TYPE, "params": node.params(images)}
            if node.children:
                entry["children"] = [index[id(c)] for c in node.children]
            k = by_key[node.key] = len(entries)
            entries.append(entry)
        index[id(node)] = k
    doc: dict[str, Any] = {"format": FORMAT, "version": VERSION}
    if images:
        doc["images"] = {key: image_to_text(img) for key, img in images.items()}
    doc["nodes"] = entries
    doc["root"] = index[id(tree)]
    return doc


def dumps(tree: Node) -> str:
    return json.dumps(to_dict(tree), allow_nan=False, separators=(",", ":"))


def save(tree: Node, path: str | os.PathLike) -> None:
    """Write ``tree`` as a JSON scene file (``-``: standard output; see
    :func:`blobtree.output.write_file`)."""
    if not isinstance(tree, Node):
        raise ValueError(f"tree must be a BlobTree node, got {type(tree).__name__}")
    write_file(path, dumps(tree).encode("utf-8"))


class _NonFinite(str):
    """Where a NaN or Infinity literal was in the text (refused once its path is known)."""


def _non_finite_path(doc: Any) -> str | None:
    """The JSON path of the first NaN or Infinity literal in ``doc``, or None."""
    todo: list[tuple[Any, str]] = [(doc, "$")]
    while todo:
        v, path = todo.pop()
        if isinstance(v, _NonFinite):
            return path
        if isinstance(v, dict):
            todo.extend((x, f"{path}.{_short_key(k)}") for k, x in reversed(v.items()))
        elif isinstance(v, list):
            todo.extend((x, f"{path}[{i}]") for i, x in reversed(list(enumerate(v))))
    return None


def _short_key(key: str) -> str:
    return key if len(key) <= 40 else key[:37] + "..."


def loads(text: str) -> Node:
    """Build a tree from scene-file text."""
    try:
        doc = json.loads(text, parse_constant=_NonFinite)
    except json.JSONDecodeError as e:
        raise SceneError(f"$: not valid JSON: {e}") from None
    except RecursionError:
        raise SceneError("$: nested too deeply to read") from None
    except ValueError:  # the only other error json raises: an over-long integer literal
        raise SceneError("$: an integer literal has more digits than Python reads (4300)"
                         ) from None
    path = _non_finite_path(doc)
    if path is not None:
        raise SceneError(f"{path}: NaN and Infinity are not allowed in a scene file (numbers "
                         "must be finite)")
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
        raise SceneError(f"$.format: expected {FORMAT!r}, got {short_repr(doc.get('format'))}")
    version = doc.get("version")
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        raise SceneError(f"$.version: expected a positive integer, got {short_repr(version)}")
    if version > VERSION:
        raise SceneError(
            f"$.version: file version {version} is newer than this blobtree reads ({VERSION}); "
            "upgrade blobtree")
    known = {"format", "version", "images", "root"} | ({"nodes"} if version >= 2 else set())
    extra = set(doc) - known
    if extra:
        raise SceneError(f"$: unknown key(s) {short_repr(sorted(extra))}")
    if "root" not in doc:
        raise SceneError("$.root: missing")
    raw = doc.get("images", {})
    if not isinstance(raw, dict) or not all(isinstance(v, str) for v in raw.values()):
        raise SceneError("$.images: expected an object of base64 PNG strings")
    images: dict[str, Any] = {}
    for key, text in raw.items():
        try:
            images[key] = image_from_text(text)
        except ValueError as e:
            raise SceneError(f"$.images.{_short_key(key)}: {e}") from None
    if version == 1:
        try:
            return _build_nested(doc["root"], "$.root", images)
        except RecursionError:
            raise SceneError("$.root: nested too deeply to read (save it again as version 2)"
                             ) from None
    return _build_flat(doc, images, version)


def _kind(v: Any) -> str:
    return {dict: "an object", list: "a list", str: "a string", bool: "a boolean",
            type(None): "null"}.get(type(v), "a number")


def _build_flat(doc: dict[str, Any], images: dict[str, Any], version: int) -> Node:
    entries = doc.get("nodes")
    if not isinstance(entries, list) or not entries:
        raise SceneError("$.nodes: expected a non-empty list of nodes")
    built: list[Node] = []
    for i, d in enumerate(entries):
        path = f"$.nodes[{i}]"
        refs = d.get("children", []) if isinstance(d, dict) else []
        if not isinstance(refs, list):
            raise SceneError(f"{path}.children: expected a list of node indices, "
                             f"got {_kind(refs)}")
        children = []
        for j, r in enumerate(refs):
            if not (isinstance(r, int) and not isinstance(r, bool) and 0 <= r < i):
                raise SceneError(f"{path}.children[{j}]: expected the index of an earlier "
                                 f"node (0 to {i - 1}), got {json.dumps(r)[:40]}")
            children.append(built[r])
        built.append(_make(d, path, children, images, version))
    root = doc["root"]
    if not (isinstance(root, int) and not isinstance(root, bool) and 0 <= root < len(built)):
        raise SceneError(f"$.root: expected a node index in [0, {len(built)}), got "
                         f"{json.dumps(root)[:40]}")
    return built[root]


def _build_nested(d: Any, path: str, images: dict[str, Any]) -> Node:
    raw = d.get("children", []) if isinstance(d, dict) else []
    if not isinstance(raw, list):
        raise SceneError(f"{path}.children: expected a list, got {_kind(raw)}")
    children = [_build_nested(c, f"{path}.children[{i}]", images) for i, c in enumerate(raw)]
    return _make(d, path, children, images, 1)


def _make(d: Any, path: str, children: list[Node], images: dict[str, Any],
          version: int) -> Node:
    """One node from its JSON object and its built children (a file of ``version`` may lack
    the parameters added later, ``Param.since``: they take their defaults)."""
    if not isinstance(d, dict):
        raise SceneError(f"{path}: expected a node object, got {_kind(d)}")
    t = d.get("type")
    cls = REGISTRY.get(t) if isinstance(t, str) else None
    if cls is None:
        raise SceneError(f"{path}.type: unknown node type {short_repr(t)}; "
                         f"known: {sorted(REGISTRY)}")
    extra = set(d) - {"type", "params", "children"}
    if extra:
        raise SceneError(f"{path}: unknown key(s) {short_repr(sorted(extra))}")
    params = d.get("params", {})
    if not isinstance(params, dict):
        raise SceneError(f"{path}.params: expected an object, got {_kind(params)}")
    spec = {p.name: p for p in cls.PARAMS}
    for key in params:
        if key not in spec:
            raise SceneError(f"{path}.params.{_short_key(key)}: unknown parameter for {t!r}; "
                             f"expected {sorted(spec)}")
    values = {}
    for name, p in spec.items():
        if name not in params:
            if p.since > version:  # a parameter newer than the file: its default
                continue
            raise SceneError(f"{path}.params.{name}: missing ({p.kind.schema})")
        try:
            values[name] = p.kind.check(name, p.kind.from_json(name, params[name], images))
        except (ValueError, TypeError) as e:
            raise SceneError(f"{path}.params.{name}: {e}") from None
    lo, hi = cls.ARITY
    if len(children) < lo or (hi is not None and len(children) > hi):
        raise SceneError(f"{path}.children: {t!r} takes {arity_words(lo, hi)} children, got "
                         f"{len(children)}")
    try:
        return cls(*children, **values)
    except (ValueError, TypeError) as e:
        raise SceneError(f"{path}: {e}") from None
