"""Shell pigmentation grown by Meinhardt's reaction-diffusion models.

A shell grows only at its lip, and the pigment it lays down at each moment records the state of a
row of cells along the lip.  So a shell pattern is the space-time plot of a one-dimensional
reaction-diffusion system: one coordinate is the position along the lip, the other is time
(H. Meinhardt, *The Algorithmic Beauty of Sea Shells*, Springer 1995, "ABoSS"; D. R. Fowler,
H. Meinhardt and P. Prusinkiewicz, "Modeling seashells", SIGGRAPH 1992, "FMP92"; the BlobTree
paper's references [5] and [2]).

:func:`meinhardt` grows an image that way: ``width`` cells along the lip, one image row per
recorded moment (row 0 the oldest, time running down the rows, ``steps_per_row`` Euler steps per
row), after a warm-up so the pattern has formed.  The colour is the ground colour blended toward
the pigment colour by the activator level (:func:`tint`).  The named presets are
:data:`PATTERNS`; :func:`pattern_sheet` shows them side by side (docs/figures/patterns.png).

The models, per cell i (' is d/dx, s_i the source density of cell i: a scale times 1 plus small
random fluctuations, which seed the pattern):

* :class:`ActivatorInhibitor`, ABoSS Eq. 2.1 (FMP92 section 3.2), s_i about 1:
  a' = s (a^2 / b + b_a) - r_a a + D_a a'',   b' = s a^2 - r_b b + D_b b'' + b_b;
  optionally with a saturation s_a of the autocatalysis (a^2 / b becomes
  a^2 / (b (1 + s_a a^2))).
* :class:`ActivatorSubstrate`, ABoSS Eq. 2.4 (FMP92 section 3.1), s_i about r_a; the
  autocatalysis uses up a substrate b:
  a' = s b (a^2 / (1 + s_a a^2) + b_a) - r_a a + D_a a'',
  b' = b_b - s b (a^2 / (1 + s_a a^2) + b_a) - r_b b + D_b b''.
* :class:`HormoneWaves`, the Oliva porphyria model (Meinhardt and Klingler, J. theor. Biol. 126,
  1987; ABoSS, the chapter on global control; FMP92's Oliva porphyria), s_i about r_a: an
  activator with a local inhibitor whose lifetime a hormone c, the same all along the lip, sets:
  a' = s (a^2 / (1 + s_a a^2) + b_a) / (s_b + b) - r_a a + D_a a'',
  b' = s a^2 / (1 + s_a a^2) - (r_b / c) b + D_b b'',
  c' = r_c (mean_i a_i - c).

All are integrated by explicit Euler steps of one time unit on cells one unit apart, with
impermeable ends (the lip's two ends), and concentrations clamped at 0 (the inhibitor of Eq. 2.1
at 1e-12, as it divides).  Diffusion is stable for D < 0.5; a step also needs 4 D + r < 2 for
each substance (the presets keep well inside).  Everything is vectorised over the cells and only
the time steps loop: a 256 x 1024 image takes 0.04-0.25 s.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import ClassVar

import numpy as np

from ..checks import RGB, Choice, Integer, Kind, Number

#: Ground and pigment colours (sRGB in [0, 1]) of :func:`blobtree.models.pigment_texture`: the
#: shell's cream and a dark reddish brown.
GROUND = np.array([0.94, 0.88, 0.78])
PIGMENT = np.array([0.42, 0.22, 0.14])
#: Explicit diffusion is stable for D < 0.5 (cells and time steps of one unit).
MAX_DIFFUSION = 0.49

_DIFFUSION = Number(lo=0.0, hi=MAX_DIFFUSION)
_RATE = Number(lo=0.0, hi=1.0, lo_open=True)
_SHARE = Number(lo=0.0, hi=1.0)
_CONSTANT = Number(lo=0.0, hi=100.0)


def _diffuse(x: np.ndarray) -> np.ndarray:
    """The discrete second derivative along the cells, with impermeable ends."""
    padded = np.concatenate([x[:1], x, x[-1:]])
    return padded[:-2] - 2.0 * x + padded[2:]


def _sources(cells: int, scale: float, fluctuation: float,
             rng: np.random.Generator) -> np.ndarray:
    """The source densities s_i = scale (1 + fluctuation u_i), u_i uniform in [-1, 1)."""
    return scale * (1.0 + fluctuation * (2.0 * rng.random(cells) - 1.0))


@dataclass(frozen=True)
class Model:
    """A reaction-diffusion system along the lip.  Subclasses name their parameters' allowed
    values in ``_KINDS``, set up a state (:meth:`start`, the activator first) and advance it by
    one Euler step (:meth:`step`)."""

    #: The model's name in :class:`Pattern` and error messages.
    kind: ClassVar[str] = ""
    _KINDS: ClassVar[dict[str, Kind]] = {}

    def __post_init__(self) -> None:
        for f in fields(self):
            value = self._KINDS[f.name].check(f.name, getattr(self, f.name))
            object.__setattr__(self, f.name, value)

    def start(self, cells: int, rng: np.random.Generator) -> list:
        """The state at time 0: [a, ...] with a the activator along the cells."""
        raise NotImplementedError

    def step(self, state: list) -> None:
        """One explicit Euler step of one time unit, in place."""
        raise NotImplementedError


@dataclass(frozen=True)
class ActivatorInhibitor(Model):
    """Meinhardt's activator-inhibitor model (ABoSS Eq. 2.1), s_i = 1 + fluctuations:
    diffusion rates ``d_a``, ``d_b`` (cells^2 per step, below 0.5), decay rates ``r_a``, ``r_b``,
    basic productions ``b_a``, ``b_b``, the relative ``fluctuation`` of the source density and
    ``s_a``, the saturation of the autocatalysis (0, the default, for Eq. 2.1 as printed; the
    saturated form a^2 / (b (1 + s_a a^2)) is this module's addition, after Eq. 2.4's).  The
    defaults grow stripes along the growth direction with occasional branching: a Turing
    pattern (D_b >> D_a, r_b > r_a).  A longer-lived inhibitor (r_b < r_a) makes the uniform
    state oscillate instead."""

    kind: ClassVar[str] = "activator-inhibitor"
    d_a: float = 0.01
    d_b: float = 0.4
    r_a: float = 0.03
    r_b: float = 0.04
    b_a: float = 0.0
    b_b: float = 0.0
    fluctuation: float = 0.05
    s_a: float = 0.0
    _KINDS: ClassVar[dict[str, Kind]] = {
        "d_a": _DIFFUSION, "d_b": _DIFFUSION, "r_a": _RATE, "r_b": _RATE, "b_a": _SHARE,
        "b_b": _SHARE, "fluctuation": _SHARE, "s_a": _CONSTANT}

    def steady_state(self) -> tuple[float, float]:
        """The uniform steady state (a*, b*) for s = 1 and no basic production:
        a* = r_b / r_a, b* = a*^2 / r_b."""
        a = self.r_b / self.r_a
        return a, a * a / self.r_b

    def start(self, cells: int, rng: np.random.Generator) -> list:
        """The uniform steady state a*, b*; the source densities' fluctuations break its
        symmetry."""
        s = _sources(cells, 1.0, self.fluctuation, rng)
        a0, b0 = self.steady_state()
        return [np.full(cells, a0), np.full(cells, b0), s]

    def step(self, state: list) -> None:
        a, b, s = state
        a2 = a * a
        auto = a2 / b if not self.s_a else a2 / (b * (1.0 + self.s_a * a2))
        a_next = a + s * (auto + self.b_a) - self.r_a * a + self.d_a * _diffuse(a)
        state[1] = np.maximum(b + s * a2 - self.r_b * b + self.d_b * _diffuse(b) + self.b_b,
                              1e-12)
        state[0] = np.maximum(a_next, 0.0)


@dataclass(frozen=True)
class ActivatorSubstrate(Model):
    """Meinhardt's activator-substrate (depletion) model (ABoSS Eq. 2.4), with s_i = r_a (1 +
    fluctuations) as in Meinhardt's programs: the autocatalysis uses up a substrate b that is
    produced everywhere (``b_b``) and decays (``r_b``); ``s_a`` saturates the autocatalysis.
    The defaults (the "waves" preset) make every cell a relaxation oscillator (the uniform state
    a* = b_b / r_a < 1 is unstable) with a substrate that does not spread: a firing cell
    triggers its neighbours and then runs out of substrate, so waves travel along the lip, leave
    oblique lines, and annihilate where they meet; the fastest cells become pacemakers."""

    kind: ClassVar[str] = "activator-substrate"
    d_a: float = 0.2
    d_b: float = 0.0
    r_a: float = 0.2
    r_b: float = 0.0
    b_a: float = 0.01
    b_b: float = 0.16
    s_a: float = 0.1
    fluctuation: float = 0.2
    _KINDS: ClassVar[dict[str, Kind]] = {
        "d_a": _DIFFUSION, "d_b": _DIFFUSION, "r_a": _RATE, "r_b": _SHARE, "b_a": _SHARE,
        "b_b": _SHARE, "s_a": _CONSTANT, "fluctuation": _SHARE}

    def start(self, cells: int, rng: np.random.Generator) -> list:
        """No activator, substrate at random levels in [0, 2 b_b / r_a): the cells start out of
        phase."""
        s = _sources(cells, self.r_a, self.fluctuation, rng)
        b = 2.0 * self.b_b / self.r_a * rng.random(cells)
        return [np.zeros(cells), b, s]

    def step(self, state: list) -> None:
        a, b, s = state
        a2 = a * a
        production = s * b * (a2 / (1.0 + self.s_a * a2) + self.b_a)
        a_next = a + production - self.r_a * a + self.d_a * _diffuse(a)
        b_next = b + self.b_b - production - self.r_b * b
        if self.d_b:
            b_next += self.d_b * _diffuse(b)
        state[1] = np.maximum(b_next, 0.0)
        state[0] = np.maximum(a_next, 0.0)


@dataclass(frozen=True)
class HormoneWaves(Model):
    """The Oliva porphyria model (Meinhardt and Klingler, J. theor. Biol. 126, 1987; ABoSS, the
    chapter on global control, and its program for Oliva porphyria; FMP92), s_i = r_a (1 +
    fluctuations): an activator a (saturation ``s_a``) with a local, non-spreading inhibitor b
    (Michaelis-Menten constant ``s_b``) makes bursts that run along the lip as waves and
    annihilate where they meet; every active cell makes a hormone c (rate ``r_c``, the same all
    along the lip) that prolongs the inhibitor's life (decay r_b / c).  When too few cells are
    active the hormone falls, the inhibitor decays fast, active cells stay active and start
    backward-running waves: new branches, and triangles that open and close.  Starts with no
    activator except at a few cells (``spacing`` cells apart on average).  The defaults are the
    parameters of Meinhardt's program."""

    kind: ClassVar[str] = "activator-inhibitor-hormone"
    d_a: float = 0.015
    d_b: float = 0.0
    r_a: float = 0.1
    r_b: float = 0.014
    b_a: float = 0.0
    s_a: float = 0.25
    s_b: float = 0.1
    r_c: float = 0.1
    fluctuation: float = 0.04
    spacing: float = 60.0
    _KINDS: ClassVar[dict[str, Kind]] = {
        "d_a": _DIFFUSION, "d_b": _DIFFUSION, "r_a": _RATE, "r_b": _RATE, "b_a": _SHARE,
        "s_a": _CONSTANT, "s_b": Number(lo=0.0, hi=100.0, lo_open=True), "r_c": _RATE,
        "fluctuation": _SHARE, "spacing": Number(lo=2.0, hi=4096.0)}

    def start(self, cells: int, rng: np.random.Generator) -> list:
        """a = 0 but at a few cells (a = 1) spaced 10 to 2 spacing - 10 cells apart, b = 0.1,
        c = 0.5 (as in Meinhardt's program for Oliva porphyria)."""
        s = _sources(cells, self.r_a, self.fluctuation, rng)
        a = np.zeros(cells)
        gaps = rng.uniform(min(10.0, self.spacing / 2), max(2.0 * self.spacing - 10.0,
                           self.spacing), int(cells / self.spacing) + 2)
        at = (rng.uniform(0.0, self.spacing) + np.concatenate([[0.0], np.cumsum(gaps)]))
        a[at[at < cells].astype(int)] = 1.0
        return [a, np.full(cells, 0.1), s, np.array(0.5)]

    def step(self, state: list) -> None:
        a, b, s, c = state
        a2 = a * a
        auto = s * a2 / (1.0 + self.s_a * a2)
        a_next = a + (auto + s * self.b_a) / (self.s_b + b) - self.r_a * a \
            + self.d_a * _diffuse(a)
        b_next = b + auto - self.r_b / c * b
        if self.d_b:
            b_next += self.d_b * _diffuse(b)
        state[3] = c + self.r_c * (a.mean() - c)
        state[1] = np.maximum(b_next, 0.0)
        state[0] = np.maximum(a_next, 0.0)


