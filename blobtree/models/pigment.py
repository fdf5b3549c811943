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
pattern oscillate in time, so that stripes run oblique.  Every operation is vectorised over the
cells; only time steps loop.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..checks import Integer, Number

#: Ground and pigment colours (sRGB in [0, 1]): the shell's cream and a dark reddish brown.
GROUND = np.array([0.94, 0.88, 0.78])
PIGMENT = np.array([0.42, 0.22, 0.14])
#: Explicit diffusion is stable for D < 0.5 (cells and time steps of one unit).
MAX_DIFFUSION = 0.49


@dataclass(frozen=True)
class ActivatorInhibitor:
    """Parameters of Meinhardt's activator-inhibitor model (ABoSS Eq. 2.1): diffusion rates
    ``d_a``, ``d_b`` (cells^2 per step, below 0.5), decay rates ``r_a``, ``r_b``, basic
    productions ``b_a``, ``b_b``, and the relative ``fluctuation`` of the source density.  The
    defaults grow stripes along the growth direction with occasional branching."""

    d_a: float = 0.01
    d_b: float = 0.4
    r_a: float = 0.03
    r_b: float = 0.04
    b_a: float = 0.0
    b_b: float = 0.0
    fluctuation: float = 0.05

    def __post_init__(self) -> None:
        for name, kind in _KINDS.items():
            object.__setattr__(self, name, kind.check(name, getattr(self, name)))

    def steady_state(self) -> tuple[float, float]:
        """The uniform steady state (a*, b*) for s = 1 and no basic production:
        a* = r_b / r_a, b* = a*^2 / r_b."""
        a = self.r_b / self.r_a
        return a, a * a / self.r_b


_DIFFUSION, _RATE, _SHARE = (Number(lo=0.0, hi=MAX_DIFFUSION), Number(lo=0.0, hi=1.0, lo_open=True),
                             Number(lo=0.0, hi=1.0))
#: The allowed values of each parameter of :class:`ActivatorInhibitor`.
_KINDS = {"d_a": _DIFFUSION, "d_b": _DIFFUSION, "r_a": _RATE, "r_b": _RATE, "b_a": _SHARE,
          "b_b": _SHARE, "fluctuation": _SHARE}


def _diffuse(x: np.ndarray) -> np.ndarray:
    """The discrete second derivative along the cells, with impermeable ends."""
    padded = np.concatenate([x[:1], x, x[-1:]])
    return padded[:-2] - 2.0 * x + padded[2:]


def grow(cells: int, rows: int, steps_per_row: int = 4,
         model: ActivatorInhibitor = ActivatorInhibitor(), seed: int = 0,
         warmup: int = 0) -> np.ndarray:
    """The activator along a lip of ``cells`` cells, recorded every ``steps_per_row`` time steps
    for ``rows`` rows after ``warmup`` unrecorded steps: a (rows, cells) array, time down the
    rows.  Starts from the uniform steady state; the source densities' fluctuations (from
    ``seed``) break its symmetry."""
    cells = Integer(3, 4096).check("cells", cells)
    rows = Integer(1, 16384).check("rows", rows)
    steps_per_row = Integer(1, 1000).check("steps_per_row", steps_per_row)
    warmup = Integer(0, 100_000).check("warmup", warmup)
    seed = Integer(0, 2**63 - 1).check("seed", seed)
    if not isinstance(model, ActivatorInhibitor):
        raise ValueError(f"model must be an ActivatorInhibitor, got {type(model).__name__}")
    m = model
    rng = np.random.default_rng(seed)
    s = 1.0 + m.fluctuation * (2.0 * rng.random(cells) - 1.0)
    a0, b0 = m.steady_state()
    a = np.full(cells, a0)
    b = np.full(cells, b0)
    out = np.empty((rows, cells))
    for step in range(warmup + rows * steps_per_row):
        a2 = a * a
        a_next = a + s * (a2 / b + m.b_a) - m.r_a * a + m.d_a * _diffuse(a)
        b = np.maximum(b + s * a2 - m.r_b * b + m.d_b * _diffuse(b) + m.b_b, 1e-12)
        a = np.maximum(a_next, 0.0)
        done = step + 1 - warmup
        if done > 0 and done % steps_per_row == 0:
            out[done // steps_per_row - 1] = a
    return out


def pigment_texture(height: int = 256, width: int = 128, model: ActivatorInhibitor =
                    ActivatorInhibitor(), seed: int = 0, steps_per_row: int = 4,
                    warmup: int = 400, ground: np.ndarray = GROUND,
                    pigment: np.ndarray = PIGMENT) -> np.ndarray:
    """An (height, width, 3) uint8 texture of pigment grown by :func:`grow` (after ``warmup``
    steps, so the pattern has formed): ``width`` columns of growth (u along the spiral),
    ``height`` cells along the lip (v around the whorl).  Pigment rises with the activator: a
    pale tint at the uniform steady state a*, full pigment from 3 a*."""
    a = grow(height, width, steps_per_row, model, seed, warmup).T
    a_star = model.steady_state()[0]
    t = np.clip((a / a_star - 0.5) / 2.5, 0.0, 1.0)[..., None]
    rgb = np.asarray(ground, float) + (np.asarray(pigment, float) - np.asarray(ground, float)) * t
    return np.round(np.clip(rgb, 0.0, 1.0) * 255.0).astype(np.uint8)
