"""The BlobTree (paper Section 2.2): primitives as leaves, operators as interior nodes.

Every node is itself a BlobTree.  Each class carries its own maths in a few lines of numpy —
``_ref(P) -> (field, gradient, colour)`` in the node's own coordinates — which is the reference
evaluator the compiled engine (``compile`` + ``kernels``) is held equal to.  Public evaluation
(``field``, ``gradient``, ``albedo``) runs the compiled engine.

Conventions (DESIGN.md): fields in [0, 1], surface at 0.5, inside is field >= 0.5; angles in
degrees; rotations by the right-hand rule.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np

from . import geometry as geo
from . import texture as tex
from .fields import FALLOFFS, SLOPE, falloff_array

if TYPE_CHECKING:
    from .compile import Program

ISO = 0.5
DEFAULT_COLOR = (0.8, 0.8, 0.8)

Result = tuple[np.ndarray, np.ndarray, np.ndarray]


def check_points(P: Any) -> np.ndarray:
    """(N, 3) finite float64 points, or ValueError."""
    arr = np.asarray(P, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("points must be finite (found NaN or inf)")
    return np.ascontiguousarray(arr)


class Node:
    """A BlobTree node.  Subclasses set ``TYPE`` (the scene-file name) and their maths."""

    TYPE = "node"
    children: tuple[Node, ...] = ()

    # ----- maths each node supplies -------------------------------------------------------
    def _ref(self, P: np.ndarray, look: Any = None) -> Result:
        """Reference (field, gradient, colour) at (N, 3) points in this node's coordinates;
        ``look`` is the field-interpolated texture that paints the primitives below, if any."""
        raise NotImplementedError

    def _box(self, L: np.ndarray) -> geo.Box:
        """Conservative AABB of the support, seen through the affine map L (node -> frame)."""
        raise NotImplementedError

    def lipschitz(self) -> float:
        """A global bound on |grad f|."""
        raise NotImplementedError

    def params(self) -> dict[str, Any]:
        """The node's parameters as JSON-ready values (children excluded)."""
        return {}

    # ----- evaluation -------------------------------------------------------------------------
    def bounds(self) -> geo.Box:
        """(lo, hi): a box that contains every point where the field is > 0."""
        lo, hi = self._bounds
        return lo.copy(), hi.copy()

    @cached_property
    def _bounds(self) -> geo.Box:
        return self._box(geo.IDENTITY)

    def program(self) -> Program:
        """The compiled program of this tree (cached)."""
        return self._program

    @cached_property
    def _program(self) -> Program:
        from .compile import compile_tree

        return compile_tree(self)

    def field(self, P: Any) -> np.ndarray:
        """Field values at (N, 3) points, in [0, 1]."""
        return self.program().field(check_points(P))

    def gradient(self, P: Any) -> np.ndarray:
        """Analytic field gradient at (N, 3) points."""
        return self.program().gradient(check_points(P))

    def albedo(self, P: Any) -> np.ndarray:
        """Colour (N, 3) in [0, 1]: field-weighted at blends, the winner's at CSG (DESIGN.md)."""
        return self.program().albedo(check_points(P))

    def reference(self, P: Any) -> Result:
        """(field, gradient, colour) by the plain-numpy reference evaluator."""
        return self._ref(check_points(P), None)

    # ----- building ---------------------------------------------------------------------------
    def __add__(self, other: Node) -> Blend:
        _require_node("other", other)
        left = self.children if type(self) is Blend else (self,)
        return Blend(*left, other)

    def __radd__(self, other: Any) -> Node:
        if isinstance(other, int) and other == 0:  # so that sum(nodes) works
            return self
        return NotImplemented

    def __or__(self, other: Node) -> Union:
        return Union(self, other)

    def __and__(self, other: Node) -> Intersection:
        return Intersection(self, other)

    def __sub__(self, other: Node) -> Difference:
        return Difference(self, other)

    def translate(self, x: float | Sequence[float], y: float = 0.0, z: float = 0.0) -> Translate:
        """t(x, y, z)(B)."""
        offset = x if isinstance(x, Sequence | np.ndarray) else (x, y, z)
        return Translate(self, offset)

    def scale(self, sx: float, sy: float | None = None, sz: float | None = None) -> Scale:
        """s(x, y, z)(B); one argument scales uniformly."""
        if sy is None and sz is None:
            return Scale(self, (sx, sx, sx))
        if sy is None or sz is None:
            raise ValueError("scale takes one factor (uniform) or three (sx, sy, sz)")
        return Scale(self, (sx, sy, sz))

    def rotate(self, axis: str | Sequence[float], degrees: float) -> Rotate:
        """r(axis, theta)(B), right-hand rule, degrees."""
        return Rotate(self, axis, degrees)

    def bend(self, degrees: float, length: float, axis: str = "x", toward: str = "y") -> Bend:
        """Barr bend: the part 0..length along ``axis`` curves by ``degrees`` toward ``toward``."""
        return Bend(self, degrees=degrees, length=length, axis=axis, toward=toward)

    def twist(self, degrees_per_unit: float, axis: str = "y") -> Twist:
        """Barr twist about ``axis``: rotation grows by ``degrees_per_unit`` along it."""
        return Twist(self, degrees_per_unit=degrees_per_unit, axis=axis)

    def taper(self, rate: float, axis: str = "y") -> Taper:
        """Barr taper along ``axis``: the cross-section is scaled by 1 + rate * t."""
        return Taper(self, rate=rate, axis=axis)

    def color(self, rgb: Sequence[float]) -> Color:
        """Give this subtree one colour (the texture map m with a constant texture)."""
        return Color(self, rgb)

    def texture(self, image: Any, mapping: Any = "primitive", wrap: str = "repeat") -> Texture:
        """2D texture map m: see :class:`Texture`."""
        return Texture(self, image, mapping=mapping, wrap=wrap)

    def walk(self):
        """Every node of the tree, depth first (parents before children)."""
        stack = [self]
        while stack:
            node = stack.pop()
            yield node
            stack.extend(reversed(node.children))

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.params().items())
        if self.children:
            inner = ", ".join(repr(c) for c in self.children[:3])
            more = ", ..." if len(self.children) > 3 else ""
            args = inner + more + (", " + args if args else "")
        return f"{type(self).__name__}({args})"


