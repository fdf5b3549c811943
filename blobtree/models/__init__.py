"""Built-in models: the DESIGN.md yardstick ``whorl126`` and the paper's Murex cabritii."""

from .helico import MUREX_SPIRAL, HelicoSpiral, helico_spiral, place
from .whorl import whorl126

__all__ = ["MUREX_SPIRAL", "HelicoSpiral", "helico_spiral", "place", "whorl126"]
