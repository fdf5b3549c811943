"""Built-in models: the yardstick ``whorl126`` (docs/conventions.md), the paper's Murex cabritii
shell and the models of the paper's figures."""

from .figures import FIGURES
from .helico import MUREX_SPIRAL, HelicoSpiral, helico_spiral, place
from .murex import (
    TABLE_1,
    TABLE_2,
    Choices,
    body_whorl,
    bumps,
    canal_spines,
    generating_surface,
    inside_wall,
    inside_whorl,
    murex,
    opening,
    shell,
    varices,
    varix,
    whorl,
)
from .pigment import ActivatorInhibitor, pigment_texture
from .whorl import whorl126

__all__ = [
    "FIGURES", "MUREX_SPIRAL", "TABLE_1", "TABLE_2", "ActivatorInhibitor", "Choices",
    "HelicoSpiral", "body_whorl",
    "bumps", "canal_spines", "generating_surface", "helico_spiral", "inside_wall",
    "inside_whorl", "murex", "opening", "pigment_texture", "place", "shell", "varices", "varix",
    "whorl", "whorl126",
]
