"""The BlobTree's node types (paper Section 2.2): the registry, the node value and the contract
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
import itertools
import weakref
from collections.abc import Callable, Iterable, Iterator
from functools import cached_property
from typing import Any, ClassVar

import numpy as np

from .. import geometry as geo
from ..checks import Vec3
from .kernels import OperatorKernels, PaintKernels, PrimitiveKernels, WarpKernels
from .params import REQUIRED, Param

#: The iso-value of every surface: inside is field >= ISO.
ISO = 0.5
DEFAULT_COLOR = (0.8, 0.8, 0.8)

Result = tuple[np.ndarray, np.ndarray, np.ndarray]

#: The deepest tree that may be built (every recursive walk stays within Python's stack).
MAX_DEPTH = 256

#: Every node type by its scene-file name, in registration order.
REGISTRY: dict[str, type[Node]] = {}
_frozen_by: list[str] = []


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
    cls._defaults = {p.name: p.default for p in cls.PARAMS}
    cls._required = tuple(p.name for p in cls.PARAMS if p.default is REQUIRED)
    cls._positional = () if cls.ARITY[1] is None or cls.ARITY[1] > 1 else \
        tuple(p.name for p in cls.PARAMS)
    cls._keyed = tuple((p.name, f"{p.name}=", p.kind.key) for p in cls.PARAMS)
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


#: The memos a node keeps by frame (a frame's bytes -> its value): its boxes, and an affine
#: node's frame below its chain (``Affine.framed``).
FRAME_MEMOS = ("_box_memo", "_framed")
#: The mark :func:`mark_frames` puts in them.
_SINCE = object()


def mark_frames(nodes: Iterable[Node]) -> list[dict]:
    """Mark where the frames asked for from now on begin in the nodes' memos by frame
    (:data:`FRAME_MEMOS`); return the memos marked, for :func:`drop_older_frames`."""
    memos = {id(m): m for node in nodes for name in FRAME_MEMOS
             if (m := node.__dict__.get(name))}
    for memo in memos.values():
        memo.pop(_SINCE, None)
        memo[_SINCE] = None
    return list(memos.values())


def by_frame(memo: dict, L: np.ndarray, make: Callable[[np.ndarray], Any]) -> Any:
    """The value a memo by frame holds for frame L, ``make(L)`` the first time; either way put
    back last (the frames last asked for come last, for :func:`drop_older_frames`).  (``make``
    a bound method, not a closure made at each call: a change of the Murex's spiral asks some
    14,000 times.)"""
    key = L.tobytes()
    value = memo.pop(key, None)
    if value is None:
        value = make(L)
    memo[key] = value
    return value


def frames_kept(memo: dict) -> int:
    """How many frames a memo by frame holds (:func:`mark_frames`' mark not counted)."""
    return len(memo) - (_SINCE in memo)


def drop_older_frames(memos: list[dict]) -> None:
    """Forget the frames of the marked memos not asked for since :func:`mark_frames`, where
    any was (a memo untouched keeps them all): a subtree placed anew at each change (a spiral
    changed) would otherwise gather a frame a change, without end.  Frames asked for go last
    in a memo (``Node.box`` and ``Affine.framed`` put them back at the end)."""
    for memo in memos:
        if _SINCE not in memo:
            continue
        if next(reversed(memo)) is not _SINCE:  # (touched)
            for key in list(itertools.takewhile(lambda k: k is not _SINCE, memo)):
                del memo[key]
        del memo[_SINCE]


class Node:
    """A BlobTree node: an immutable value.  See the module docstring for what a type declares."""

    TYPE: ClassVar[str] = ""
    #: "primitive", "operator", "warp", "paint" or "affine" (folded into primitives)
    KIND: ClassVar[str] = ""
    PARAMS: ClassVar[tuple[Param, ...]] = ()
    #: (least, most) children; most None for any number
    ARITY: ClassVar[tuple[int, int | None]] = (0, 0)
    KERNELS: ClassVar[Any] = None
    #: every parameter's default (REQUIRED where it has none), set by :func:`register`
    _defaults: ClassVar[dict[str, Any]] = {}
    #: the parameters without a default, set by :func:`register`
    _required: ClassVar[tuple[str, ...]] = ()
    #: the parameters that may be given by position, in order, set by :func:`register`
    _positional: ClassVar[tuple[str, ...]] = ()
    #: (name, "name=", the kind's key) of every parameter, set by :func:`register`
    _keyed: ClassVar[tuple] = ()
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
        nodes = 0  # the children given first, by position
        for a in args:
            if not isinstance(a, Node):
                break
            nodes += 1
        if hi is not None and nodes > hi:
            raise ValueError(f"{cls.__name__} takes {arity_words(lo, hi)} children, got {nodes}")
        # children by position, then parameters (positional only where there is no list of
        # children) and by name: bound here as the signature would bind them, fast
        given = args[nodes:]
        named = cls._positional[:len(given)]
        if (nodes == lo or hi != lo) and len(named) == len(given) \
                and cls._defaults.keys() >= kwargs.keys() and not kwargs.keys() & named:
            values = dict(cls._defaults)
            values.update(zip(named, given, strict=True))
            values.update(kwargs)
            children: tuple = args[:nodes]
            if any(values[k] is REQUIRED for k in cls._required):
                self._bind(args, kwargs)  # raises Python's error for the missing argument
        else:
            values = self._bind(args, kwargs)
            if "child" in values:
                children = (values.pop("child"),)
            else:
                children = tuple(values.pop("children", ()))
                if len(children) == 1 and isinstance(children[0], list | tuple):
                    children = tuple(children[0])
        if len(children) < lo or (hi is not None and len(children) > hi):
            raise ValueError(f"{cls.__name__} takes {arity_words(lo, hi)} children, got "
                             f"{len(children)}")
        children = tuple(children)
        for i, c in enumerate(children):
            if not isinstance(c, Node):
                require_node("child" if hi == 1 else f"children[{i}]", c)  # (raises)
        self._set("children", children)
        depth = 1 + max([c.depth for c in children], default=0)
        if depth > MAX_DEPTH:
            raise ValueError(f"the tree would be {depth} levels deep, more than {MAX_DEPTH}: "
                             "group long chains (e.g. one blend of many children rather than "
                             "blends of blends)")
        self._set("depth", depth)
        for p in cls.PARAMS:
            self._set(p.name, p.kind.check(p.name, values[p.name]))
        self._check()

    def _bind(self, args: tuple, kwargs: dict[str, Any]) -> dict[str, Any]:
        """The constructor's arguments by name, bound by its signature (Python's error for an
        unknown or missing argument, with the type's name)."""
        try:
            bound = type(self).__signature__.bind(self, *args, **kwargs)
        except TypeError as e:
            raise TypeError(f"{type(self).__name__}: {e}") from None
        bound.apply_defaults()
        values = dict(bound.arguments)
        values.pop("self")
        return values

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
        keyed = all("key" in c.__dict__ for c in self.children)
        for node in (self,) if keyed else self.unique():  # children first: no deep recursion
            if "key" not in node.__dict__:  # TYPE|name=value|...|child key|...
                text = "|".join([node.TYPE,
                                 *[label + key_of(getattr(node, attr))
                                   for attr, label, key_of in node._keyed],
                                 *[c.__dict__["key"] for c in node.children]])
                node.__dict__["key"] = hashlib.sha256(text.encode()).hexdigest()[:32]
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
        """A global bound on ``|grad f|``."""
        raise NotImplementedError

    def memo(self, name: str, make: Callable[[], Any] | None = None) -> Any:
        """A value of this node's subtree kept on the node under ``name``: computed by ``make``
        the first time (a node is a value: what its subtree gives never changes); None if it
        is not kept and there is no ``make``."""
        kept = self.__dict__
        if name not in kept:
            if make is None:
                return None
            kept[name] = make()
        return kept[name]

    def box_memo(self, known: dict[bytes, geo.Box] | None = None) -> dict[bytes, geo.Box]:
        """The boxes :meth:`box` computed, by frame; ``known``: a structurally equal node's
        (the same boxes), to start from if this node has none yet."""
        return self._frame_memo("_box_memo", known)

    def _frame_memo(self, name: str, known: dict | None = None) -> dict:
        """The memo by frame kept on the node under ``name`` (one of ``FRAME_MEMOS``),
        ``known`` (else empty) if it has none yet; read directly, as ``by_frame``'s callers
        ask for it thousands of times a compile."""
        memo = self.__dict__.get(name)
        if memo is None:
            memo = self.__dict__[name] = {} if known is None else known
        return memo

    def box(self, L: np.ndarray) -> geo.Box:
        """``_box``, computed once per frame (a shared subtree is not walked again)."""
        return by_frame(self.box_memo(), L, self._read_only_box)

    def _read_only_box(self, L: np.ndarray) -> geo.Box:
        lo, hi = self._box(L)
        box = (np.array(lo, dtype=float), np.array(hi, dtype=float))
        for a in box:
            a.setflags(write=False)
        return box

    def lipschitz(self) -> float:
        """A global bound on ``|grad f|`` (computed once)."""
        return self.memo("_lipschitz_memo", lambda: float(self._lipschitz()))

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
