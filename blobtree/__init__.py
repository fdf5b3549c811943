"""blobtree: structured implicit surface modelling with the BlobTree (Galbraith, Prusinkiewicz
and Wyvill, "Modeling Murex cabritii sea shell with a structured implicit surface modeler")."""

from . import models
from .compile import Program, compile_tree
from .io import load, save
from .nodes import (
    ISO,
    Blend,
    Color,
    Cone,
    ControlledBlend,
    Cylinder,
    Difference,
    Disc,
    Intersection,
    Node,
    Point,
    Primitive,
    Segment,
    SuperBlend,
    Torus,
    Union,
    blend,
    controlled_blend,
    difference,
    intersection,
    super_blend,
    union,
)
from .render import Camera, Light, RenderSettings, render, render_tile, save_image

__version__ = "0.1.0"

#: Names imported on first use (the mesher is not needed to render or evaluate).
_LAZY = {"Mesh": "mesh", "polygonize": "mesh"}


def __getattr__(name: str):
    """Import the lazily loaded names of :data:`_LAZY` on first access."""
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

__all__ = [
    "ISO", "Blend", "Color", "Cone", "ControlledBlend", "Cylinder", "Difference", "Disc",
    "Intersection", "Node", "Point", "Primitive", "Program", "Segment", "SuperBlend", "Torus",
    "Union", "blend", "compile_tree", "controlled_blend", "difference", "intersection", "load",
    "Camera", "Light", "Mesh", "RenderSettings", "models", "polygonize", "render",
    "render_tile", "save", "save_image", "super_blend", "union",
]
