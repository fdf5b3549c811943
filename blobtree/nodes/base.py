"""The BlobTree's node types (paper Section 2.2): the registry, the base classes and the contract
a node type fulfils.

A node type is one class in one module of this package, registered with :func:`register`.  Its
class declares

* ``TYPE`` (its scene-file name), ``PARAMS`` (:class:`~blobtree.nodes.params.Param`: names,
  kinds, defaults; the constructor, validation, ``params()``, ``replace()``, the scene schema and
  the test strategies derive from them) and ``ARITY`` (how many children);
* its reference maths in plain numpy: ``_ref(P, look) -> (field, gradient, colour)`` (the oracle
  the compiled engine is held equal to), its bounds ``_box(L)`` and its Lipschitz bound
  ``_lipschitz()``;
* its compiled kernels (``KERNELS``, numba functions written once with named parameter offsets,
  see ``Layout``) and how the compiler packs its parameters; operators also declare what a zero
  child does, how their Lipschitz bounds combine and their stack use.

The engine (``blobtree.engine``) builds its dispatch from the registry; nothing else lists node
types.  Nodes are immutable values: a changed parameter is a new node (``node.replace(...)``),
structurally equal trees are equal (``==``, ``hash``, :attr:`Node.key`), and a subtree used in
several places is one object, serialised once.

Conventions (docs/conventions.md): fields in [0, 1], surface at 0.5, inside is field >= 0.5;
angles in degrees; rotations by the right-hand rule.
"""

from __future__ import annotations

import hashlib
import inspect
import weakref
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import cached_property
from typing import Any, ClassVar

import numpy as np

from .. import geometry as geo
from ..checks import Choice, Vec3
from ..fields import FALLOFFS, SLOPE, falloff_array
from .params import REQUIRED, Param

ISO = 0.5
DEFAULT_COLOR = (0.8, 0.8, 0.8)

Result = tuple[np.ndarray, np.ndarray, np.ndarray]

#: The deepest tree that may be built (every recursive walk stays within Python's stack).
MAX_DEPTH = 256

#: Every node type by its scene-file name, in registration order.
REGISTRY: dict[str, type[Node]] = {}
_frozen_by: list[str] = []

# ----- the program layout a primitive's kernels see (docs/engine.md) --------------------------
#: params[o + MAP : o + MAP + 12]: the 3x4 map from the frame to the primitive's own coordinates
MAP = 0
#: params[o + RADIUS]: the field radius R; params[o + FALLOFF]: the falloff's id (fields.FALLOFFS)
RADIUS, FALLOFF = 12, 13
#: params[o + MAP_NORM]: the spectral norm of the map's linear part (a ball of radius r in the frame
#: lies in a ball of radius MAP_NORM r in the primitive's own coordinates)
MAP_NORM = 14
#: params[o + FRAME_NORM] of a PUSHPT (entering a warp's frame): its 3x4 map's norm
FRAME_NORM = 12
#: the primitive's own parameters start here (see :class:`Layout`)
GEOMETRY = 15


class Layout:
    """Named offsets of a node type's own parameters in the program, from ``start``.

    ``Layout(GEOMETRY, a=3, b=3, radius_a=1)`` places a at start, b at start + 3, radius_a at
    start + 6; ``.offsets`` gives those numbers for the kernels (module constants, so numba
    compiles them in) and ``.pack(a=..., b=..., radius_a=...)`` the values in that order.
    """

    def __init__(self, start: int = 0, **widths: int) -> None:
        self.start = start
        self.widths = widths
        offsets, at = [], start
        for w in widths.values():
            offsets.append(at)
            at += w
        self.offsets = tuple(offsets)
        self.size = at - start

    def pack(self, **values: Any) -> list[float]:
        """The values flattened in layout order; each must have its declared width."""
        if set(values) != set(self.widths):
            raise TypeError(f"layout needs {sorted(self.widths)}, got {sorted(values)}")
        out: list[float] = []
        for name, width in self.widths.items():
            flat = np.asarray(values[name], dtype=np.float64).reshape(-1)
            if flat.size != width:
                raise ValueError(f"layout field {name} has width {width}, got {flat.size}")
            out.extend(float(v) for v in flat)
        return out


