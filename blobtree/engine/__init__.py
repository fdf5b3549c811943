"""The compiled engine: a tree flattened into a program that numba kernels evaluate.

``dispatch`` derives opcodes and one dispatcher per kind of kernel from the node registry;
``program`` compiles trees; ``interp`` runs a program at a point; ``specialize`` shortens it to a
region; ``batch`` evaluates large batches cell by cell.  Importing the engine installs its
compiler for ``Node.program()``.
"""

from ..nodes.node import use_compiler
from .program import GRID_MIN_POINTS, Program, compile_tree

use_compiler(compile_tree)

__all__ = ["GRID_MIN_POINTS", "Program", "compile_tree"]
