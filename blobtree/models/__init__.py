"""Built-in models: the yardstick ``whorl126`` (docs/conventions.md), shells built from specs
(:func:`shell`, :data:`~blobtree.models.spec.SHELLS`: the paper's Murex cabritii and other species)
and the models of the paper's figures."""

from ..helico import MUREX_SPIRAL, HelicoSpiral, helico_spiral, place
from ..texture.pigment import ActivatorInhibitor, pigment_texture
from .figures import FIGURES
from .murex import (
    TABLE_1,
    TABLE_2,
    body_whorl,
    bumps,
    canal_spines,
    generating_surface,
    inside_wall,
    inside_whorl,
    murex,
    opening,
    outer_shell,
    shell,
    varices,
    varix,
    whorl,
)
from .raup import raup, raup_spec
from .spec import SHELLS, ShellSpec, load_spec
from .yardstick import whorl126

__all__ = [
    "FIGURES", "MUREX_SPIRAL", "SHELLS", "TABLE_1", "TABLE_2", "ActivatorInhibitor",
    "HelicoSpiral", "ShellSpec", "body_whorl", "bumps", "canal_spines", "generating_surface",
    "helico_spiral", "inside_wall", "inside_whorl", "load_spec", "murex", "opening",
    "outer_shell", "pigment_texture", "place", "raup", "raup_spec", "shell", "varices", "varix",
    "whorl", "whorl126",
]