# ----- kernels a node type provides (numba functions, see docs/extending.md) --------------------
@dataclass(frozen=True)
class PrimitiveKernels:
    """``s(p, o, qx, qy, qz) -> (s, ds/dqx, ds/dqy, ds/dqz)``: s = r^2 / R^2 at the local point q
    (the field is the falloff of s); ``uv(p, o, qx, qy, qz) -> (u, v)`` its own texture
    coordinates; optional ``lipschitz(p, o, lip, cx, cy, cz, hx, hy, hz, r)``: a bound on
    |grad f| over the local region within the box of centre c, half extents h and within the
    ball of centre c, radius r (``lip``: the global bound in the frame);
    optional ``along(p, o, ox, oy, oz, dx, dy, dz, length)``: a bound on |df/dt| along a frame
    segment, or -1 for none; optional ``rise(p, o, lox, loy, loz, hix, hiy, hiz, dx, dy, dz,
    spread)``: a bound on how fast the field can rise (df/dt, not |df/dt|) anywhere in the frame
    box [lo, hi] along any unit direction within distance ``spread`` of the unit vector d, or -1
    for none (0 where the rays all move away from the skeleton: they only leave the primitive).
    ``o`` is the primitive's params offset."""

    s: Callable
    uv: Callable
    lipschitz: Callable | None = None
    along: Callable | None = None
    rise: Callable | None = None


#: Columns of the value stack that, in the engine's bound pass (field only: the colour's columns
#: are free there), hold a row's gradient bound over a region and the distances from the
#: region's point over which its field surely stays below / above ISO, as an operator proved
#: them (read by operators' ``bound`` kernels).
BOUND, BELOW, ABOVE = 4, 5, 6


#: Rows at the end of a batch's value stack (engine.batch.value_rows) past its depth, free for
#: operators' ``rows`` kernels: whole rows of per-point scratch, so their loops run over the
#: batch's points one step at a time and vectorise.
ROWS_SCRATCH = 3


@dataclass(frozen=True)
class OperatorKernels:
    """``combine(vs, b, k, p, o, mode)``: the operator over value-stack rows b .. b + k - 1 (field,
    gradient, colour; see engine.interp), result in row b; optional ``rows(vs, b, k, p, o, nb)``:
    field only over the rows of a batch of nb points (engine.batch), vectorisable (its last
    ``ROWS_SCRATCH`` rows are scratch); optional
    ``bound(vs, b, k, p, o, reach) -> (bound, below, above)``: from the children's fields at a
    point of a region (vs[b + j, 0]) and their bounds over it (vs[b + j, BOUND], a region of
    diameter ``reach``), a bound on |grad f| over the region, and how far from the point the
    field surely stays below and above ISO (0: no more than its value and bound say); without
    it the ``LIPSCHITZ`` rule applies.  A CSG operator uses the values to drop the bound of a
    child that cannot set the result anywhere in the region, and its children's distances
    (``kmath.safe_distances``): a min stays below ISO as far as any of its terms does."""

    combine: Callable
    rows: Callable | None = None
    bound: Callable | None = None


@dataclass(frozen=True)
class WarpKernels:
    """``map(p, o, X, Y, Z) -> (qx, qy, qz, J00, J01, J02, J10, ..., J22)``: the query map of the
    warp in its canonical axes and its Jacobian, row by row."""

    map: Callable


@dataclass(frozen=True)
class PaintKernels:
    """``paint(p, o, px, py, pz, gx, gy, gz) -> (r, g, b)``: the colour of the subtree at a point
    with field gradient g (frame coordinates)."""

    paint: Callable