def _require_node(name: str, value: Any) -> Node:
    if not isinstance(value, Node):
        raise ValueError(f"{name} must be a BlobTree node, got {type(value).__name__}")
    return value


# ============================================================================================
# Primitives
# ============================================================================================


class Primitive(Node):
    """A skeletal primitive: field = falloff(r^2 / R^2), r the distance to the skeleton."""

    def __init__(self, radius: float, falloff: str) -> None:
        self.radius = geo.check_positive("radius", radius)
        if falloff not in FALLOFFS:
            raise ValueError(f"falloff must be one of {sorted(FALLOFFS)}, got {falloff!r}")
        self.falloff = falloff

    def _delta(self, q: np.ndarray) -> np.ndarray:
        """q minus its closest skeleton point."""
        raise NotImplementedError

    def _s(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """s = r^2 / R^2 and ds/dq."""
        d = self._delta(q)
        r2 = self.radius**2
        return (d * d).sum(axis=1) / r2, 2.0 * d / r2

    def _ref(self, P: np.ndarray, look: Any = None) -> Result:
        s, ds = self._s(P)
        f, df = falloff_array(self.falloff, s)
        if look is None:
            color = np.broadcast_to(np.asarray(DEFAULT_COLOR), P.shape).copy()
        else:
            color = look.paint(*self.uv(P))
        return f, df[:, None] * ds, color

    def uv(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The primitive's own 2D parameterisation at local points (field-interpolated
        texturing, the paper's ref. [10])."""
        raise NotImplementedError

    def lipschitz(self) -> float:
        return SLOPE[self.falloff] / self.radius

    def _base_params(self) -> dict[str, Any]:
        return {"radius": self.radius, "falloff": self.falloff}


class Point(Primitive):
    """Point skeleton; a lone one has its surface at radius R/2 (soft object falloff)."""

    TYPE = "point"

    def __init__(
        self,
        radius: float = 1.0,
        center: Sequence[float] = (0.0, 0.0, 0.0),
        falloff: str = "soft_object",
    ) -> None:
        super().__init__(radius, falloff)
        self.center = geo.check_vec3("center", center)

    def _delta(self, q):
        return q - self.center

    def uv(self, q):
        """Spherical: u = longitude about +y, v = colatitude / pi."""
        d = q - self.center
        r = np.linalg.norm(d, axis=1)
        cos_t = np.clip(d[:, 1] / np.where(r > 0.0, r, 1.0), -1.0, 1.0)
        return tex.turn(-d[:, 2], d[:, 0]), np.arccos(cos_t) / np.pi

    def _box(self, L):
        c = L[:, :3] @ self.center + L[:, 3]
        h = geo.ellipsoid_half(L, self.radius)
        return c - h, c + h

    def params(self):
        return {"center": self.center.tolist(), **self._base_params()}


class Cone(Primitive):
    """Segment skeleton a-b whose field radius varies linearly from radius_a to radius_b.

    r / R(t) is used in the falloff, with t the clamped projection on the axis (a scaled-distance
    cone; our choice — the paper does not define its cone).  The paper's spines are cones.
    """

    TYPE = "cone"

    def __init__(
        self,
        a: Sequence[float],
        b: Sequence[float],
        radius_a: float,
        radius_b: float,
        falloff: str = "soft_object",
    ) -> None:
        self.radius_a = geo.check_positive("radius_a", radius_a)
        self.radius_b = geo.check_positive("radius_b", radius_b)
        super().__init__(max(self.radius_a, self.radius_b), falloff)
        self.a = geo.check_vec3("a", a)
        self.b = geo.check_vec3("b", b)
        if np.linalg.norm(self.b - self.a) == 0.0:
            raise ValueError(f"a and b must differ (zero-length axis at {tuple(self.a)})")

    def _s(self, q):
        ab = self.b - self.a
        l2 = ab @ ab
        t_raw = (q - self.a) @ ab / l2
        t = np.clip(t_raw, 0.0, 1.0)
        d = q - (self.a + t[:, None] * ab)
        dr = self.radius_b - self.radius_a
        rt = self.radius_a + t * dr
        d2 = (d * d).sum(axis=1)
        s = d2 / rt**2
        free = ((t_raw > 0.0) & (t_raw < 1.0))[:, None]
        ds = 2.0 * d / rt[:, None] ** 2 - np.where(
            free, (2.0 * d2 / rt**3 * dr)[:, None] * ab / l2, 0.0
        )
        return s, ds

    def uv(self, q):
        """u = angle around the axis (from :func:`texture.perpendicular_frame`), v = t."""
        ab = self.b - self.a
        t = np.clip((q - self.a) @ ab / (ab @ ab), 0.0, 1.0)
        d = q - (self.a + t[:, None] * ab)
        e1, e2 = tex.perpendicular_frame(ab)
        return tex.turn(d @ e2, d @ e1), t

    def _box(self, L):
        ends = []
        for p, r in ((self.a, self.radius_a), (self.b, self.radius_b)):
            c = L[:, :3] @ p + L[:, 3]
            h = geo.ellipsoid_half(L, r)
            ends.append((c - h, c + h))
        return geo.box_union(ends)

    def lipschitz(self):
        # |grad (r / R(t))| <= (1 + |R_b - R_a| / |b - a|) / min R (see docs in README)
        slope = abs(self.radius_b - self.radius_a) / np.linalg.norm(self.b - self.a)
        return SLOPE[self.falloff] * (1.0 + slope) / min(self.radius_a, self.radius_b)

    def params(self):
        return {
            "a": self.a.tolist(),
            "b": self.b.tolist(),
            "radius_a": self.radius_a,
            "radius_b": self.radius_b,
            "falloff": self.falloff,
        }


class Segment(Cone):
    """Line-segment skeleton a-b with a constant field radius."""

    TYPE = "segment"

    def __init__(
        self,
        a: Sequence[float],
        b: Sequence[float],
        radius: float = 1.0,
        falloff: str = "soft_object",
    ) -> None:
        r = geo.check_positive("radius", radius)
        super().__init__(a, b, r, r, falloff)

    def params(self):
        return {"a": self.a.tolist(), "b": self.b.tolist(), **self._base_params()}


class _Circular(Primitive):
    """Shared geometry of the torus and disc skeletons: a circle in the xz plane."""

    def __init__(self, ring: float, ring_name: str, radius: float, center, falloff) -> None:
        super().__init__(radius, falloff)
        self.ring = geo.check_positive(ring_name, ring)
        self.center = geo.check_vec3("center", center)

    def _ring_point(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Radial distance rho in the xz plane and the closest circle point (x, 0, z)."""
        rho = np.hypot(q[:, 0], q[:, 2])
        safe = np.where(rho > 0.0, rho, 1.0)
        cx = np.where(rho > 0.0, q[:, 0] / safe, 1.0) * self.ring
        cz = np.where(rho > 0.0, q[:, 2] / safe, 0.0) * self.ring
        return rho, np.stack([cx, np.zeros_like(cx), cz], axis=1)

    def uv(self, q):
        """u = angle around +y; torus: v = angle around the tube; disc: v = radius / ring."""
        d = q - self.center
        rho = np.hypot(d[:, 0], d[:, 2])
        u = tex.turn(-d[:, 2], d[:, 0])
        if isinstance(self, Disc):
            return u, np.minimum(rho / self.ring, 1.0)
        return u, tex.turn(d[:, 1], rho - self.ring)

    def _box(self, L):
        c = L[:, :3] @ self.center + L[:, 3]
        h = self.ring * np.hypot(L[:, 0], L[:, 2]) + geo.ellipsoid_half(L, self.radius)
        return c - h, c + h


class Torus(_Circular):
    """Circle skeleton of radius ``major_radius`` in the xz plane."""

    TYPE = "torus"

    def __init__(
        self,
        major_radius: float = 1.0,
        radius: float = 0.2,
        center: Sequence[float] = (0.0, 0.0, 0.0),
        falloff: str = "soft_object",
    ) -> None:
        super().__init__(major_radius, "major_radius", radius, center, falloff)

    def _delta(self, q):
        q = q - self.center
        return q - self._ring_point(q)[1]

    def params(self):
        return {"major_radius": self.ring, "center": self.center.tolist(), **self._base_params()}


class Disc(_Circular):
    """Solid disc skeleton of radius ``disc_radius`` in the xz plane."""

    TYPE = "disc"

    def __init__(
        self,
        disc_radius: float = 1.0,
        radius: float = 0.2,
        center: Sequence[float] = (0.0, 0.0, 0.0),
        falloff: str = "soft_object",
    ) -> None:
        super().__init__(disc_radius, "disc_radius", radius, center, falloff)

    def _delta(self, q):
        q = q - self.center
        rho, ring = self._ring_point(q)
        flat = np.stack([q[:, 0], np.zeros(len(q)), q[:, 2]], axis=1)
        return q - np.where((rho <= self.ring)[:, None], flat, ring)

    def params(self):
        return {"disc_radius": self.ring, "center": self.center.tolist(), **self._base_params()}


class Cylinder(Primitive):
    """Solid cylinder skeleton of radius ``cylinder_radius`` with axis a-b."""

    TYPE = "cylinder"

    def __init__(
        self,
        a: Sequence[float],
        b: Sequence[float],
        cylinder_radius: float = 0.5,
        radius: float = 0.2,
        falloff: str = "soft_object",
    ) -> None:
        super().__init__(radius, falloff)
        self.a = geo.check_vec3("a", a)
        self.b = geo.check_vec3("b", b)
        self.cylinder_radius = geo.check_positive("cylinder_radius", cylinder_radius)
        if np.linalg.norm(self.b - self.a) == 0.0:
            raise ValueError(f"a and b must differ (zero-length axis at {tuple(self.a)})")

    def _delta(self, q):
        axis = self.b - self.a
        length = np.linalg.norm(axis)
        u = axis / length
        w = q - self.a
        h = w @ u
        radial = w - h[:, None] * u
        rho = np.linalg.norm(radial, axis=1)
        scale = np.where(rho > 0.0, np.minimum(rho, self.cylinder_radius) / np.where(
            rho > 0.0, rho, 1.0), 0.0)
        closest = self.a + np.clip(h, 0.0, length)[:, None] * u + scale[:, None] * radial
        return q - closest

    def uv(self, q):
        """u = angle around the axis, v = height along it / length."""
        axis = self.b - self.a
        w = q - self.a
        e1, e2 = tex.perpendicular_frame(axis)
        return tex.turn(w @ e2, w @ e1), np.clip(w @ axis / (axis @ axis), 0.0, 1.0)

    def _box(self, L):
        u = (self.b - self.a) / np.linalg.norm(self.b - self.a)
        rows = L[:, :3]
        disc = self.cylinder_radius * np.sqrt(
            np.maximum((rows**2).sum(axis=1) - (rows @ u) ** 2, 0.0)
        )
        h = disc + geo.ellipsoid_half(L, self.radius)
        ends = []
        for p in (self.a, self.b):
            c = rows @ p + L[:, 3]
            ends.append((c - h, c + h))
        return geo.box_union(ends)

    def params(self):
        return {
            "a": self.a.tolist(),
            "b": self.b.tolist(),
            "cylinder_radius": self.cylinder_radius,
            **self._base_params(),
        }


# ============================================================================================
# Operators
# ============================================================================================


class Operator(Node):
    """An n-ary operator on child BlobTrees."""

    MIN_CHILDREN = 1

    def __init__(self, *children: Node) -> None:
        if len(children) == 1 and isinstance(children[0], list | tuple):
            children = tuple(children[0])
        if len(children) < self.MIN_CHILDREN:
            raise ValueError(
                f"{type(self).__name__} needs at least {self.MIN_CHILDREN} children, "
                f"got {len(children)}"
            )
        self.children = tuple(_require_node(f"children[{i}]", c) for i, c in enumerate(children))

    def _refs(self, P, look) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Children's results stacked: f (k, N), g (k, N, 3), c (k, N, 3)."""
        rs = [c._ref(P, look) for c in self.children]
        return (np.stack([r[0] for r in rs]), np.stack([r[1] for r in rs]),
                np.stack([r[2] for r in rs]))

    def combine_boxes(self, boxes: list[geo.Box]) -> geo.Box:
        """This operator's box from its children's boxes (in the same frame)."""
        return geo.box_union(boxes)

    def _box(self, L):
        return self.combine_boxes([c._box(L) for c in self.children])

    def lipschitz(self):
        return float(sum(c.lipschitz() for c in self.children))


def _pick(index: np.ndarray, stacked: np.ndarray) -> np.ndarray:
    """stacked[index[n], n] for each point n."""
    return np.take_along_axis(stacked, index[None, :, None], axis=0)[0]


def _weighted_color(w: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Sum w_i c_i / sum w_i; the first child's colour where all weights are 0."""
    total = w.sum(axis=0)
    safe = np.where(total > 0.0, total, 1.0)
    mean = (w[:, :, None] * c).sum(axis=0) / safe[:, None]
    return np.where((total > 0.0)[:, None], mean, c[0])


class Blend(Operator):
    """B_1 + ... + B_n: the sum of the fields."""

    TYPE = "blend"

    def _ref(self, P, look=None):
        f, g, c = self._refs(P, look)
        return f.sum(axis=0), g.sum(axis=0), _weighted_color(f, c)


class SuperBlend(Operator):
    """Ricci's super-elliptic blend (Eq. 4): (sum f_i^n)^(1/n), computed as m (sum (f_i/m)^n)^(1/n)
    with m = max f_i so that n = 400 neither underflows nor overflows."""

    TYPE = "super_blend"

    def __init__(self, *children: Node, n: float = 2.0) -> None:
        super().__init__(*children)
        self.n = geo.check_finite("n", n)
        if self.n < 1.0:
            raise ValueError(f"n must be >= 1 (n = 1 is the plain blend), got {n!r}")

    def _ref(self, P, look=None):
        f, g, c = self._refs(P, look)
        m = f.max(axis=0)
        safe = np.where(m > 0.0, m, 1.0)
        w = (f / safe) ** self.n  # weights f_i^n / m^n, in [0, 1]
        value = np.where(m > 0.0, m * w.sum(axis=0) ** (1.0 / self.n), 0.0)
        ratio = f / np.where(value > 0.0, value, 1.0)
        grad = (ratio[:, :, None] ** (self.n - 1.0) * g).sum(axis=0)
        return value, np.where((value > 0.0)[:, None], grad, 0.0), _weighted_color(w, c)

    def params(self):
        return {"n": self.n}


class Union(Operator):
    """B_1 U ... U B_n: max of the fields; colour and gradient of the winner."""

    TYPE = "union"

    def _ref(self, P, look=None):
        f, g, c = self._refs(P, look)
        i = np.argmax(f, axis=0)
        return f.max(axis=0), _pick(i, g), _pick(i, c)

    def lipschitz(self):
        return max(c.lipschitz() for c in self.children)


class Intersection(Operator):
    """B_1 n ... n B_n: min of the fields."""

    TYPE = "intersection"

    def _ref(self, P, look=None):
        f, g, c = self._refs(P, look)
        i = np.argmin(f, axis=0)
        return f.min(axis=0), _pick(i, g), _pick(i, c)

    def combine_boxes(self, boxes):
        return geo.box_intersection(boxes)

    def lipschitz(self):
        return max(c.lipschitz() for c in self.children)


class Difference(Operator):
    """B_1 - B_2 - ...: max(0, min(f_1, 2*0.5 - f_2, ...)); the box is B_1's."""

    TYPE = "difference"
    MIN_CHILDREN = 2

    def _ref(self, P, look=None):
        f, g, c = self._refs(P, look)
        f = np.concatenate([f[:1], 2.0 * ISO - f[1:]])
        g = np.concatenate([g[:1], -g[1:]])
        i = np.argmin(f, axis=0)
        value = f.min(axis=0)
        # a subtrahend whose field exceeds 1 (a blend) would push the result below 0: clamp,
        # so the field stays in [0, 1] and is 0 outside the first child's box
        neg = (value < 0.0)[:, None]
        return np.maximum(value, 0.0), np.where(neg, 0.0, _pick(i, g)), _pick(i, c)

    def combine_boxes(self, boxes):
        return boxes[0]

    def lipschitz(self):
        return max(c.lipschitz() for c in self.children)


class ControlledBlend(Operator):
    """Controlled blend c(b_1..b_n)(B_1..B_m) (Eq. 6): each listed pair (j, k) blends f_j + f_k;
    a child blends with no one else; the field is the max over the pairs (and over children in
    no pair, alone).

    This is a reconstruction: Guy & Wyvill's blending graph (the paper's ref. [3]) expressed as
    a union of pairwise blend groups, as recommended in notes/blobtree-formulas.md section 3.
    """

    TYPE = "controlled_blend"

    def __init__(self, *children: Node, pairs: Sequence[Sequence[int]] = ()) -> None:
        super().__init__(*children)
        m = len(self.children)
        checked = []
        for k, pair in enumerate(pairs):
            try:
                i, j = (int(v) for v in pair)
                ok = [float(v) for v in pair] == [i, j]
            except (TypeError, ValueError):
                ok = False
            if not ok or not (0 <= i < m and 0 <= j < m) or i == j:
                raise ValueError(
                    f"pairs[{k}] must be two different child indices in [0, {m}), got {pair!r}"
                )
            checked.append((i, j))
        self.pairs = tuple(checked)
        paired = {i for p in self.pairs for i in p}
        self.singles = tuple(i for i in range(m) if i not in paired)

    def _ref(self, P, look=None):
        f, g, c = self._refs(P, look)
        cand_f, cand_g, cand_c = [], [], []
        for i, j in self.pairs:
            cand_f.append(f[i] + f[j])
            cand_g.append(g[i] + g[j])
            cand_c.append(_weighted_color(f[[i, j]], c[[i, j]]))
        for i in self.singles:
            cand_f.append(f[i])
            cand_g.append(g[i])
            cand_c.append(c[i])
        cf = np.stack(cand_f)
        k = np.argmax(cf, axis=0)
        return cf.max(axis=0), _pick(k, np.stack(cand_g)), _pick(k, np.stack(cand_c))

    def params(self):
        return {"pairs": [list(p) for p in self.pairs]}


# ============================================================================================
# Unary nodes: affine transforms, warps, colour
# ============================================================================================


class Unary(Node):
    """A node with one child."""

    def __init__(self, child: Node) -> None:
        self.children = (_require_node("child", child),)

    @property
    def child(self) -> Node:
        return self.children[0]


class Affine(Unary):
    """An affine transform; ``matrix`` (3x4) maps child coordinates to this node's."""

    matrix: np.ndarray

    @cached_property
    def inverse(self) -> np.ndarray:
        return geo.invert(self.matrix)

    def _ref(self, P, look=None):
        inv = self.inverse
        f, g, c = self.child._ref(geo.apply(inv, P), look)
        return f, g @ inv[:, :3], c

    def _box(self, L):
        return self.child._box(geo.compose(L, self.matrix))

    def lipschitz(self):
        return self.child.lipschitz() * geo.spectral_norm(self.inverse[:, :3])


class Translate(Affine):
    """t(x, y, z)(B)."""

    TYPE = "translate"

    def __init__(self, child: Node, offset: Sequence[float]) -> None:
        super().__init__(child)
        self.offset = geo.check_vec3("offset", offset)
        self.matrix = geo.affine(np.eye(3), self.offset)

    def params(self):
        return {"offset": self.offset.tolist()}


class Scale(Affine):
    """s(x, y, z)(B); factors must be non-zero."""

    TYPE = "scale"

    def __init__(self, child: Node, factors: Sequence[float]) -> None:
        super().__init__(child)
        self.factors = geo.check_vec3("factors", factors)
        if np.any(self.factors == 0.0):
            raise ValueError(f"scale factors must be non-zero, got {tuple(self.factors)}")
        self.matrix = geo.affine(np.diag(self.factors))

    def params(self):
        return {"factors": self.factors.tolist()}


class Rotate(Affine):
    """r(axis, theta)(B): right-hand rule, degrees."""

    TYPE = "rotate"

    def __init__(self, child: Node, axis: str | Sequence[float], degrees: float) -> None:
        super().__init__(child)
        geo.axis_vector(axis)  # validates
        self.axis = axis if isinstance(axis, str) else geo.check_vec3("axis", axis).tolist()
        self.degrees = geo.check_finite("degrees", degrees)
        self.matrix = geo.affine(geo.rotation_matrix(self.axis, self.degrees))

    def params(self):
        return {"axis": self.axis, "degrees": self.degrees}


def _axis_index(name: str, value: Any) -> int:
    if value not in geo.AXES:
        raise ValueError(f"{name} must be 'x', 'y' or 'z', got {value!r}")
    return geo.AXES[value]


class Warp(Unary):
    """A global deformation (Barr 1984) as a query-point map w: f(p) = f_child(w(p)).

    Each warp supplies ``warp_points(P) -> (Q, J)`` (J = dQ/dP, (N, 3, 3)) and its output box
    ``own_box`` computed from the child's box by the forward deformation.  The field is 0
    outside ``own_box``.
    """

    def warp_points(self, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    @cached_property
    def child_box(self) -> geo.Box:
        lo, hi = self.child._box(geo.IDENTITY)
        if geo.is_empty((lo, hi)):
            return np.zeros(3), np.zeros(3)
        return lo, hi

    @cached_property
    def own_box(self) -> geo.Box:
        """The box of the deformed child (empty when the child's support is empty)."""
        if geo.is_empty(self.child._box(geo.IDENTITY)):
            return geo.empty_box()
        return self._deformed_box()

    def _deformed_box(self) -> geo.Box:
        """The box of the child's box under the forward deformation."""
        raise NotImplementedError

    def _ref(self, P, look=None):
        lo, hi = self.own_box
        inside = np.all((P >= lo) & (P <= hi), axis=1)
        f = np.zeros(len(P))
        g = np.zeros_like(P)
        c = np.broadcast_to(np.asarray(DEFAULT_COLOR), P.shape).copy()
        if inside.any():
            q, jac = self.warp_points(P[inside])
            fc, gc, cc = self.child._ref(q, look)
            f[inside] = fc
            g[inside] = np.einsum("nij,ni->nj", jac, gc)
            c[inside] = cc
        return f, g, c

    def _box(self, L):
        return geo.transform_box(L, self.own_box)

    def lipschitz(self):
        return self.child.lipschitz() * self.stretch


class Bend(Warp):
    """Barr bend: the child's part from 0 to ``length`` along ``axis`` is bent into a circular arc
    of ``degrees`` curving toward +``toward`` (negative degrees: toward -``toward``); beyond
    ``length`` it continues straight along the arc's end tangent; below 0 it is unchanged."""

    TYPE = "bend"

    def __init__(self, child: Node, degrees: float, length: float, axis: str = "x",
                 toward: str = "y") -> None:
        super().__init__(child)
        self.degrees = geo.check_finite("degrees", degrees)
        if not 0.0 < abs(self.degrees) <= 180.0:
            raise ValueError(f"degrees must be non-zero and within [-180, 180], got {degrees!r}")
        self.length = geo.check_positive("length", length)
        self.axis, self.toward = axis, toward
        a, b = _axis_index("axis", axis), _axis_index("toward", toward)
        if a == b:
            raise ValueError(f"axis and toward must differ, got {axis!r} twice")
        self.index = (a, b, 3 - a - b)
        self.sign = 1.0 if self.degrees > 0 else -1.0
        self.k = math.radians(abs(self.degrees)) / self.length
        y_hi = self.sign * self.child_box[1][b] if self.sign > 0 else -self.child_box[0][b]
        if y_hi >= 1.0 / self.k:
            raise ValueError(
                f"bend of {degrees} degrees over length {length} is too tight: the child reaches "
                f"{y_hi:.4g} toward '{toward}', past the centre of curvature at {1 / self.k:.4g}"
            )

    def _canon(self, P: np.ndarray) -> np.ndarray:
        a, b, c = self.index
        return np.stack([P[:, a], self.sign * P[:, b], P[:, c]], axis=1)

    def _uncanon(self, Q: np.ndarray) -> np.ndarray:
        a, b, c = self.index
        out = np.empty_like(Q)
        out[:, a], out[:, b], out[:, c] = Q[:, 0], self.sign * Q[:, 1], Q[:, 2]
        return out

    def warp_points(self, P):
        k, ik = self.k, 1.0 / self.k
        X = self._canon(P)
        u, v = X[:, 0], ik - X[:, 1]
        phi = np.arctan2(u, v)
        th = np.clip(phi, 0.0, k * self.length)
        sn, cs = np.sin(th), np.cos(th)
        dx, dy = X[:, 0] - sn * ik, X[:, 1] - (1.0 - cs) * ik
        Q = np.stack([th * ik + dx * cs + dy * sn, -dx * sn + dy * cs, X[:, 2]], axis=1)
        # Jacobian in canonical coordinates: rows d(x, y)/d(X, Y)
        rho2 = u * u + v * v
        rho = np.sqrt(rho2)
        arc = (phi > 0.0) & (phi < k * self.length)
        J = np.zeros((len(P), 3, 3))
        J[:, 0, 0] = np.where(arc, v / (k * rho2), cs)
        J[:, 0, 1] = np.where(arc, u / (k * rho2), sn)
        J[:, 1, 0] = np.where(arc, -u / rho, -sn)
        J[:, 1, 1] = np.where(arc, v / rho, cs)
        J[:, 2, 2] = 1.0
        perm = self._perm
        return self._uncanon(Q), np.einsum("ji,njk,kl->nil", perm, J, perm)

    @cached_property
    def _perm(self) -> np.ndarray:
        """Signed permutation: canonical = perm @ p."""
        a, b, c = self.index
        m = np.zeros((3, 3))
        m[0, a], m[1, b], m[2, c] = 1.0, self.sign, 1.0
        return m

    def _deformed_box(self):
        lo, hi = self.child_box
        perm = self._perm
        clo, chi = geo.transform_box(geo.affine(perm), (lo, hi))
        k, ik, length = self.k, 1.0 / self.k, self.length
        pts = []
        x0, x1 = clo[0], chi[0]
        ys = (clo[1], chi[1])
        if x0 < 0.0:  # unbent part
            for x in (x0, min(x1, 0.0)):
                pts += [(x, y) for y in ys]
        if x1 > 0.0 and x0 < length:  # arc part
            ta, tb = k * max(x0, 0.0), k * min(x1, length)
            thetas = [ta, tb] + [t for t in (math.pi / 2, math.pi) if ta < t < tb]
            for t in thetas:
                for y in ys:
                    r = ik - y
                    pts.append((r * math.sin(t), ik - r * math.cos(t)))
        if x1 > length:  # straight continuation beyond the arc
            t = k * length
            ox, oy = math.sin(t) * ik, (1 - math.cos(t)) * ik
            for x in (max(x0, length), x1):
                for y in ys:
                    s = x - length
                    pts.append((ox + s * math.cos(t) - y * math.sin(t),
                                oy + s * math.sin(t) + y * math.cos(t)))
        xy = np.array(pts)
        cbox = (np.array([xy[:, 0].min(), xy[:, 1].min(), clo[2]]),
                np.array([xy[:, 0].max(), xy[:, 1].max(), chi[2]]))
        return geo.transform_box(geo.affine(perm.T), cbox)

    @cached_property
    def stretch(self) -> float:
        lo, hi = self.child_box
        y_hi = self.sign * hi[self.index[1]] if self.sign > 0 else -lo[self.index[1]]
        return max(1.0, 1.0 / (self.k * (1.0 / self.k - y_hi)))

    def params(self):
        return {"degrees": self.degrees, "length": self.length, "axis": self.axis,
                "toward": self.toward}


class Twist(Warp):
    """Barr twist about ``axis``: at height t along the axis the child is turned by
    ``degrees_per_unit * t`` degrees (right-hand rule)."""

    TYPE = "twist"

    def __init__(self, child: Node, degrees_per_unit: float, axis: str = "y") -> None:
        super().__init__(child)
        self.degrees_per_unit = geo.check_finite("degrees_per_unit", degrees_per_unit)
        self.axis = axis
        a = _axis_index("axis", axis)
        self.index = (a, (a + 1) % 3, (a + 2) % 3)
        self.k = math.radians(self.degrees_per_unit)

    def warp_points(self, P):
        a, i, j = self.index
        th = self.k * P[:, a]
        cs, sn = np.cos(th), np.sin(th)
        Q = P.copy()
        Q[:, i] = cs * P[:, i] + sn * P[:, j]
        Q[:, j] = -sn * P[:, i] + cs * P[:, j]
        J = np.zeros((len(P), 3, 3))
        J[:, a, a] = 1.0
        J[:, i, i], J[:, i, j], J[:, i, a] = cs, sn, self.k * Q[:, j]
        J[:, j, i], J[:, j, j], J[:, j, a] = -sn, cs, -self.k * Q[:, i]
        return Q, J

    @cached_property
    def _reach(self) -> float:
        lo, hi = self.child_box
        _, i, j = self.index
        return float(max(np.hypot(x, y) for x in (lo[i], hi[i]) for y in (lo[j], hi[j])))

    def _deformed_box(self):
        lo, hi = (b.copy() for b in self.child_box)
        _, i, j = self.index
        lo[[i, j]], hi[[i, j]] = -self._reach, self._reach
        return lo, hi

    @cached_property
    def stretch(self) -> float:
        return 1.0 + abs(self.k) * self._reach

    def params(self):
        return {"degrees_per_unit": self.degrees_per_unit, "axis": self.axis}


class Taper(Warp):
    """Barr taper along ``axis``: the cross-section at t is scaled by s(t) = 1 + rate * t, with t
    clamped to the child's extent along the axis (s must stay > 0 there)."""

    TYPE = "taper"

    def __init__(self, child: Node, rate: float, axis: str = "y") -> None:
        super().__init__(child)
        self.rate = geo.check_finite("rate", rate)
        self.axis = axis
        a = _axis_index("axis", axis)
        self.index = (a, (a + 1) % 3, (a + 2) % 3)
        self.t_range = (float(self.child_box[0][a]), float(self.child_box[1][a]))
        s = [1.0 + self.rate * t for t in self.t_range]
        if min(s) <= 0.0:
            raise ValueError(
                f"taper rate {rate!r} makes the scale 1 + rate*t <= 0 within the child's extent "
                f"{self.t_range} along '{axis}'"
            )
        self.s_range = (min(s), max(s))

    def warp_points(self, P):
        a, i, j = self.index
        t = np.clip(P[:, a], *self.t_range)
        s = 1.0 + self.rate * t
        free = (P[:, a] > self.t_range[0]) & (P[:, a] < self.t_range[1])
        Q = P.copy()
        Q[:, i], Q[:, j] = P[:, i] / s, P[:, j] / s
        J = np.zeros((len(P), 3, 3))
        J[:, a, a] = 1.0
        J[:, i, i] = J[:, j, j] = 1.0 / s
        J[:, i, a] = np.where(free, -Q[:, i] * self.rate / s, 0.0)
        J[:, j, a] = np.where(free, -Q[:, j] * self.rate / s, 0.0)
        return Q, J

    def _deformed_box(self):
        lo, hi = (b.copy() for b in self.child_box)
        _, i, j = self.index
        smin, smax = self.s_range
        for ax in (i, j):
            lo[ax] = min(lo[ax] * smin, lo[ax] * smax)
            hi[ax] = max(hi[ax] * smin, hi[ax] * smax)
        return lo, hi

    @cached_property
    def stretch(self) -> float:
        lo, hi = self.child_box
        _, i, j = self.index
        reach = max(np.hypot(x, y) for x in (lo[i], hi[i]) for y in (lo[j], hi[j]))
        smin = self.s_range[0]
        return 1.0 / smin + abs(self.rate) * reach / smin

    def params(self):
        return {"rate": self.rate, "axis": self.axis}


class Color(Unary):
    """A constant colour for the whole subtree."""

    TYPE = "color"

    def __init__(self, child: Node, rgb: Sequence[float]) -> None:
        super().__init__(child)
        self.rgb = geo.check_vec3("rgb", rgb)
        if np.any(self.rgb < 0.0) or np.any(self.rgb > 1.0):
            raise ValueError(f"rgb components must lie in [0, 1], got {tuple(self.rgb)}")

    def _ref(self, P, look=None):
        f, g, _ = self.child._ref(P, look)
        return f, g, np.broadcast_to(self.rgb, P.shape).copy()

    def _box(self, L):
        return self.child._box(L)

    def lipschitz(self):
        return self.child.lipschitz()

    def params(self):
        return {"rgb": self.rgb.tolist()}


class Texture(Unary):
    """The 2D texture-map operator m (Section 3.4) with one of the paper's two methods:
    ``mapping="primitive"`` (field-interpolated: each primitive below uses its own (u, v)) or a
    :class:`texture.HelicoSurface` (bounding surface).  ``image``: a PNG/JPEG path, an (H, W, 3)
    array (uint8, or floats in [0, 1]) or a function of (u, v) arrays returning (..., 3) colours.

    Which paint wins: colour nodes and bounding-surface textures paint their whole subtree (the
    outermost wins); a field-interpolated texture paints the primitives below it that no nearer
    field-interpolated texture paints."""

    TYPE = "texture"

    def __init__(self, child: Node, image: tex.TextureSource, mapping: Any = "primitive",
                 wrap: str = "repeat") -> None:
        super().__init__(child)
        self.image = image if isinstance(image, np.ndarray) and image.dtype == np.uint8 \
            and image.ndim == 3 and image.shape[2] == 3 else tex.load_image(image)
        self.mapping = tex.parse_mapping(mapping)
        if wrap not in tex.WRAPS:
            raise ValueError(f"wrap must be one of {sorted(tex.WRAPS)}, got {wrap!r}")
        self.wrap = wrap

    def paint(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Texture colours at (u, v)."""
        return tex.sample(self.image, u, v, self.wrap)

    def _ref(self, P, look=None):
        if self.mapping == "primitive":
            return self.child._ref(P, self)
        f, g, _ = self.child._ref(P, look)
        return f, g, self.paint(*self.mapping.uv(P, g))

    def _box(self, L):
        return self.child._box(L)

    def lipschitz(self):
        return self.child.lipschitz()

    def params(self):
        mapping = self.mapping if self.mapping == "primitive" else {
            "helico": self.mapping.to_dict()}
        return {"image": self.digest, "mapping": mapping, "wrap": self.wrap}

    @cached_property
    def digest(self) -> str:
        """Content key of the image (scene files store each distinct image once)."""
        return tex.image_digest(self.image)


# ============================================================================================
# Functional forms of the operators (the public API of DESIGN.md)
# ============================================================================================


def blend(*nodes: Node) -> Blend:
    """B_1 + B_2 + ... (sum)."""
    return Blend(*nodes)


def super_blend(*nodes: Node, n: float = 2.0) -> SuperBlend:
    """Ricci super-elliptic blend, Eq. 4, n-ary."""
    return SuperBlend(*nodes, n=n)


def union(*nodes: Node) -> Union:
    return Union(*nodes)


def intersection(*nodes: Node) -> Intersection:
    return Intersection(*nodes)


def difference(*nodes: Node) -> Difference:
    """B_1 - B_2 - ... (CSG difference)."""
    return Difference(*nodes)


def controlled_blend(nodes: Sequence[Node], pairs: Sequence[Sequence[int]]) -> ControlledBlend:
    """Controlled blend, Eq. 6: only the listed pairs (i, j) of ``nodes`` blend."""
    return ControlledBlend(*nodes, pairs=pairs)


#: Every concrete node class by its scene-file name.
NODE_TYPES: dict[str, type[Node]] = {
    cls.TYPE: cls
    for cls in (Point, Segment, Cone, Torus, Disc, Cylinder, Blend, SuperBlend, Union,
                Intersection, Difference, ControlledBlend, Translate, Scale, Rotate, Bend,
                Twist, Taper, Color, Texture)
}
