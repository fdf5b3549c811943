"""blobtree: structured implicit surface modelling with the BlobTree (Galbraith, Prusinkiewicz
and Wyvill, "Modeling Murex cabritii sea shell with a structured implicit surface modeler").

Layers, each importing only those before it (docs/architecture.md): the model (``nodes``,
``fields``, ``helico``, ``texture``, ``io``, ``models``), the engine (``engine``), the mesher
and the ray tracer (``mesh``, ``render``), then scale-out (``distributed``), this API and the
command line.
"""

from . import engine, models, texture
from .api import polygonize, preview, render
from .engine import Program, compile_tree
from .io import load, save
from .live import explore
from .mesh import Mesh
from .nodes import *  # noqa: F403  (every node type and operator function, see nodes.__all__)
from .nodes import __all__ as _node_names
from .render import Camera, Light, RenderSettings, render_tile, save_image
from .runtime.allocator import pin_thresholds
from .texture import pigment as textures  # noqa: F401  (bt.textures: bt.texture.pigment)

__version__ = "0.2.0"

pin_thresholds()  # large arrays reused, not fresh pages each time (blobtree/runtime/allocator.py)

__all__ = [
    *_node_names, "Camera", "Light", "Mesh", "Program", "RenderSettings", "compile_tree",
    "engine", "explore", "load", "models", "polygonize", "preview", "render", "render_tile", "save",
    "save_image", "texture",
]
