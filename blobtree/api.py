"""The public functions that reach across layers: render and polygonize, on this machine or on a
Dask cluster (``scheduler=``)."""

from __future__ import annotations

from typing import Any

import numpy as np

from . import distributed
from .mesh import Mesh
from .mesh import polygonize as _polygonize
from .render import render as _render


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
