"""The BlobTree's node types, one module each, registered in ``base.REGISTRY`` on import.

To add a node type, write its module (see docs/extending.md) and import it here: its import
registers it, and the engine, scene files and tests pick it up from the registry.
"""

from .affine import Rotate, Scale, Translate
from .bend import Bend
from .blend import Blend, blend
from .color import Color
from .cone import Cone, Segment
from .controlled_blend import ControlledBlend, controlled_blend
from .cylinder import Cylinder
from .difference import Difference, difference
from .ellipsoid import Ellipsoid
from .gradient_blend import GradientBlend, gradient_blend
from .intersection import Intersection, intersection
from .kinds import Affine, Operator, Paint, Primitive, Unary
from .node import ISO, REGISTRY, Node, check_points
from .point import Point
from .ring import Disc, Torus
from .super_blend import SuperBlend, super_blend
from .taper import Taper
from .texture import Texture
from .twist import Twist
from .union import Union, union
from .warp import Warp

#: Every concrete node class by its scene-file name (the registry).
NODE_TYPES = REGISTRY

__all__ = [
    "Affine", "Bend", "Blend", "Color", "Cone", "ControlledBlend", "Cylinder", "Difference",
    "Disc", "Ellipsoid", "GradientBlend", "ISO", "Intersection", "NODE_TYPES", "Node", "Operator",
    "Paint", "Point", "Primitive", "REGISTRY", "Rotate", "Scale", "Segment", "SuperBlend", "Taper",
    "Texture", "Torus", "Translate", "Twist", "Unary", "Union", "Warp", "blend", "check_points",
    "controlled_blend", "difference", "gradient_blend", "intersection", "super_blend", "union",
]
