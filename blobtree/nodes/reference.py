"""Helpers of the reference evaluator that several node types share: which child wins a CSG
operator's point, and the field-weighted colour of a blend."""

from __future__ import annotations

import numpy as np

#: Margin by which a later child's field must beat the best so far to win a union's or
#: intersection's point (its gradient and colour): children whose fields agree closer than
#: rounding (coinciding cone caps, overlapping segments) keep the first, in the compiled engine
#: (``kernel_math.select``) and in the reference (:func:`winner`) alike.  Absolute, since fields are
#: of order 1 and their rounding errors are absolute (relative to a field near 0 they are not
#: small).  A field of exactly 0 (outside a child's support) is never tied with a positive one:
#: a union takes the positive child, an intersection the zero one, as the specialised programs
#: do when they drop or zero a child that misses their region.
TIE = 1e-12


def winner(f: np.ndarray, largest: bool) -> np.ndarray:
    """Per point, the index of the child (row of ``f``) with the largest (or smallest) field,
    the first of those within :data:`TIE` of each other."""
    index = np.zeros(f.shape[1], dtype=np.int64)
    best = f[0]
    for j in range(1, len(f)):
        better = ((f[j] > best + TIE) | ((best == 0.0) & (f[j] > 0.0)) if largest
                  else (f[j] < best - TIE) | ((f[j] == 0.0) & (best > 0.0)))
        index = np.where(better, j, index)
        best = np.where(better, f[j], best)
    return index


def pick(index: np.ndarray, stacked: np.ndarray) -> np.ndarray:
    """stacked[index[n], n] for each point n."""
    return np.take_along_axis(stacked, index[None, :, None], axis=0)[0]


def weighted_color(w: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Sum w_i c_i / sum w_i; the first child's colour where all weights are 0."""
    total = w.sum(axis=0)
    safe = np.where(total > 0.0, total, 1.0)
    mean = (w[:, :, None] * c).sum(axis=0) / safe[:, None]
    return np.where((total > 0.0)[:, None], mean, c[0])
