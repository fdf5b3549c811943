"""The triangle mesh returned by the polygonizer, its checks and its atomic export."""

from __future__ import annotations

import math
import os
import signal
import sys
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..checks import Number, positive
from ..geometry import axis_vector, rotation_onto
from ..output import file_format, write_file
from ..runtime.jit import cached
from ..runtime.threads import parallel_for

#: The mesh formats, each named as its extension without the dot; PLY and STL are encoded here
#: (``ENCODERS``), the others by trimesh (3MF's unit is the millimetre)
FORMATS = {name: name for name in ("ply", "obj", "stl", "glb", "3mf")}
#: The nozzle width print reports and print files count against, in millimetres (the common one).
NOZZLE_MM = 0.4
#: Print files drop sealed bubbles enclosing less than this, in mm^3: a cube one nozzle width on
#: a side, a space no extruded line fits into, which the printer fills anyway (and which a slicer
#: would count as a part of its own).  The shipped shells' bubbles are about 1e-4 mm^3 at 80 mm.
BUBBLE_MM3 = NOZZLE_MM**3
#: glTF's up and a printer's (3MF's) up
Y, Z = np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0])


def import_trimesh():
    """Import trimesh with Ctrl-C held back until the import is over, then delivered.

    trimesh imports its optional dependencies under ``except BaseException``, which would swallow
    a KeyboardInterrupt arriving meanwhile and let a command go on to write its output.
    """
    previous = signal.getsignal(signal.SIGINT)
    if "trimesh" in sys.modules or not callable(previous) \
            or threading.current_thread() is not threading.main_thread():
        import trimesh  # (SIGINT ignored or default: nothing to hold back)
        return trimesh
    pressed: list[int] = []
    signal.signal(signal.SIGINT, lambda signum, frame: pressed.append(signum))
    try:
        import trimesh
    finally:
        signal.signal(signal.SIGINT, previous)
    if pressed:
        previous(signal.SIGINT, None)  # the default handler raises KeyboardInterrupt
    return trimesh


def _rgba8(colors: np.ndarray) -> np.ndarray:
    """Colours in [0, 1] as opaque 8-bit RGBA rows."""
    rgba = np.empty((len(colors), 4), dtype=np.uint8)
    rgba[:, :3] = np.round(np.clip(colors, 0.0, 1.0) * 255.0)
    rgba[:, 3] = 255
    return rgba


def _ply_bytes(mesh: Mesh) -> bytes:
    """Binary little-endian PLY: float positions and normals, 8-bit RGBA colours, int faces."""
    vertex = np.empty(len(mesh.vertices), dtype=[("p", "<f4", 3), ("n", "<f4", 3),
                                                 ("c", "u1", 4)])
    vertex["p"], vertex["n"], vertex["c"] = mesh.vertices, mesh.normals, _rgba8(mesh.colors)
    face = np.empty(len(mesh.faces), dtype=[("k", "u1"), ("v", "<i4", 3)])
    face["k"], face["v"] = 3, mesh.faces
    header = "\n".join([
        "ply", "format binary_little_endian 1.0", "comment blobtree",
        f"element vertex {len(vertex)}",
        *(f"property float {a}" for a in ("x", "y", "z", "nx", "ny", "nz")),
        *(f"property uchar {c}" for c in ("red", "green", "blue", "alpha")),
        f"element face {len(face)}", "property list uchar int vertex_indices", "end_header", ""])
    return header.encode("ascii") + vertex.tobytes() + face.tobytes()


#: a binary STL triangle: unit normal, three corners, a zero 16-bit attribute count (50 bytes)
_STL_RECORD = np.dtype([("normal", "<f4", 3), ("corners", "<f4", 9), ("attribute", "<u2")])


@cached(nogil=True)
def _stl_floats(start, stop, vertices, faces, out):
    """For faces ``start:stop``: the unit normal (zero for a degenerate face) and the three
    corners, as the 12 floats of an STL record."""
    for f in range(start, stop):
        a, b, c = faces[f, 0], faces[f, 1], faces[f, 2]
        u0, u1, u2 = (vertices[b, 0] - vertices[a, 0], vertices[b, 1] - vertices[a, 1],
                      vertices[b, 2] - vertices[a, 2])
        v0, v1, v2 = (vertices[c, 0] - vertices[a, 0], vertices[c, 1] - vertices[a, 1],
                      vertices[c, 2] - vertices[a, 2])
        n0, n1, n2 = u1 * v2 - u2 * v1, u2 * v0 - u0 * v2, u0 * v1 - u1 * v0
        length = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        scale = 1.0 / length if length > 0.0 else 0.0
        out[f, 0], out[f, 1], out[f, 2] = n0 * scale, n1 * scale, n2 * scale
        for k in range(3):
            for d in range(3):
                out[f, 3 + 3 * k + d] = vertices[faces[f, k], d]