def register(cls: type[Node]) -> type[Node]:
    """Add a node type to :data:`REGISTRY` (class decorator); checks its declaration."""
    if _frozen_by:
        raise RuntimeError(
            f"node type {cls.__name__} registered after the engine was built "
            f"({_frozen_by[0]}); register node types when the package is imported")
    if not cls.TYPE or cls.TYPE in REGISTRY:
        raise ValueError(f"{cls.__name__}.TYPE must be a new non-empty name, got {cls.TYPE!r}")
    expected = {"primitive": PrimitiveKernels, "operator": OperatorKernels,
                "warp": WarpKernels, "paint": PaintKernels, "affine": type(None)}
    if cls.KIND not in expected or not isinstance(cls.KERNELS, expected[cls.KIND]):
        raise TypeError(f"{cls.__name__}: KIND {cls.KIND!r} needs KERNELS of type "
                        f"{expected.get(cls.KIND, object).__name__}")
    cls.__signature__ = cls._signature()
    if cls.METHOD:
        def method(self: Node, *args: Any, **kwargs: Any) -> Node:
            return cls.chain(self, *args, **kwargs)

        method.__name__ = method.__qualname__ = cls.METHOD
        method.__doc__ = cls.chain.__doc__ or cls.__doc__
        setattr(Node, cls.METHOD, method)
    REGISTRY[cls.TYPE] = cls
    return cls


def freeze_registry(by: str) -> None:
    """Called by the engine when it builds its dispatch: later registrations are refused."""
    if not _frozen_by:
        _frozen_by.append(by)


#: The engine's tree compiler, installed by ``blobtree.engine`` (the model does not need it).
_compiler: list[Callable[[Node], Any]] = []
#: Compiled programs by tree key, while some tree still holds its program.
_PROGRAMS: weakref.WeakValueDictionary[str, Any] = weakref.WeakValueDictionary()


def use_compiler(compile_tree: Callable[[Node], Any]) -> None:
    """Install the function that turns a tree into an evaluator (``Node.program``)."""
    _compiler[:] = [compile_tree]