_MODELS = (ActivatorInhibitor, ActivatorSubstrate, HormoneWaves)


def _check_model(model: object) -> None:
    """ValueError unless ``model`` is a :class:`Model` that can run (a subclass instance)."""
    if not isinstance(model, Model) or type(model) is Model:
        raise ValueError(f"model must be one of {[m.__name__ for m in _MODELS]} (a Model), got "
                         f"{type(model).__name__}")


def grow(cells: int, rows: int, steps_per_row: int = 4,
         model: Model = ActivatorInhibitor(), seed: int = 0, warmup: int = 0) -> np.ndarray:
    """The activator along a lip of ``cells`` cells, recorded every ``steps_per_row`` time steps
    for ``rows`` rows after ``warmup`` unrecorded steps: a (rows, cells) array, time down the
    rows.  The model's start state and its source densities' fluctuations come from ``seed``."""
    cells = Integer(3, 4096).check("cells", cells)
    rows = Integer(1, 16384).check("rows", rows)
    steps_per_row = Integer(1, 1000).check("steps_per_row", steps_per_row)
    warmup = Integer(0, 100_000).check("warmup", warmup)
    seed = Integer(0, 2**63 - 1).check("seed", seed)
    _check_model(model)
    state = model.start(cells, np.random.default_rng(seed))
    for _ in range(warmup):
        model.step(state)
    out = np.empty((rows, cells))
    for row in range(rows):
        for _ in range(steps_per_row):
            model.step(state)
        out[row] = state[0]
    return out


