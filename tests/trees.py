"""Hypothesis strategies for random BlobTrees built from every node type."""

from __future__ import annotations

import numpy as np
from hypothesis import strategies as st

import blobtree as bt
from blobtree.spiral import HelicoSpiral
from blobtree.texture import HelicoSurface

coord = st.floats(-1.0, 1.0, allow_nan=False)
vec = st.tuples(coord, coord, coord)
radius = st.floats(0.3, 1.2)
falloff = st.sampled_from(["soft_object", "cubic"])


@st.composite
def point(draw):
    return bt.Point(radius=draw(radius), center=draw(vec), falloff=draw(falloff))


@st.composite
def segment(draw):
    a = np.array(draw(vec))
    b = a + np.array(draw(vec)) + 0.1
    return bt.Segment(a, b, radius=draw(radius), falloff=draw(falloff))


@st.composite
def cone(draw):
    a = np.array(draw(vec))
    b = a + np.array(draw(vec)) + 0.1
    return bt.Cone(a, b, radius_a=draw(radius), radius_b=draw(radius), falloff=draw(falloff))


@st.composite
def torus(draw):
    return bt.Torus(major_radius=draw(st.floats(0.2, 1.0)), radius=draw(radius),
                    center=draw(vec), falloff=draw(falloff))


@st.composite
def disc(draw):
    return bt.Disc(disc_radius=draw(st.floats(0.2, 1.0)), radius=draw(radius), center=draw(vec))


@st.composite
def cylinder(draw):
    a = np.array(draw(vec))
    b = a + np.array(draw(vec)) + 0.1
    return bt.Cylinder(a, b, cylinder_radius=draw(st.floats(0.1, 0.6)), radius=draw(radius))


primitives = st.one_of(point(), segment(), cone(), torus(), disc(), cylinder())


def _nary(children, smooth_only):
    names = ["blend", "super_blend"]
    if not smooth_only:
        names += ["union", "intersection", "difference", "controlled_blend"]

    @st.composite
    def make(d):
        cs = d(st.lists(children, min_size=2, max_size=4))
        name = d(st.sampled_from(names))
        if name == "super_blend":
            return bt.super_blend(*cs, n=d(st.sampled_from([1.0, 2.0, 7.5, 400.0])))
        if name == "controlled_blend":
            return bt.controlled_blend(cs, pairs=[(0, 1)])
        return getattr(bt, name)(*cs)

    return make()


def _unary(children):
    @st.composite
    def make(d):
        c = d(children)
        kind = d(st.sampled_from(["translate", "scale", "scale3", "rotate", "bend", "twist",
                                  "taper", "color", "texture"]))
        if kind == "translate":
            return c.translate(*d(vec))
        if kind == "scale":
            return c.scale(d(st.floats(0.5, 2.0)))
        if kind == "scale3":
            return c.scale(*d(st.tuples(*[st.floats(0.5, 2.0)] * 3)))
        if kind == "rotate":
            return c.rotate(d(st.sampled_from(["x", "y", "z", (1.0, 2.0, -0.5)])),
                            d(st.floats(-180, 180)))
        if kind == "bend":
            lo, hi = c.bounds()
            toward = d(st.sampled_from(["x", "y", "z"]))
            axis = d(st.sampled_from([a for a in "xyz" if a != toward]))
            reach = max(hi["xyz".index(toward)], -lo["xyz".index(toward)], 0.1)
            length = d(st.floats(0.5, 2.0))
            max_deg = np.degrees(length / (reach * 1.5))
            deg = d(st.floats(5.0, float(min(90.0, max_deg)))) * d(st.sampled_from([1, -1]))
            return c.bend(deg, length, axis=axis, toward=toward)
        if kind == "twist":
            return c.twist(d(st.floats(-90, 90)), axis=d(st.sampled_from(["x", "y", "z"])))
        if kind == "taper":
            axis = d(st.sampled_from(["x", "y", "z"]))
            lo, hi = c.bounds()
            ext = max(abs(lo["xyz".index(axis)]), abs(hi["xyz".index(axis)]), 0.1)
            return c.taper(d(st.floats(-0.5, 0.5)) / ext, axis=axis)
        if kind == "texture":
            img = np.random.default_rng(d(st.integers(0, 99))).integers(0, 256, (3, 5, 3))
            mapping = d(st.sampled_from(["primitive", "helico"]))
            if mapping == "helico":
                mapping = HelicoSurface(spiral=HelicoSpiral(r0=0.3), radius_factor=1.0,
                                        theta_max=720.0, max_steps=8)
            return c.texture(img.astype(np.uint8), mapping=mapping,
                             wrap=d(st.sampled_from(["repeat", "clamp"])))
        return c.color(d(st.tuples(*[st.floats(0.0, 1.0)] * 3)))

    return make()


def trees(smooth_only: bool = False, max_leaves: int = 8):
    """Random trees; ``smooth_only`` leaves out the CSG operators (whose gradients jump)."""
    return st.recursive(
        primitives,
        lambda children: st.one_of(_nary(children, smooth_only), _unary(children)),
        max_leaves=max_leaves,
    )


def sample_points(tree: bt.Node, n: int, seed: int, grow: float = 0.2) -> np.ndarray:
    """Uniform points in the tree's bounds, grown by a fraction on every side."""
    lo, hi = tree.bounds()
    if np.any(lo > hi):  # empty support (e.g. a disjoint intersection): sample around it
        lo, hi = np.full(3, -2.0), np.full(3, 2.0)
    pad = grow * (hi - lo) + 1e-3
    return np.random.default_rng(seed).uniform(lo - pad, hi + pad, (n, 3))