def check_points(P: Any) -> np.ndarray:
    """(N, 3) finite float64 points, or ValueError."""
    arr = np.asarray(P, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("points must be finite (found NaN or inf)")
    return np.ascontiguousarray(arr)


def require_node(name: str, value: Any) -> Node:
    if not isinstance(value, Node):
        raise ValueError(f"{name} must be a BlobTree node, got {type(value).__name__[:60]}")
    return value


def _rebuild(cls: type[Node], children: tuple[Node, ...], values: dict[str, Any]) -> Node:
    return cls(*children, **values)


def arity_words(lo: int, hi: int | None) -> str:
    """How many children an ARITY allows, in words."""
    return f"at least {lo}" if hi is None else f"exactly {lo}" if lo == hi else f"{lo} to {hi}"


class Node:
    """A BlobTree node: an immutable value.  See the module docstring for what a type declares."""

    TYPE: ClassVar[str] = ""
    #: "primitive", "operator", "warp", "paint" or "affine" (folded into primitives)
    KIND: ClassVar[str] = ""
    PARAMS: ClassVar[tuple[Param, ...]] = ()
    #: (least, most) children; most None for any number
    ARITY: ClassVar[tuple[int, int | None]] = (0, 0)
    KERNELS: ClassVar[Any] = None
    #: name of the chainable method (``node.bend(...)``) a unary type adds to every node
    METHOD: ClassVar[str | None] = None

    children: tuple[Node, ...]
    #: Levels from this node down to its deepest leaf (1 for a primitive).
    depth: int

    # ----- construction -----------------------------------------------------------------------
    @classmethod
    def _signature(cls) -> inspect.Signature:
        P = inspect.Parameter
        params = [P("self", P.POSITIONAL_OR_KEYWORD)]
        lo, hi = cls.ARITY
        if hi == 1 and lo == 1:
            params.append(P("child", P.POSITIONAL_OR_KEYWORD))
            mode = P.POSITIONAL_OR_KEYWORD
        elif hi is None or hi > 1:
            params.append(P("children", P.VAR_POSITIONAL))
            mode = P.KEYWORD_ONLY
        else:
            mode = P.POSITIONAL_OR_KEYWORD
        for p in cls.PARAMS:
            default = P.empty if p.default is REQUIRED else p.default
            params.append(P(p.name, mode, default=default))
        return inspect.Signature(params)

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        cls = type(self)
        if cls.TYPE not in REGISTRY or REGISTRY[cls.TYPE] is not cls:
            raise TypeError(f"{cls.__name__} is not a registered node type")
        lo, hi = cls.ARITY
        nodes = next((i for i, a in enumerate(args) if not isinstance(a, Node)), len(args))
        if hi is not None and nodes > hi:
            raise ValueError(f"{cls.__name__} takes {arity_words(lo, hi)} children, got {nodes}")
        try:
            bound = cls.__signature__.bind(self, *args, **kwargs)
        except TypeError as e:  # an unknown or missing argument: Python's error, with the type
            raise TypeError(f"{cls.__name__}: {e}") from None
        bound.apply_defaults()
        values = dict(bound.arguments)
        values.pop("self")
        if "child" in values:
            children: tuple = (values.pop("child"),)
        else:
            children = tuple(values.pop("children", ()))
            if len(children) == 1 and isinstance(children[0], list | tuple):
                children = tuple(children[0])
        if len(children) < lo or (hi is not None and len(children) > hi):
            raise ValueError(f"{cls.__name__} takes {arity_words(lo, hi)} children, got "
                             f"{len(children)}")
        name = "child" if hi == 1 else "children[{}]"
        self._set("children", tuple(require_node(name.format(i), c)
                                    for i, c in enumerate(children)))
        depth = 1 + max((c.depth for c in self.children), default=0)
        if depth > MAX_DEPTH:
            raise ValueError(f"the tree would be {depth} levels deep, more than {MAX_DEPTH}: "
                             "group long chains (e.g. one blend of many children rather than "
                             "blends of blends)")
        self._set("depth", depth)
        for p in cls.PARAMS:
            self._set(p.name, p.kind.check(p.name, values[p.name]))
        self._check()

    def _check(self) -> None:
        """Checks across parameters (and derived values, set with ``_set``); ValueError."""

    def _set(self, name: str, value: Any) -> None:
        object.__setattr__(self, name, value)

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"{type(self).__name__} nodes are immutable: build a new one, "
                             f"e.g. node.replace({name}=...)")

    def __delattr__(self, name: str) -> None:
        raise AttributeError(f"{type(self).__name__} nodes are immutable")

    def __reduce__(self):
        return _rebuild, (type(self), self.children, self.values())

    def values(self) -> dict[str, Any]:
        """The parameters as the node keeps them (constructor arguments)."""
        return {p.name: getattr(self, p.name) for p in self.PARAMS}

    def params(self, images: dict[str, np.ndarray] | None = None) -> dict[str, Any]:
        """The parameters as JSON-ready values (children excluded; texture images go into
        ``images`` under their digest)."""
        images = {} if images is None else images
        return {p.name: p.kind.to_json(getattr(self, p.name), images) for p in self.PARAMS}

    def replace(self, **changes: Any) -> Node:
        """A new node with some parameters (or ``children=``) changed."""
        children = changes.pop("children", self.children)
        unknown = set(changes) - {p.name for p in self.PARAMS}
        if unknown:
            raise TypeError(f"{type(self).__name__} has no parameter(s) {sorted(unknown)}; "
                            f"it has {[p.name for p in self.PARAMS]}")
        return _rebuild(type(self), tuple(children), {**self.values(), **changes})

    def shown(self, up: tuple[float, float, float] = (0.0, 1.0, 0.0),
              view: tuple[float, float, float] | None = None) -> Node:
        """The same tree (equal to this one, the same field) carrying how it is best looked at:
        the direction shown up and the direction looked along (None: a three-quarter view).
        Notebook previews use it; it is display metadata, not saved in scene files."""
        up = tuple(float(x) for x in Vec3().check("up", up))
        if view is not None:
            view = tuple(float(x) for x in Vec3().check("view", view))
        if not (any(up) and (view is None or any(view))):
            raise ValueError(f"up and view must be non-zero vectors, got up={up}, view={view}")
        node = _rebuild(type(self), self.children, self.values())
        node.__dict__["display"] = (up, view)
        return node

    @property
    def display(self) -> tuple[tuple[float, float, float], tuple[float, float, float] | None]:
        """(up, view) given by :meth:`shown`; ((0, 1, 0), None) if none was."""
        return self.__dict__.get("display", ((0.0, 1.0, 0.0), None))

    # ----- identity ---------------------------------------------------------------------------
    @cached_property
    def key(self) -> str:
        """A digest of the type, parameters and children: equal for structurally equal trees."""
        for node in self.unique():  # children first, so no deep recursion
            if "key" not in node.__dict__:
                h = hashlib.sha256(node.TYPE.encode())
                for p in node.PARAMS:
                    h.update(f"|{p.name}={p.kind.key(getattr(node, p.name))}".encode())
                for c in node.children:
                    h.update(b"|" + c.__dict__["key"].encode())
                node.__dict__["key"] = h.hexdigest()[:32]
        return self.__dict__["key"]

    def __eq__(self, other: object) -> bool:
        if self is other:
            return True
        return isinstance(other, Node) and type(other) is type(self) and other.key == self.key

    def __hash__(self) -> int:
        return hash(self.key)

    def unique(self) -> list[Node]:
        """Each distinct node object of the tree once, children before parents."""
        order: list[Node] = []
        seen: set[int] = set()
        stack: list[tuple[Node, bool]] = [(self, False)]
        while stack:
            node, done = stack.pop()
            if done:
                order.append(node)
                continue
            if id(node) in seen:
                continue
            seen.add(id(node))
            stack.append((node, True))
            stack.extend((c, False) for c in reversed(node.children) if id(c) not in seen)
        return order

    def walk(self) -> Iterator[Node]:
        """Every node of the tree, depth first (parents before children; a shared subtree is
        visited at each of its places)."""
        stack = [self]
        while stack:
            node = stack.pop()
            yield node
            stack.extend(reversed(node.children))

    # ----- maths each node supplies -------------------------------------------------------------
    def _ref(self, P: np.ndarray, look: Any = None) -> Result:
        """Reference (field, gradient, colour) at (N, 3) points in this node's coordinates;
        ``look`` is the field-interpolated texture that paints the primitives below, if any."""
        raise NotImplementedError

    def _box(self, L: np.ndarray) -> geo.Box:
        """Conservative AABB of the support, seen through the affine map L (node -> frame)."""
        raise NotImplementedError

    def _lipschitz(self) -> float:
        """A global bound on |grad f|."""
        raise NotImplementedError

    def box(self, L: np.ndarray) -> geo.Box:
        """:meth:`_box`, computed once per frame (a shared subtree is not walked again)."""
        memo = self.__dict__.setdefault("_box_memo", {})
        key = L.tobytes()
        if key not in memo:
            lo, hi = self._box(L)
            memo[key] = (np.array(lo, dtype=float), np.array(hi, dtype=float))
            for a in memo[key]:
                a.setflags(write=False)
        return memo[key]

    def lipschitz(self) -> float:
        """A global bound on |grad f| (computed once)."""
        if "_lipschitz_memo" not in self.__dict__:
            self.__dict__["_lipschitz_memo"] = float(self._lipschitz())
        return self.__dict__["_lipschitz_memo"]

    # ----- evaluation -------------------------------------------------------------------------
    def bounds(self) -> geo.Box:
        """(lo, hi): a box that contains every point where the field is > 0."""
        lo, hi = self._bounds
        return lo.copy(), hi.copy()

    @cached_property
    def _bounds(self) -> geo.Box:
        return self.box(geo.IDENTITY)

    def program(self) -> Any:
        """The compiled program of this tree (compiled once: the tree cannot change)."""
        return self._program

    @cached_property
    def _program(self) -> Any:
        if not _compiler:
            raise RuntimeError("no engine installed: import blobtree (not only blobtree.nodes)")
        # an equal tree built again (a notebook cell run twice) reuses the compiled program
        program = _PROGRAMS.get(self.key)
        if program is None:
            program = _compiler[0](self)
            _PROGRAMS[self.key] = program
        return program

    def field(self, P: Any) -> np.ndarray:
        """Field values at (N, 3) points, in [0, 1]."""
        return self.program().field(check_points(P))

    def gradient(self, P: Any) -> np.ndarray:
        """Analytic field gradient at (N, 3) points."""
        return self.program().gradient(check_points(P))

    def albedo(self, P: Any) -> np.ndarray:
        """Colour (N, 3) in [0, 1]: field-weighted at blends, the winner's at CSG."""
        return self.program().albedo(check_points(P))

    def reference(self, P: Any) -> Result:
        """(field, gradient, colour) by the plain-numpy reference evaluator."""
        return self._ref(check_points(P), None)

    # ----- building ---------------------------------------------------------------------------
    def __add__(self, other: Node) -> Node:
        require_node("other", other)
        blend = REGISTRY["blend"]
        left = self.children if type(self) is blend else (self,)
        return blend(*left, other)

    def __radd__(self, other: Any) -> Node:
        if isinstance(other, int) and other == 0:  # so that sum(nodes) works
            return self
        return NotImplemented

    def __or__(self, other: Node) -> Node:
        return REGISTRY["union"](self, other)

    def __and__(self, other: Node) -> Node:
        return REGISTRY["intersection"](self, other)

    def __sub__(self, other: Node) -> Node:
        return REGISTRY["difference"](self, other)

    @classmethod
    def chain(cls, child: Node, *args: Any, **kwargs: Any) -> Node:
        """The chainable method's body (unary types): ``child.<METHOD>(*args)``."""
        return cls(child, *args, **kwargs)

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.params().items())
        if self.children:
            inner = ", ".join(repr(c) for c in self.children[:3])
            more = ", ..." if len(self.children) > 3 else ""
            args = inner + more + (", " + args if args else "")
        return f"{type(self).__name__}({args})"