def tint(a: np.ndarray, low: float, high: float, ground: np.ndarray = GROUND,
         pigment: np.ndarray = PIGMENT) -> np.ndarray:
    """Colours (shape a.shape + (3,), floats in [0, 1]) for activator levels ``a``: the ground
    colour up to ``low``, blended linearly toward the pigment colour, reached at ``high``."""
    t = np.clip((a - low) / (high - low), 0.0, 1.0)[..., None]
    g = np.asarray(ground, float)
    rgb = g + (np.asarray(pigment, float) - g) * t
    return np.clip(rgb, 0.0, 1.0)


def to_uint8(rgb: np.ndarray) -> np.ndarray:
    """Colours in [0, 1] as uint8 values."""
    return np.round(np.clip(rgb, 0.0, 1.0) * 255.0).astype(np.uint8)


@dataclass(frozen=True)
class Pattern:
    """A named shell pattern: a :class:`Model` (its ``kind`` and parameters), the Euler
    ``steps_per_row`` between recorded rows, the unrecorded ``warmup`` steps, the ``ground`` and
    ``pigment`` colours, the activator levels (``low``, ``high``) where the pigment starts and
    where it is full, and ``doc``: the equations and where they come from."""

    model: Model
    steps_per_row: int
    warmup: int
    ground: tuple[float, float, float]
    pigment: tuple[float, float, float]
    low: float
    high: float
    doc: str

    def __post_init__(self) -> None:
        _check_model(self.model)
        Integer(1, 1000).check("steps_per_row", self.steps_per_row)
        Integer(0, 100_000).check("warmup", self.warmup)
        for name in ("ground", "pigment"):
            rgb = RGB().check(name, getattr(self, name))
            object.__setattr__(self, name, tuple(float(v) for v in rgb))
        low = Number(lo=0.0, hi=1e6).check("low", self.low)
        Number(lo=low, hi=1e6, lo_open=True).check("high", self.high)

    @property
    def kind(self) -> str:
        """The model's kind: ``"activator-inhibitor"``, ``"activator-substrate"`` or
        ``"activator-inhibitor-hormone"``."""
        return self.model.kind


