"""Shell pigmentation grown, not painted: Meinhardt's activator-inhibitor model.

The paper's textures "were created in a paint program"; its authors point to reaction-diffusion
(Meinhardt, *The Algorithmic Beauty of Sea Shells*, the paper's reference [5]; Fowler, Meinhardt
and Prusinkiewicz, SIGGRAPH 1992, its reference [2]).  A shell grows at its lip: a row of cells
along the lip carries an activator a and an inhibitor b, and the pigment laid down at each moment
is a record of a along the lip.  So the texture's columns are time (the growth direction, u
along the spiral, as ``texture.sample`` reads u across an image) and its rows are the cells
along the lip (v around the whorl).

The model, Meinhardt's activator-inhibitor equations (ABoSS, Eq. 2.1), per cell i:

    da/dt = s_i (a^2 / b + b_a) - r_a a + D_a d2a/dx2
    db/dt = s_i a^2 - r_b b + D_b d2b/dx2 + b_b

with s_i the source density of cell i (1 plus small random fluctuations: the seed of the
pattern), integrated by explicit Euler steps of one time unit on cells one unit apart, with
impermeable ends (the lip's two ends).  A pattern forms where the inhibitor diffuses much faster
than the activator (Turing's condition, D_b >> D_a); a slow inhibitor (small r_b) makes the
pattern oscillate in time, so that stripes run oblique.

The simulation itself (:class:`ActivatorInhibitor`, :func:`grow`) lives in
:mod:`blobtree.textures`, with the other models and the named patterns; this module lays its
result out as a texture for the shell.
"""

from __future__ import annotations

import numpy as np

from ..textures import GROUND, MAX_DIFFUSION, PIGMENT, ActivatorInhibitor, grow, tint, to_uint8

__all__ = ["GROUND", "MAX_DIFFUSION", "PIGMENT", "ActivatorInhibitor", "grow", "pigment_texture"]

#: The default model of :func:`pigment_texture`: stripes along the growth direction.
STRIPES = ActivatorInhibitor()


def pigment_texture(height: int = 256, width: int = 128, model: ActivatorInhibitor = STRIPES,
                    seed: int = 0, steps_per_row: int = 4, warmup: int = 400,
                    ground: np.ndarray = GROUND, pigment: np.ndarray = PIGMENT) -> np.ndarray:
    """An (height, width, 3) uint8 texture of pigment grown by :func:`grow` (after ``warmup``
    steps, so the pattern has formed): ``width`` columns of growth (u along the spiral),
    ``height`` cells along the lip (v around the whorl).  Pigment rises with the activator: a
    pale tint at the uniform steady state a*, full pigment from 3 a*."""
    if not isinstance(model, ActivatorInhibitor):
        raise ValueError(f"model must be an ActivatorInhibitor, got {type(model).__name__}")
    a = grow(height, width, steps_per_row, model, seed, warmup).T
    a_star = model.steady_state()[0]
    return to_uint8(tint(a, 0.5 * a_star, 3.0 * a_star, ground, pigment))
