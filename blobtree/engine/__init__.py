"""The compiled engine: a tree flattened into a program that numba kernels evaluate.

``dispatch`` derives opcodes and one dispatcher per kind of kernel from the node registry;
``program`` compiles trees; ``walk`` is the one program walk, which ``point`` runs at a point,
``bounds`` over a region and ``batch`` over batches of points (cell by cell); ``specialize``
shortens a program to a region.  Importing the engine installs its
compiler for ``Node.program()``.
"""

from ..nodes.node import use_compiler
from .program import GRID_MIN_POINTS, Program, compile_tree

use_compiler(compile_tree)

__all__ = ["GRID_MIN_POINTS", "Program", "compile_tree"]