#: The named presets of :func:`meinhardt`.
PATTERNS: dict[str, Pattern] = {
    "stripes": Pattern(
        model=ActivatorInhibitor(), steps_per_row=4, warmup=400,
        ground=(0.94, 0.88, 0.78), pigment=(0.42, 0.22, 0.14), low=0.5 * 4 / 3, high=3 * 4 / 3,
        doc="Stripes along the growth direction (perpendicular to the growing edge), with "
            "occasional branches: a stable Turing pattern of the activator-inhibitor model, "
            "ABoSS Eq. 2.1 (FMP92 section 3.2): a' = s (a^2/b + b_a) - r_a a + D_a a'', "
            "b' = s a^2 - r_b b + D_b b'' + b_b, with a fast-spreading inhibitor: D_a = 0.01, "
            "D_b = 0.4, r_a = 0.03, r_b = 0.04, b_a = b_b = 0, s = 1 +- 5 %, 4 steps per row "
            "(the parameters of blobtree.models.pigment_texture, chosen for this project).  "
            "Pigment from a*/2 to 3 a*, a* = r_b / r_a = 4/3."),
    "waves": Pattern(
        model=ActivatorSubstrate(), steps_per_row=1, warmup=6000,
        ground=(0.96, 0.90, 0.74), pigment=(0.30, 0.16, 0.20), low=0.8, high=3.0,
        doc="Oblique lines from travelling waves, inverted V's where a pacemaker starts two "
            "waves and V's where two waves meet and annihilate: the activator-substrate model, "
            "ABoSS Eq. 2.4 (FMP92 section 3.1): a' = s b (a^2/(1 + s_a a^2) + b_a) - r_a a "
            "+ D_a a'', b' = b_b - s b (a^2/(1 + s_a a^2) + b_a) - r_b b + D_b b'', with "
            "D_a = 0.2, D_b = 0, r_a = 0.2, r_b = 0, b_a = 0.01, b_b = 0.16, s_a = 0.1, "
            "s = r_a (1 +- 20 %), 1 step per row.  Each cell is a relaxation oscillator "
            "(a* = b_b / r_a = 0.8 < 1); the substrate does not spread, so a firing cell "
            "triggers its neighbours and runs out of substrate behind the wave.  Parameters "
            "tuned here by eye, not taken from a figure."),
    "triangles": Pattern(
        model=HormoneWaves(), steps_per_row=12, warmup=600,
        ground=(0.93, 0.84, 0.76), pigment=(0.33, 0.17, 0.12), low=0.2, high=1.2,
        doc="The tent-shaped lines and triangles of Oliva porphyria: Meinhardt and Klingler, "
            "J. theor. Biol. 126 (1987); ABoSS, the chapter on global control, and Meinhardt's "
            "program for Oliva porphyria; FMP92.  a' = s (a^2/(1 + s_a a^2) + b_a) / (s_b + b) "
            "- r_a a + D_a a'', b' = s a^2/(1 + s_a a^2) - (r_b/c) b + D_b b'', "
            "c' = r_c (mean a - c), with the program's parameters D_a = 0.015, D_b = 0, "
            "r_a = 0.1, r_b = 0.014, s_a = 0.25, s_b = 0.1, r_c = 0.1, b_a = 0, "
            "s = r_a (1 +- 4 %), 12 steps per row, started from a few active cells.  The "
            "antagonist is a local inhibitor, not a substrate: it stops each burst and leaves "
            "the cells behind a wave refractory.  Pigment levels and colours chosen here."),
    "bands": Pattern(
        model=ActivatorInhibitor(d_a=0.4, d_b=0.2, r_a=0.2, r_b=0.12, b_a=0.01, b_b=0.0,
                                 fluctuation=0.05, s_a=0.2),
        steps_per_row=1, warmup=600,
        ground=(0.97, 0.93, 0.86), pigment=(0.62, 0.30, 0.10), low=0.4, high=2.5,
        doc="Lines parallel to the growing edge: the activator-inhibitor model, ABoSS Eq. 2.1 "
            "with a saturated autocatalysis, a' = s (a^2/(b (1 + s_a a^2)) + b_a) - r_a a "
            "+ D_a a'', b' = s a^2 - r_b b + D_b b'' + b_b, with a longer-lived inhibitor than "
            "activator (r_b < r_a), so the uniform state oscillates in time, and fast-spreading "
            "substances that keep all cells in phase: D_a = 0.4, D_b = 0.2, r_a = 0.2, "
            "r_b = 0.12, b_a = 0.01, b_b = 0, s_a = 0.2, s = 1 +- 5 %, 1 step per row.  The "
            "saturation (an addition to Eq. 2.1 as printed, after Eq. 2.4) keeps the bursts "
            "bounded.  Parameters tuned here by eye."),
}

