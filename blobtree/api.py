"""The public functions that reach across layers: render and polygonize, on this machine or on a
Dask cluster (``scheduler=``)."""

from __future__ import annotations

import html
from typing import Any

import numpy as np

from . import distributed
from .mesh import Mesh
from .mesh import polygonize as _polygonize
from .mesh.web import page
from .nodes import Node
from .render import render as _render
from .render.camera import seen_camera
from .render.image import encode_png


def render(tree, width: int, height: int, *args: Any, scheduler=None,
           **options: Any) -> np.ndarray:
    """Ray-trace ``tree`` into an (height, width, 3) uint8 sRGB image: see
    :func:`blobtree.render.render` for the arguments.  ``scheduler`` (a Dask address
    "tcp://HOST:PORT" or a ``distributed.Client``; ``tree`` must then be a tree, not a program)
    renders the tiles on that cluster instead, with the same bytes."""
    if scheduler is None:
        return _render(tree, width, height, *args, **options)
    return distributed.render(scheduler, tree, width, height, *args, **options)


def polygonize(tree, resolution: int | None = None, *, scheduler=None, **options: Any) -> Mesh:
    """Triangulate the 0.5 iso-surface of ``tree`` into a closed, welded, oriented mesh: see
    :func:`blobtree.mesh.polygonize` for the arguments.  ``scheduler`` (a Dask address or
    ``distributed.Client``) evaluates the field on that cluster; the mesh is the same."""
    if scheduler is None:
        return _polygonize(tree, resolution, **options)
    return distributed.polygonize(scheduler, tree, resolution=resolution, **options)


#: Side in pixels of a notebook preview.
PREVIEW_SIZE = 256


def preview(tree: Node, size: int = PREVIEW_SIZE, **options: Any) -> np.ndarray:
    """A quick picture of ``tree`` (what a notebook shows for a node): ``size`` pixels square,
    the studio look without shadow rays, framed along the view :meth:`Node.shown` gave the tree
    (a three-quarter view otherwise); ``options`` go to :func:`render`."""
    prog = tree.program()
    if "camera" not in options:
        options["camera"] = seen_camera(tree, prog, size, size)
    options.setdefault("shadows", False)
    return _render(prog, size, size, **options)


def _node_png(node: Node) -> bytes:
    """PNG bytes of :func:`preview` (Jupyter's ``_repr_png_``)."""
    return encode_png(preview(node))


def _mesh_html(mesh: Mesh) -> str:
    """The mesh's 3D page in an iframe (Jupyter's ``_repr_html_``)."""
    if len(mesh.faces) == 0:
        return "<p>an empty mesh (no triangles)</p>"
    text = html.escape(page(mesh), quote=True)
    return (f'<iframe srcdoc="{text}" width="100%" height="480" style="border: none" '
            f'title="3D view of the mesh"></iframe>')


# Notebook display, installed here, where rendering and meshing are available: a node shows a
# preview picture, a mesh an orbit viewer.
Node._repr_png_ = _node_png
Mesh._repr_html_ = _mesh_html