def _stl_bytes(mesh: Mesh) -> np.ndarray:
    """Binary STL: an 80-byte header, the triangle count, then a 50-byte record per triangle
    (``_STL_RECORD``), as one byte array."""
    n = len(mesh.faces)
    floats = np.empty((n, 12), dtype=np.float32)
    parallel_for(_stl_floats, n, np.ascontiguousarray(mesh.vertices, dtype=np.float64),
                 np.ascontiguousarray(mesh.faces), floats)
    data = np.empty(84 + n * _STL_RECORD.itemsize, dtype=np.uint8)
    data[:80] = np.frombuffer(b"blobtree".ljust(80, b" "), dtype=np.uint8)
    data[80:84] = np.frombuffer(np.uint32(n).tobytes(), dtype=np.uint8)
    records = data[84:].view(_STL_RECORD)
    records["normal"], records["corners"], records["attribute"] = floats[:, :3], floats[:, 3:], 0
    return data


#: format -> encoder of the formats written here (no trimesh needed); each returns the file's
#: bytes (``bytes`` or a uint8 array, both written as they are)
ENCODERS = {"ply": _ply_bytes, "stl": _stl_bytes}


@cached
def _union_faces(faces, nverts):
    """Union-find over vertices joined by faces; returns each vertex's root."""
    parent = np.arange(nverts)

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for f in range(faces.shape[0]):
        r0 = find(faces[f, 0])
        for k in range(1, 3):
            rk = find(faces[f, k])
            if rk != r0:
                parent[rk] = r0
    for v in range(nverts):
        parent[v] = find(v)
    return parent


@cached
def _edges_pair_up(faces, nverts):
    """Whether every directed edge of the faces occurs once and its reverse once.  The edges
    are bucketed by their lower vertex (a counting sort); within a bucket, each edge must meet
    exactly one other edge to the same upper vertex, running the other way."""
    count = np.zeros(nverts + 1, dtype=np.int64)
    for f in range(faces.shape[0]):
        for k in range(3):
            count[min(faces[f, k], faces[f, (k + 1) % 3]) + 1] += 1
    for v in range(nverts):
        count[v + 1] += count[v]
    fill = count[:-1].copy()
    upper = np.empty(3 * faces.shape[0], dtype=faces.dtype)
    forward = np.empty(3 * faces.shape[0], dtype=np.bool_)
    for f in range(faces.shape[0]):
        for k in range(3):
            a, b = faces[f, k], faces[f, (k + 1) % 3]
            lo = min(a, b)
            upper[fill[lo]], forward[fill[lo]] = max(a, b), a < b
            fill[lo] += 1
    for v in range(nverts):
        for i in range(count[v], count[v + 1]):
            same = other = 0
            for j in range(count[v], count[v + 1]):
                if j != i and upper[j] == upper[i]:
                    if forward[j] == forward[i]:
                        same += 1
                    else:
                        other += 1
            if same != 0 or other != 1:
                return False
    return True


@cached
def _piece_volumes(vertices, faces, pieces, n):
    """Per piece, the sum over its faces of the signed volume of the tetrahedron the face makes
    with the origin, a . (b x c) / 6 (the divergence theorem)."""
    out = np.zeros(n)
    for f in range(faces.shape[0]):
        a, b, c = vertices[faces[f, 0]], vertices[faces[f, 1]], vertices[faces[f, 2]]
        out[pieces[f]] += (a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2])
                           + a[2] * (b[0] * c[1] - b[1] * c[0])) / 6.0
    return out


