"""A shell as data: :class:`ShellSpec`, every number the shell builder needs, read from TOML.

A spec file is TOML (comments carry the sources of its numbers), version :data:`VERSION`:

    version = 1
    name = "Murex cabritii"
    extends = "murex"        # optional: start from a shipped spec, change what is listed

    [spiral]                 # Eqs. 1-3 (Eq. 7 for the Murex)
    beta = 22.5
    ...

Each table groups the fields of one part of the shell (``spiral``, ``whorls``, ``canal``,
``varices``, ``bumps``, ``canal_spines``, ``opening``, ``look``); :data:`FIELDS` lists every key
with its meaning and what it allows (docs/shells.md prints it).  Unknown tables and keys are
refused, as are values out of range, with the key's dotted name in the message.  Files are read
as data (``tomllib``), never executed.
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from types import MappingProxyType
from typing import Any

from ..checks import Choice, Integer, Kind, Number, positive, short_repr
from ..helico import HelicoSpiral
from ..texture.pigment import PATTERNS

#: The version of the spec format this code reads.
VERSION = 1
#: Where the shipped specs live (``SHELLS`` in ``blobtree.models``).
SHIPPED = Path(__file__).parent / "species"


# ----- kinds of spec values beyond checks.py ---------------------------------------------------
@dataclass(frozen=True)
class Flag(Kind):
    """true or false."""

    def check(self, name: str, value: Any) -> bool:
        if not isinstance(value, bool):
            raise ValueError(f"{name} must be true or false, got {short_repr(value)}")
        return value


@dataclass(frozen=True)
class Numbers(Kind):
    """A fixed number of values of one kind, kept as a tuple."""

    count: int = 2
    item: Kind = Number()

    def check(self, name: str, value: Any) -> tuple:
        if isinstance(value, str | bytes | Mapping) or not hasattr(value, "__len__") \
                or len(value) != self.count:
            raise ValueError(f"{name} must be a list of {self.count} values, got "
                             f"{short_repr(value)}")
        return tuple(self.item.check(f"{name}[{i}]", v) for i, v in enumerate(value))


@dataclass(frozen=True)
class ListOf(Kind):
    """A list (any length within [lo, hi]) of values of one kind, kept as a tuple."""

    item: Kind = Number()
    lo: int = 0
    hi: int = 1000

    def check(self, name: str, value: Any) -> tuple:
        if isinstance(value, str | bytes | Mapping) or not hasattr(value, "__len__") \
                or not self.lo <= len(value) <= self.hi:
            raise ValueError(f"{name} must be a list of {self.lo} to {self.hi} values, got "
                             f"{short_repr(value)}")
        return tuple(self.item.check(f"{name}[{i}]", v) for i, v in enumerate(value))


@dataclass(frozen=True)
class Text(Kind):
    """A short string."""

    def check(self, name: str, value: Any) -> str:
        if not isinstance(value, str) or not 0 < len(value) <= 200:
            raise ValueError(f"{name} must be a string of 1 to 200 characters, got "
                             f"{short_repr(value)}")
        return value


_SIZE, _FRACTION = positive(), Number(0.0, 1.0)
_COORD, _ANGLE = Number(-1e3, 1e3), Number(-360.0, 360.0)
#: A spine of a varix: (alpha_i in degrees, delta_i), as a row of Table 1.
_SPINE = Numbers(2, Number(-1e3, 1e3))
#: A colour.
_RGB = Numbers(3, _FRACTION)


def _spec(section: str, key: str, kind: Kind, doc: str) -> Any:
    return field(metadata={"section": section, "key": key, "kind": kind, "doc": doc})


@dataclass(frozen=True)
class ShellSpec:
    """Everything the shell builder (``blobtree.models.shell``) needs, in the local units of the
    generating curve (D(theta) = 1) unless stated.  ``SHELLS["murex"]`` holds the paper's
    numbers (Sections 3.1-3.4, Tables 1-2) and the choices it leaves open, each documented in
    its file."""

    name: str = _spec("", "name", Text(), "the species, as the figures and `blobtree models` "
                                          "name it")
    spiral: HelicoSpiral = _spec("spiral", "", Kind(), "Eqs. 1-3: beta (degrees), rho, r0, and "
                                                       "optionally d_ratio = D / R; or Raup's "
                                                       "W, D, T and r0")
    whorls: int = _spec("whorls", "count", Integer(1, 40), "number of whorls")
    whorl_deg: float = _spec("whorls", "degrees", Number(1.0, 720.0),
                             "angle of one whorl along the spiral (348 deg for the Murex)")
    sections_per_whorl: int = _spec("whorls", "sections", Integer(1, 24),
                                    "sections per whorl: a varix ends each section (Eq. 10)")
    instances_per_section: int = _spec("whorls", "instances", Integer(1, 64),
                                       "generating surfaces per section (Eq. 9)")
    point_radius: float = _spec("whorls", "point_radius", _SIZE,
                                "field radius of the generating point")
    point_scale: tuple = _spec("whorls", "point_scale", Numbers(3, Number(0.05, 20.0)),
                               "scale of the generating point along x (out from the axis), y "
                               "(along the axis) and z (along the spiral): an oval section")
    canal_sections: int = _spec("canal", "sections", Integer(0, 960),
                                "the last this many sections have a canal (0: none)")
    canal_base: tuple = _spec("canal", "base", Numbers(2, _COORD),
                              "start (x, y) of the canal cone, y toward the apex")
    canal_tilt: float = _spec("canal", "tilt", Number(1.0, 89.0),
                              "the canal leaves tilted this far toward the axis, then bends back")
    canal_gap: float = _spec("canal", "gap", Number(0.0, 1e3),
                             "distance from the straight end of the canal to the shell axis")
    canal_straight: float = _spec("canal", "straight", _SIZE, "length of the straight end")
    canal_radii: tuple = _spec("canal", "radii", Numbers(2, _SIZE),
                               "field radii of the canal cone at base and tip")
    canal_fuse: bool = _spec("canal", "fuse", Flag(),
                             "each canal section's canal blends with the later canal "
                             "sections' canals and points, not only its neighbours' (their "
                             "points do not: the suture stays Eq. 10's)")
    table_1: tuple = _spec("varices", "table", ListOf(ListOf(_SPINE, 0, 64), 1, 40),
                           "Table 1: per whorl, the (alpha_i deg, delta_i) of each curving "
                           "spine of its varices (Eqs. 11-12)")
    varix_placement: str = _spec("varices", "placement", Choice(("table", "grown")),
                                 "'table': spines as listed; 'grown': one row per varix, "
                                 "positions and sizes from two activator-inhibitors along the "
                                 "lip (models.growth)")
    first_whorl_varices: bool = _spec("varices", "first_whorl", Flag(),
                                      "whorl 1's varices (tori only when it lists no spines)")
    varices_down_canal: float = _spec("varices", "down_canal", _FRACTION,
                                      "part of the canal's length each varix of the canal "
                                      "sections runs down it, as a ridge (the tori extended) "
                                      "carrying Table 2's spines (0: the paper's varices stop "
                                      "short of the canal)")
    tori: tuple = _spec("varices", "tori", ListOf(Numbers(2, _SIZE), 0, 8),
                        "the concentric tori of a varix: (major radius, field radius) each")
    spine_offset: float = _spec("varices", "spine_offset", Number(0.0, 1e3),
                                "x_k of Eq. 11 for a spine: centre of the section to its base")
    spine_length: float = _spec("varices", "spine_length", _SIZE, "length before delta_i")
    spine_radii: tuple = _spec("varices", "spine_radii", Numbers(2, _SIZE),
                               "field radii of a spine at base and tip")
    spine_bend: float = _spec("varices", "spine_bend", Number(0.0, 180.0),
                              "curving spines: cones bent by this many degrees")
    spine_branches: int = _spec("varices", "branches", Integer(0, 8),
                                "side branches per spine (Chicoreus' foliated spines; 0: none)")
    bump_sets: int = _spec("bumps", "sets", Integer(0, 64),
                           "sets of bumps between two varices (0: none)")
    bump_size: float = _spec("bumps", "size", _SIZE, "s: the mean size of a bump")
    bump_offset: float = _spec("bumps", "offset", Number(0.0, 1e3),
                               "x_k of Eq. 11 for a bump: its centre")
    bump_z_extra: float = _spec("bumps", "z_extra", Number(0.0, 100.0),
                                "bumps scaled by (zeta_x, zeta_y, zeta_z + this)")
    bump_blend_n: float = _spec("bumps", "n", Number(1.0, 1e4),
                                "super-elliptic blend of the bumps with the shell (Eq. 4)")
    bump_join: str = _spec("bumps", "join", Choice(("super_elliptic", "gradient")),
                           "'super_elliptic': the bumps join the shell by bumps.n (the paper); "
                           "'gradient': each section's bumps join it by the gradient-based "
                           "blend (ours)")
    table_2: tuple = _spec("canal_spines", "table", ListOf(ListOf(_SIZE, 1, 64), 0, 12),
                           "Table 2: sizes of the canal spines of the last len(table) varices, "
                           "in order (the one at the opening last)")
    canal_spine_length: float = _spec("canal_spines", "length", _SIZE,
                                      "length of a canal spine of size 1")
    canal_spine_radii: tuple = _spec("canal_spines", "radii", Numbers(2, _SIZE),
                                     "field radii at base and tip")
    canal_spine_span: tuple = _spec("canal_spines", "span", Numbers(2, _FRACTION),
                                    "part of the canal's length they are spread over")
    canal_spine_tilt: float = _spec("canal_spines", "tilt", _ANGLE,
                                    "tilt toward the apex, degrees")
    canal_spine_base: float = _spec("canal_spines", "base", Number(0.0, 10.0),
                                    "base off the canal's centre line, in canal radii")
    canal_spine_min_size: float = _spec("canal_spines", "min_size", Number(0.0, 10.0),
                                        "spines smaller than this keep its thickness (cone radii "
                                        "times max(size, min_size) / size): printable tips")
    canal_spine_bends: tuple = _spec("canal_spines", "bends", Numbers(2, Integer(0, 10)),
                                     "each bent this many times (range) ...")
    canal_spine_bend_deg: tuple = _spec("canal_spines", "bend_degrees", Numbers(2, _ANGLE),
                                        "... by this many degrees (range)")
    opening: bool = _spec("opening", "carve", Flag(), "carve the opening (Eqs. 14-15)")
    previous_whorl: tuple = _spec("opening", "previous_whorl", Numbers(2, Integer(0, 10_000)),
                                  "instances of B_w kept by Eq. 14")
    inside_instances: tuple = _spec("opening", "inside_instances",
                                    Numbers(2, Integer(0, 10_000)),
                                    "instances of the inside whorl (past the last: open)")
    inside_scale: float = _spec("opening", "inside_scale", Number(0.01, 1.0),
                                "inside point radius / point_radius")
    inner_canal_scale: float = _spec("opening", "inner_canal_scale", Number(0.01, 1.0),
                                     "inner canal radii / canal_radii")
    inner_canal_cones: int = _spec("opening", "inner_canal_cones", Integer(0, 16),
                                   "slender inner-canal cones per instance step")
    extension_cones: int = _spec("opening", "extension_cones", Integer(0, 16),
                                 "cones reaching the previous whorl per instance step")
    extension_radii: tuple = _spec("opening", "extension_radii", Numbers(2, _SIZE),
                                   "their field radii at base and tip")
    extension_reach: float = _spec("opening", "extension_reach", Number(0.0, 10.0),
                                   "how far past the previous whorl's surface they reach")
    wall_scale: float = _spec("opening", "wall_scale", Number(0.01, 2.0),
                              "inside wall (Eq. 15) point radius / point_radius")
    wall_join: str = _spec("opening", "wall_join", Choice(("clipped", "union")),
                           "Eq. 15: 'union': (B_shell - B_opening) U B_inside_wall, the "
                           "paper's form; 'clipped': B_shell - (B_opening - B_inside_wall), "
                           "the same solid where the wall lies inside the shell, and no wall "
                           "outside it")
    lip_smooth: float = _spec("opening", "lip_smooth", Number(0.0, 0.5),
                              "rounding of the carved lip (Eq. 15's difference), in field "
                              "value: 0 = the sharp CSG cut")
    cut_smooth: float = _spec("opening", "cut_smooth", Number(0.0, 0.5),
                              "rounding of Eq. 14's difference and of the wall's, in field value")
    texture: str = _spec("look", "texture", Choice(("paper", "plain", *PATTERNS)),
                         "'paper': Figure 12's textures; 'plain': colours; or a pigment pattern "
                         "of bt.texture.PATTERNS grown along the body")
    colours: tuple = _spec("look", "colours", Numbers(4, _RGB),
                           "plain colours of body, varices, bumps and inside")
    up: tuple = _spec("look", "up", Numbers(3, Number(-1.0, 1.0)), "screen up for renders")
    view: tuple = _spec("look", "view", Numbers(3, Number(-1.0, 1.0)),
                        "direction the camera looks along")

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.name != "spiral":
                object.__setattr__(self, f.name, f.metadata["kind"].check(
                    dotted(f.name), getattr(self, f.name)))
        if not isinstance(self.spiral, HelicoSpiral):
            raise ValueError(f"spiral must be a HelicoSpiral, got {short_repr(self.spiral)}")
        if len(self.table_1) != self.whorls:
            raise ValueError(f"varices.table must list one row per whorl ({self.whorls}), got "
                             f"{len(self.table_1)}")
        if self.canal_sections > self.sections:
            raise ValueError(f"canal.sections must be at most the number of sections "
                             f"({self.sections}), got {self.canal_sections}")
        if len(self.table_2) > self.sections:
            raise ValueError(f"canal_spines.table must list at most {self.sections} rows, got "
                             f"{len(self.table_2)}")
        if self.varices_down_canal > 0 and not self.tori:
            raise ValueError(f"varices.down_canal must be 0 when varices.tori lists none (its "
                             f"ridge extends the tori), got {self.varices_down_canal}")
        for key, a, b in (("previous_whorl", "first", "last"),
                          ("inside_instances", "first", "last"),
                          ("canal_spine_bends", "low", "high"),
                          ("canal_spine_bend_deg", "low", "high")):
            lo, hi = getattr(self, key)
            if lo > hi:
                raise ValueError(f"{dotted(key)} must be ({a}, {b}) with {a} <= {b}, got "
                                 f"{(lo, hi)}")

    # ----- derived numbers (Section 3.1) ----------------------------------------------------
    @property
    def section_deg(self) -> float:
        """Angle of a section: 348 / 3 = 116 deg for the Murex."""
        return self.whorl_deg / self.sections_per_whorl

    @property
    def theta_s(self) -> float:
        """theta_s of Eq. 9: the angle between instances."""
        return self.section_deg / self.instances_per_section

    @property
    def sections(self) -> int:
        """Sections along the whole spiral (21 for the Murex, Eq. 10)."""
        return self.whorls * self.sections_per_whorl

    @property
    def instances(self) -> int:
        """Instances of the generating surface (126 for the Murex)."""
        return self.sections * self.instances_per_section

    @property
    def delta_max(self) -> float:
        """delta_max of Eq. 12: the largest delta_i of Table 1 (1 when it lists none)."""
        return max((d for row in self.table_1 for _, d in row), default=1.0)

    @property
    def axis_x(self) -> float:
        """x of the shell axis in the local frame: -R / D."""
        return -1.0 / self.spiral.d_over_r


#: Each spec key, dotted ("canal.tilt"), with its field; the spiral's keys are its own.
FIELDS: dict[str, Any] = {}
for _f in fields(ShellSpec):
    if _f.name != "spiral":
        _section, _key = _f.metadata["section"], _f.metadata["key"]
        FIELDS[f"{_section}.{_key}" if _section else _key] = _f
_DOTTED = {f.name: key for key, f in FIELDS.items()}
SPIRAL_KEYS = ("beta", "rho", "r0", "d_ratio")
#: Raup's coiling parameters, which a spiral table may give instead of beta, rho and d_ratio.
RAUP_KEYS = ("W", "D", "T")
TOP_KEYS = ("version", "name", "extends")


def dotted(name: str) -> str:
    """The spec key of a field ("canal_tilt" -> "canal.tilt")."""
    return _DOTTED.get(name, name)


def read_toml(path: str | Path) -> dict:
    """A spec file's data; a missing file or bad syntax is a ValueError naming the file."""
    path = Path(path)
    try:
        return tomllib.loads(path.read_text())
    except OSError as e:
        raise ValueError(f"{path}: cannot read the spec: {e.strerror or e}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise ValueError(f"{path}: not valid TOML: {e}") from None


def spec_from_data(data: Mapping, base: ShellSpec | None = None,
                   resolve: Any = None) -> ShellSpec:
    """A :class:`ShellSpec` from parsed TOML.  ``extends = NAME`` starts from ``resolve(NAME)``
    (or ``base``); without either every key is required."""
    if not isinstance(data, Mapping):
        raise ValueError(f"a spec must be a table of keys, got {short_repr(data)}")
    version = data.get("version")
    if version != VERSION:
        raise ValueError(f"version must be {VERSION} (this blobtree reads spec version "
                         f"{VERSION}), got {short_repr(version)}")
    if "extends" in data:
        if resolve is None:
            raise ValueError("extends is not allowed here")
        base = resolve(data["extends"])
    values: dict[str, Any] = {}
    spiral = {}
    for key, value in data.items():
        if key in TOP_KEYS:
            if key == "name":
                values["name"] = value
            continue
        if key == "spiral":
            if not isinstance(value, Mapping):
                raise ValueError(f"spiral must be a table, got {short_repr(value)}")
            unknown = sorted(set(value) - set(SPIRAL_KEYS) - set(RAUP_KEYS))
            if unknown:
                raise ValueError(f"spiral.{unknown[0]} is not a spec key; spiral allows "
                                 f"{list(SPIRAL_KEYS)}, or {list(RAUP_KEYS)} and r0")
            spiral = dict(value)
            continue
        if not isinstance(value, Mapping):
            raise ValueError(f"{key} is not a spec key or table; allowed: "
                             f"{sorted({k.split('.')[0] for k in FIELDS} | {'spiral'})}")
        for sub, v in value.items():
            dotted_key = f"{key}.{sub}"
            f = FIELDS.get(dotted_key)
            if f is None:
                allowed = sorted(k for k in FIELDS if k.startswith(key + "."))
                raise ValueError(f"{dotted_key} is not a spec key; allowed: "
                                 f"{allowed or sorted({k.split('.')[0] for k in FIELDS})}")
            values[f.name] = v
    if base is None:
        missing = [dotted(f.name) for f in fields(ShellSpec)
                   if f.name not in values and (f.name != "spiral" or not spiral)]
        if missing:
            raise ValueError(f"spec is missing {missing[:5]}{' ...' if len(missing) > 5 else ''}"
                             " (or give extends = a shipped spec's name)")
    if spiral:  # a spiral table is whole: it replaces the base's
        values["spiral"] = _spiral(spiral)
    if base is not None:
        return replace(base, **values)
    return ShellSpec(**values)


def _spiral(values: dict) -> HelicoSpiral:
    """The spiral of a spec's spiral table: beta, rho, r0 (and d_ratio), or Raup's W, D, T
    (and r0; :meth:`HelicoSpiral.from_raup`)."""
    raup = [k for k in RAUP_KEYS if k in values]
    if raup:
        mixed = sorted(set(values) - {*RAUP_KEYS, "r0"})
        if mixed or len(raup) < len(RAUP_KEYS):
            raise ValueError(f"spiral gives Raup's {raup}: it needs all of {list(RAUP_KEYS)} "
                             f"(and r0), without {mixed or 'nothing else'}")
        try:
            return HelicoSpiral.from_raup(values["W"], values["D"], values["T"],
                                          values.get("r0", 0.2))
        except ValueError as e:
            raise ValueError(f"spiral.{e}") from None
    for key in ("beta", "rho", "r0"):
        if key not in values:
            raise ValueError(f"spiral.{key} is missing")
    try:
        return HelicoSpiral(**values)
    except ValueError as e:
        raise ValueError(f"spiral.{e}") from None


def _shipped_specs() -> dict[str, ShellSpec]:
    """The specs in :data:`SHIPPED`, by file name; the Murex first, as others extend it."""
    out: dict[str, ShellSpec] = {}

    def resolve(name: Any) -> ShellSpec:
        if name not in out:
            raise ValueError(f"extends must name a shipped spec loaded before this one "
                             f"{sorted(out)}, got {short_repr(name)}")
        return out[name]

    for path in sorted(SHIPPED.glob("*.toml"), key=lambda p: (p.stem != "murex", p.stem)):
        try:
            out[path.stem] = spec_from_data(read_toml(path), resolve=resolve)
        except ValueError as e:
            raise ValueError(f"{path}: {e}") from None
    return out


#: The shipped species, by name: ``murex`` (the paper's), and the others of ``species/``.
SHELLS: Mapping[str, ShellSpec] = MappingProxyType(_shipped_specs())


def _resolve(name: Any) -> ShellSpec:
    if not isinstance(name, str) or name not in SHELLS:
        raise ValueError(f"extends must be one of {sorted(SHELLS)}, got {short_repr(name)}")
    return SHELLS[name]


def load_spec(spec: ShellSpec | Mapping | str | Path) -> ShellSpec:
    """A :class:`ShellSpec` from itself, a shipped name (:data:`~blobtree.models.spec.SHELLS`), a
    path to a TOML spec file or its parsed data."""
    if isinstance(spec, ShellSpec):
        return spec
    if isinstance(spec, Mapping):
        return spec_from_data(spec, resolve=_resolve)
    if isinstance(spec, str) and spec in SHELLS:
        return SHELLS[spec]
    if isinstance(spec, str | Path) and Path(spec).suffix == ".toml":
        try:
            return spec_from_data(read_toml(spec), resolve=_resolve)
        except ValueError as e:
            raise ValueError(e if str(e).startswith(str(spec)) else f"{spec}: {e}") from None
    raise ValueError(f"spec must be a shipped shell {sorted(SHELLS)}, a path to a .toml spec "
                     f"file, its data or a ShellSpec, got {short_repr(spec)}")


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value)
    return "[" + ", ".join(_toml_value(v) for v in value) + "]"


def to_toml(spec: ShellSpec) -> str:
    """The whole spec as TOML, every key with its meaning as a comment: a complete file to
    start a new species from (``blobtree spec NAME``); :func:`load_spec` reads it back equal."""
    lines = [f"# Shell spec, version {VERSION} (docs/shells.md).", f"version = {VERSION}",
             f"name = {_toml_value(spec.name)}", "",
             "[spiral]  # " + ShellSpec.__dataclass_fields__["spiral"].metadata["doc"]]
    for key in SPIRAL_KEYS:
        value = getattr(spec.spiral, key)
        if value is not None:
            lines.append(f"{key} = {_toml_value(value)}")
    section = ""
    for key, f in FIELDS.items():
        if "." not in key:
            continue
        table, sub = key.split(".", 1)
        if table != section:
            lines += ["", f"[{table}]"]
            section = table
        lines.append(f"# {f.metadata['doc']}")
        lines.append(f"{sub} = {_toml_value(getattr(spec, f.name))}")
    return "\n".join(lines) + "\n"