_NAMES = Choice(tuple(PATTERNS))


def meinhardt(name: str, width: int, height: int, seed: int = 0) -> np.ndarray:
    """An (height, width, 3) float image in [0, 1] of the preset ``name`` (:data:`PATTERNS`)
    grown as a shell grows it: ``width`` cells along the lip, one row per ``steps_per_row``
    Euler steps after the preset's warm-up, row 0 the oldest.  Colour: the ground blended toward
    the pigment by the activator level.  Deterministic by ``seed``."""
    name = _NAMES.check("name", name)
    width = Integer(3, 4096).check("width", width)
    height = Integer(1, 16384).check("height", height)
    seed = Integer(0, 2**63 - 1).check("seed", seed)
    p = PATTERNS[name]
    a = grow(width, height, p.steps_per_row, p.model, seed, p.warmup)
    return tint(a, p.low, p.high, np.array(p.ground), np.array(p.pigment))


def pattern_sheet(width: int = 160, height: int = 320, seed: int = 0) -> np.ndarray:
    """The presets of :data:`PATTERNS` side by side, each ``width`` x ``height`` with its name
    written under it: an RGB uint8 image (docs/figures/patterns.png)."""
    from PIL import Image, ImageDraw

    width = Integer(16, 4096).check("width", width)
    height = Integer(16, 16384).check("height", height)
    gap, label = 10, 22
    names = list(PATTERNS)
    sheet = Image.new("RGB", (gap + len(names) * (width + gap), gap + height + label),
                      (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    for k, name in enumerate(names):
        x = gap + k * (width + gap)
        sheet.paste(Image.fromarray(to_uint8(meinhardt(name, width, height, seed))), (x, gap))
        left, top, right, bottom = draw.textbbox((0, 0), name)
        draw.text((x + (width - (right - left)) // 2, gap + height + (label - bottom) // 2), name,
                  fill=(0, 0, 0))
    return np.asarray(sheet).copy()

#: The default model of :func:`pigment_texture`: stripes along the growth direction.
STRIPES = ActivatorInhibitor()


def pigment_texture(height: int = 256, width: int = 128, model: ActivatorInhibitor = STRIPES,
                    seed: int = 0, steps_per_row: int = 4, warmup: int = 400,
                    ground: np.ndarray = GROUND, pigment: np.ndarray = PIGMENT) -> np.ndarray:
    """An (height, width, 3) uint8 texture of pigment grown by
    :func:`~blobtree.texture.pigment.grow` (after ``warmup`` steps, so the pattern has formed):
    ``width`` columns of growth (u along the spiral), ``height`` cells along the lip (v around the
    whorl).  Pigment rises with the activator: a pale tint at the uniform steady state a*, full
    pigment from 3 a*."""
    if not isinstance(model, ActivatorInhibitor):
        raise ValueError(f"model must be an ActivatorInhibitor, got {type(model).__name__}")
    a = grow(height, width, steps_per_row, model, seed, warmup).T
    a_star = model.steady_state()[0]
    return to_uint8(tint(a, 0.5 * a_star, 3.0 * a_star, ground, pigment))
