"""blobtree: structured implicit surface modelling with the BlobTree (Galbraith, Prusinkiewicz
and Wyvill, "Modeling Murex cabritii sea shell with a structured implicit surface modeler")."""

from . import models
from .compile import Program, compile_tree
from .io import load, save
from .mesh import Mesh, polygonize
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

__all__ = [
    "ISO", "Blend", "Color", "Cone", "ControlledBlend", "Cylinder", "Difference", "Disc",
    "Intersection", "Node", "Point", "Primitive", "Program", "Segment", "SuperBlend", "Torus",
    "Union", "blend", "compile_tree", "controlled_blend", "difference", "intersection", "load",
    "Camera", "Light", "Mesh", "RenderSettings", "models", "polygonize", "render",
    "render_tile", "save", "save_image", "super_blend", "union",
]