@dataclass
class Mesh:
    """An indexed triangle mesh with per-vertex normals and colours (RGB in [0, 1]).

    Faces are wound counter-clockwise seen from outside (their right-hand normal points out).
    """

    vertices: np.ndarray  # (V, 3) float64
    faces: np.ndarray  # (F, 3) int
    normals: np.ndarray  # (V, 3) float64, unit, outward
    colors: np.ndarray  # (V, 3) float64 in [0, 1]

    @classmethod
    def empty(cls) -> Mesh:
        """A mesh with no vertices and no faces."""
        z = np.zeros((0, 3))
        return cls(z, np.zeros((0, 3), dtype=np.int32), z, z)

    @property
    def is_watertight(self) -> bool:
        """Closed, oriented 2-manifold at the edges: each directed edge occurs once and its
        reverse once, i.e. every edge joins exactly two faces of opposite winding."""
        if len(self.faces) == 0:
            return False
        return bool(_edges_pair_up(np.ascontiguousarray(self.faces), len(self.vertices)))

    @property
    def euler_characteristic(self) -> int:
        """V - E + F (2 per sphere-like closed component)."""
        f = self.faces.astype(np.int64)
        a, b = f.reshape(-1), np.roll(f, -1, axis=1).reshape(-1)
        edges = len(np.unique(np.minimum(a, b) * len(self.vertices) + np.maximum(a, b)))
        used = len(np.unique(self.faces))
        return used - edges + len(self.faces)

    def component_count(self) -> int:
        """Number of connected pieces (faces sharing a vertex are connected)."""
        return 0 if len(self.faces) == 0 else int(self._pieces().max()) + 1

    def solid_count(self) -> int:
        """Number of separate solids (see :meth:`solids_and_bubbles`)."""
        return self.solids_and_bubbles()[0]

    def solids_and_bubbles(self) -> tuple[int, int]:
        """(solids, bubbles): the closed pieces wound outward (enclosing positive volume) and
        those wound inward (negative volume), each the wall of an empty space sealed inside a
        solid, which belongs to that solid."""
        volumes = self.piece_volumes()
        return int((volumes > 0.0).sum()), int((volumes < 0.0).sum())

    def _pieces(self) -> np.ndarray:
        """Each face's piece, numbered from 0."""
        roots = _union_faces(np.ascontiguousarray(self.faces, dtype=np.int64), len(self.vertices))
        return np.unique(roots[self.faces[:, 0]], return_inverse=True)[1].reshape(-1)

    def piece_volumes(self, pieces: np.ndarray | None = None) -> np.ndarray:
        """The signed volume each connected piece encloses (divergence theorem; negative for a
        closed piece wound inward, such as a bubble inside the solid); ``pieces``: each face's
        piece, if already known."""
        if len(self.faces) == 0:
            return np.zeros(0)
        pieces = self._pieces() if pieces is None else pieces
        return _piece_volumes(np.ascontiguousarray(self.vertices, dtype=np.float64),
                              np.ascontiguousarray(self.faces, dtype=np.int64), pieces,
                              int(pieces.max()) + 1)

    def without_small_pieces(self, min_volume: float,
                             bubbles_only: bool = False) -> tuple[Mesh, int]:
        """The mesh without the pieces enclosing less than ``min_volume`` (in absolute value:
        debris and bubbles alike, or only bubbles, the pieces wound inward), and how many were
        dropped."""
        min_volume = Number(lo=0.0).check("min_volume", min_volume)
        if len(self.faces) == 0:
            return self, 0
        pieces = self._pieces()
        volumes = self.piece_volumes(pieces)
        small = np.abs(volumes) < min_volume
        if bubbles_only:
            small &= volumes < 0.0
        keep = ~small[pieces]
        used = np.unique(self.faces[keep])
        index = np.full(len(self.vertices), -1, dtype=np.int64)
        index[used] = np.arange(len(used))
        faces = index[self.faces[keep]].astype(self.faces.dtype)
        return (Mesh(self.vertices[used], faces, self.normals[used], self.colors[used]),
                int(small.sum()))

    def scaled(self, factor: float) -> Mesh:
        """The mesh scaled by ``factor`` about the origin (normals and colours unchanged)."""
        factor = positive().check("factor", factor)
        return Mesh(self.vertices * factor, self.faces, self.normals, self.colors)

    def extent(self, direction=Y) -> float:
        """How long the mesh is along ``direction`` (a non-zero 3-vector)."""
        if len(self.vertices) == 0:
            return 0.0
        along = self.vertices @ axis_vector(direction, "direction")
        return float(along.max() - along.min())

    def turned(self, up=Y, to=Y) -> Mesh:
        """The mesh rotated (by the smallest angle) so that the direction ``up`` points along
        ``to`` (normals turned too).  ``mesh.turned(up)`` has ``up`` along +y, glTF's up."""
        rot = rotation_onto(axis_vector(up, "up"), axis_vector(to, "to"))
        return Mesh(self.vertices @ rot.T, self.faces, self.normals @ rot.T, self.colors)

    def standing(self, up=Y) -> Mesh:
        """The mesh as a printer takes it: turned so that ``up`` points along +Z, resting on
        z = 0, the middle of its footprint's box at x = y = 0 (a file does not know the
        printer's plate; slicers such as PrusaSlicer centre a part on theirs)."""
        turned = self.turned(up, Z)
        if len(turned.vertices) == 0:
            return turned
        lo, hi = turned.vertices.min(axis=0), turned.vertices.max(axis=0)
        shift = np.array([-(lo[0] + hi[0]) / 2.0, -(lo[1] + hi[1]) / 2.0, -lo[2]])
        return Mesh(turned.vertices + shift, self.faces, turned.normals, self.colors)

    def to_trimesh(self):
        """The mesh as a ``trimesh.Trimesh`` (vertices kept as they are, not merged)."""
        trimesh = import_trimesh()

        return trimesh.Trimesh(
            vertices=self.vertices,
            faces=self.faces,
            vertex_normals=self.normals,
            vertex_colors=_rgba8(self.colors),
            process=False,
        )

    def save(self, path: str | os.PathLike, format: str | None = None) -> Path:
        """Write PLY (binary, with colours and normals), OBJ, STL, GLB or 3MF (coordinates in
        millimetres): ``format`` (a name of ``FORMATS``) or else the extension's.  The
        coordinates are written as they are: :meth:`standing` gives a print's frame (+Z up, on
        z = 0), :meth:`turned` glTF's (+y up).

        Written as :func:`blobtree.output.write_file` writes: ``-`` is standard output (and needs
        ``format``), a regular file is written whole or not at all.
        """
        path = Path(path)
        kind = file_format(path, FORMATS, format)
        if len(self.faces) == 0:
            raise ValueError("the mesh has no triangles (the surface is absent or smaller than a "
                             "cell: try a finer resolution); nothing written")
        encode = ENCODERS.get(kind)
        data = encode(self) if encode else self.to_trimesh().export(file_type=kind)
        return write_file(path, data.encode() if isinstance(data, str) else data)
