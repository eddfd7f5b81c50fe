"""Break points merged: the sorted union of two sets of times [s] or sweep fractions.

``np.union1d`` sorts the same values and drops the repeats, through NumPy's general ``unique``
(hash tables, masked-array and NaN handling: about 10 us a call on a few dozen numbers, and the
planner merges break points three times per arc and round). :func:`union_sorted` does only the
sort and the drop where every number is finite and not negative (times and sweep fractions),
which gives ``np.union1d``'s array; elsewhere it is ``np.union1d`` (which of 0 and -0 NumPy
keeps depends on its hash table).
"""

from __future__ import annotations

import numpy as np

__all__ = ["union_sorted"]


def union_sorted(a: np.ndarray, b: np.ndarray | list[float]) -> np.ndarray:
    """``np.union1d(a, b)``: the sorted distinct values of ``a`` and ``b`` (a new float
    array), made faster where no value is negative (-0 included) or NaN."""
    out = np.concatenate((a, b), axis=None).astype(float, copy=False)
    out.sort()
    if out.size and (np.signbit(out).any() or np.isnan(out[-1])):  # sorted: NaNs last
        return np.union1d(a, b)
    if out.size > 1:
        keep = np.empty(out.size, dtype=bool)
        keep[0] = True
        np.not_equal(out[1:], out[:-1], out=keep[1:])
        out = out[keep]
    return out
