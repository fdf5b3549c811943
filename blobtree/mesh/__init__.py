"""The polygonizer: watertight triangle meshes of a BlobTree at any resolution."""

from .export import Mesh

__all__ = ["Mesh", "polygonize"]


def __getattr__(name: str):
    """``polygonize`` is imported on first use (its kernels are not needed to load a mesh)."""
    if name == "polygonize":
        from .polygonizer import polygonize

        return polygonize
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
