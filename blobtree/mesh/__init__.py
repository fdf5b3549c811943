"""The polygonizer: watertight triangle meshes of a BlobTree at any resolution."""

from .export import Mesh
from .polygonizer import polygonize

__all__ = ["Mesh", "polygonize"]
