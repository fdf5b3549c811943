"""Writing images: whole or not at all."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

_FORMATS = {".png": "PNG", ".jpg": "JPEG", ".jpeg": "JPEG", ".tif": "TIFF", ".tiff": "TIFF",
            ".bmp": "BMP", ".ppm": "PPM"}


def save_image(img: np.ndarray, path: str | os.PathLike) -> Path:
    """Write an (H, W, 3) uint8 image (PNG, or JPEG/TIFF/BMP/PPM by suffix) atomically: to a
    temporary file beside ``path``, then renamed over it.  Returns the path."""
    path = Path(path)
    fmt = _FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise ValueError(f"path must end in one of {sorted(_FORMATS)}, got {str(path)!r}")
    img = np.asarray(img)
    if img.dtype != np.uint8 or img.ndim != 3 or img.shape[2] != 3 or 0 in img.shape:
        raise ValueError(f"img must be a non-empty (H, W, 3) uint8 array, got shape {img.shape} "
                         f"dtype {img.dtype}")
    directory = path.parent if str(path.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
    try:
        with os.fdopen(fd, "wb") as fh:
            Image.fromarray(img, "RGB").save(fh, format=fmt)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise
    return path
