"""The base classes of the node kinds: primitives, operators, unary nodes (affine transforms,
warps and paints)."""

from __future__ import annotations

from collections.abc import Callable
from functools import cached_property
from typing import Any, ClassVar

import numpy as np

from .. import geometry as geo
from ..checks import Choice
from ..fields import FALLOFFS, SLOPE, falloff_array
from .kernels import LIPSCHITZ_RULES
from .layout import Layout
from .node import DEFAULT_COLOR, Node, Result, by_frame
from .params import Param

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


class Operator(Node):
    """An n-ary operator on child BlobTrees (postfix: its children are evaluated first).

    Declares ``ZERO_FIRST`` / ``ZERO_REST`` (what a zero first / later child does under
    specialisation, see ``nodes.kernels.ZERO_RULES``), ``LIPSCHITZ``
    (``nodes.kernels.LIPSCHITZ_RULES``),
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
        rule = self.LIPSCHITZ
        if rule == "scaled":
            return float(self.op_params()[0] * sum(c.lipschitz() for c in self.program_children()))
        bounds = [c.lipschitz() for c in self.children]
        if rule == "sum":
            return float(sum(bounds))
        if rule == "max":
            return float(max(bounds))
        if rule == "norm":
            m, n = max(bounds), self.op_params()[0]
            return float(m * sum((b / m) ** n for b in bounds) ** (1.0 / n)) if m > 0.0 else 0.0
        raise TypeError(f"{type(self).__name__}.LIPSCHITZ is {rule!r}, not one of "
                        f"{LIPSCHITZ_RULES}")


class Unary(Node):
    """A node with one child."""

    ARITY = (1, 1)

    @property
    def child(self) -> Node:
        """The one child."""
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
        """The 3x4 affine map from the child's coordinates to this node's."""
        raise NotImplementedError

    @cached_property
    def inverse(self) -> np.ndarray:
        """The 3x4 map from this node's coordinates to the child's."""
        return geo.invert(self.matrix)

    def _ref(self, P, look=None):
        inv = self.inverse
        f, g, c = self.child._ref(geo.apply(inv, P), look)
        return f, g @ inv[:, :3], c

    @cached_property
    def folded(self) -> tuple[Node, np.ndarray]:
        """The first node below this chain of affine nodes that is not one, and the chain's
        maps composed (that node's coordinates -> this node's), read-only: a value of the
        subtree, so a chain placed in a new frame (a spiral changed) is composed with it
        once, not node by node."""
        node, M = self.child, self.matrix
        if node.KIND == "affine":
            node, inner = node.folded
            M = geo.compose(M, inner)
        M.setflags(write=False)
        return node, M

    def framed(self, L: np.ndarray) -> np.ndarray:
        """The frame of the node below the chain (:attr:`folded`) seen through L (this node ->
        frame): ``compose(L, chain matrix)``, read-only, computed once per frame (boxes and
        the compiler both ask for it)."""
        return by_frame(self._frame_memo("_framed"), L, self._composed)

    def _composed(self, L: np.ndarray) -> np.ndarray:
        M = geo.compose(L, self.folded[1])
        M.setflags(write=False)
        return M

    def below(self, L: np.ndarray) -> tuple[Node, np.ndarray]:
        """The first node below this chain of affine nodes that is not one, and its frame seen
        through L (:meth:`framed`)."""
        return self.folded[0], self.framed(L)

    def _box(self, L):
        node, M = self.below(L)
        return node.box(M)

    def _lipschitz(self):
        return self.child.lipschitz() * geo.spectral_norm(self.inverse[:, :3])


class Paint(Unary):
    """A node that sets the colour of its subtree (kernel: ``PaintKernels``).  ``sets_look``:
    instead of an instruction, it paints the primitives below with their own (u, v)."""

    KIND = "paint"

    @property
    def sets_look(self) -> bool:
        """Whether it paints the primitives below with their own (u, v) instead of being an
        instruction of the program (a field-interpolated texture)."""
        return False

    def pack(self, frame: np.ndarray, image_offset: Callable[[Node], int]) -> list[float]:
        """Its parameters in the program; ``frame`` maps its coordinates to the current frame,
        ``image_offset(node)`` places a texture image in the program."""
        raise NotImplementedError


def operator_function(cls: type[Operator], doc: str) -> Callable[..., Operator]:
    """The lowercase function of a registered operator type (``bt.blend`` for :class:`Blend`):
    it takes the type's own arguments (children, then its ``PARAMS`` with their defaults), so
    the function and the type cannot disagree."""
    def build(*children: Node, **params: Any) -> Operator:
        return cls(*children, **params)

    signature = cls.__signature__  # the type's, set by register
    build.__signature__ = signature.replace(parameters=list(signature.parameters.values())[1:])
    build.__name__ = build.__qualname__ = cls.TYPE
    build.__module__ = cls.__module__
    build.__doc__ = doc
    return build