# ============================================================================================
# Base classes of the four kinds with kernels, and of affine transforms
# ============================================================================================

FALLOFF_PARAM = Param("falloff", Choice(tuple(FALLOFFS)), "soft_object",
                      "falloff name (fields.FALLOFFS)")


class Primitive(Node):
    """A skeletal primitive: field = falloff(s), s = r^2 / R^2 with r the distance to the
    skeleton and R the field radius (0 for s >= 1).

    A type supplies ``field_radius`` (R), ``LAYOUT`` and ``pack()`` (its parameters after the
    header ``MAP, RADIUS, FALLOFF``), the reference ``_delta(q)`` (q minus the closest skeleton
    point; or ``_s`` where R varies), ``uv``, ``_box`` and ``KERNELS``.
    """

    KIND = "primitive"
    LAYOUT: ClassVar[Layout]

    @property
    def field_radius(self) -> float:
        """R: the largest distance from the skeleton at which the field is non-zero."""
        return self.radius

    def pack(self) -> list[float]:
        """The primitive's own parameters in the program (after the header), LAYOUT's order."""
        raise NotImplementedError

    def _delta(self, q: np.ndarray) -> np.ndarray:
        """q minus its closest skeleton point."""
        raise NotImplementedError

    def _s(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """s = r^2 / R^2 and ds/dq."""
        d = self._delta(q)
        r2 = self.field_radius ** 2
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

    def _lipschitz(self) -> float:
        return SLOPE[self.falloff] / self.field_radius


#: How zero children are treated when a program is specialised to a region (engine.specialize):
#: "drop" (a zero changes nothing: remove it), "keep" (keep it as a ZERO instruction: its place or
#: value matters) or "kill" (the operator is then zero everywhere in the region).
ZERO_RULES = ("drop", "keep", "kill")
#: How an operator's Lipschitz bound follows from its children's: their sum, their largest,
#: their sum times the operator's first parameter (``op_params()[0]``, a factor it derives), or
#: their n-norm (sum L_j^n)^(1/n) with n that first parameter (an operator that is the n-norm of
#: its children's fields: |f(x) - f(y)| <= ||(f_j(x) - f_j(y))_j||_n by the triangle inequality).
LIPSCHITZ_RULES = ("sum", "max", "scaled", "norm")


class Operator(Node):
    """An n-ary operator on child BlobTrees (postfix: its children are evaluated first).

    Declares ``ZERO_FIRST`` / ``ZERO_REST`` (what a zero first / later child does under
    specialisation, see :data:`ZERO_RULES`), ``LIPSCHITZ`` (:data:`LIPSCHITZ_RULES`),
    ``ASSOCIATIVE`` (the compiler may regroup its children into a box hierarchy),
    ``IDEMPOTENT`` (a child repeated verbatim may be evaluated once), ``STACK`` (value-stack
    rows it needs beyond its children's, usually 0), ``SMOOTH`` (its gradient is continuous
    where its children's are), ``WANTS_VALUES`` (its ``LIPSCHITZ`` rule is far looser than
    its value-aware ``bound``: a program holding it takes the value-aware pass throughout) and
    ``MONOTONE`` (how its field moves with its first child and with each later one: +1, it
    never falls where that child's rises; -1, it never rises; 0, either way.  Its ``LIPSCHITZ``
    rule then bounds how fast its field *rises* along a ray from how fast its children's rise or
    fall, and a ray's bound leaves out the primitives it moves away from).
    An operator of one child must be that child (specialisation relies on it).
    """

    KIND = "operator"
    ARITY = (1, None)
    ZERO_FIRST: ClassVar[str] = "drop"
    ZERO_REST: ClassVar[str] = "drop"
    LIPSCHITZ: ClassVar[str] = "sum"
    ASSOCIATIVE: ClassVar[bool] = False
    IDEMPOTENT: ClassVar[bool] = False
    STACK: ClassVar[int] = 0
    SMOOTH: ClassVar[bool] = False
    WANTS_VALUES: ClassVar[bool] = False
    MONOTONE: ClassVar[tuple[int, int]] = (0, 0)

    def op_params(self) -> list[float]:
        """The operator's parameters in the program (empty by default)."""
        return []

    def program_children(self) -> list[Node]:
        """The children the program evaluates, in order (its combine kernel's rows): by
        default the children, an idempotent operator's repeated ones once."""
        if self.IDEMPOTENT:
            return list(dict.fromkeys(self.children))
        return list(self.children)

    def _refs(self, P: np.ndarray, look: Any) -> Result:
        """Children's results stacked: f (k, N), g (k, N, 3), c (k, N, 3)."""
        rs = [c._ref(P, look) for c in self.children]
        return (np.stack([r[0] for r in rs]), np.stack([r[1] for r in rs]),
                np.stack([r[2] for r in rs]))

    def combine_boxes(self, boxes: list[geo.Box]) -> geo.Box:
        """This operator's box from its children's boxes (in the same frame)."""
        return geo.box_union(boxes)

    def _box(self, L):
        return self.combine_boxes([c.box(L) for c in self.children])

    def _lipschitz(self):
        bounds = [c.lipschitz() for c in self.children]
        if self.LIPSCHITZ == "norm":
            m, n = max(bounds), self.op_params()[0]
            return float(m * sum((b / m) ** n for b in bounds) ** (1.0 / n)) if m > 0.0 else 0.0
        return float(sum(bounds) if self.LIPSCHITZ == "sum" else max(bounds))


#: Margin by which a later child's field must beat the best so far to win a union's or
#: intersection's point (its gradient and colour): children whose fields agree closer than
#: rounding (coinciding cone caps, overlapping segments) keep the first, in the compiled engine
#: (``kmath.select``) and in the reference (:func:`winner`) alike.  Absolute, since fields are
#: of order 1 and their rounding errors are absolute (relative to a field near 0 they are not
#: small).  A field of exactly 0 (outside a child's support) is never tied with a positive one:
#: a union takes the positive child, an intersection the zero one, as the specialised programs
#: do when they drop or zero a child that misses their region.
TIE = 1e-12


def winner(f: np.ndarray, largest: bool) -> np.ndarray:
    """Per point, the index of the child (row of ``f``) with the largest (or smallest) field,
    the first of those within :data:`TIE` of each other."""
    index = np.zeros(f.shape[1], dtype=np.int64)
    best = f[0]
    for j in range(1, len(f)):
        better = ((f[j] > best + TIE) | ((best == 0.0) & (f[j] > 0.0)) if largest
                  else (f[j] < best - TIE) | ((f[j] == 0.0) & (best > 0.0)))
        index = np.where(better, j, index)
        best = np.where(better, f[j], best)
    return index


def pick(index: np.ndarray, stacked: np.ndarray) -> np.ndarray:
    """stacked[index[n], n] for each point n."""
    return np.take_along_axis(stacked, index[None, :, None], axis=0)[0]


def weighted_color(w: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Sum w_i c_i / sum w_i; the first child's colour where all weights are 0."""
    total = w.sum(axis=0)
    safe = np.where(total > 0.0, total, 1.0)
    mean = (w[:, :, None] * c).sum(axis=0) / safe[:, None]
    return np.where((total > 0.0)[:, None], mean, c[0])


class Unary(Node):
    """A node with one child."""

    ARITY = (1, 1)

    @property
    def child(self) -> Node:
        return self.children[0]

    def _box(self, L):
        return self.child.box(L)

    def _lipschitz(self):
        return self.child.lipschitz()


class Affine(Unary):
    """An affine transform; ``matrix`` (3x4) maps child coordinates to this node's.  The compiler
    folds chains of them into the primitives below (no kernel)."""

    KIND = "affine"

    @cached_property
    def matrix(self) -> np.ndarray:
        raise NotImplementedError

    @cached_property
    def inverse(self) -> np.ndarray:
        return geo.invert(self.matrix)

    def _ref(self, P, look=None):
        inv = self.inverse
        f, g, c = self.child._ref(geo.apply(inv, P), look)
        return f, g @ inv[:, :3], c

    def _box(self, L):
        return self.child.box(geo.compose(L, self.matrix))

    def _lipschitz(self):
        return self.child.lipschitz() * geo.spectral_norm(self.inverse[:, :3])


class Paint(Unary):
    """A node that sets the colour of its subtree (kernel: ``PaintKernels``).  ``sets_look``:
    instead of an instruction, it paints the primitives below with their own (u, v)."""

    KIND = "paint"

    @property
    def sets_look(self) -> bool:
        return False

    def pack(self, frame: np.ndarray, image_offset: Callable[[Node], int]) -> list[float]:
        """Its parameters in the program; ``frame`` maps its coordinates to the current frame,
        ``image_offset(node)`` places a texture image in the program."""
        raise NotImplementedError
