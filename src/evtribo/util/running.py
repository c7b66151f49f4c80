"""Running counts of a mask: exactly :func:`numpy.cumsum`'s values, accumulated in 32-bit
integers.

numpy accumulates booleans into 64-bit integers through a casting loop without vector code:
2.1 ms for the 330 k grid points of a load cell, where an accumulation into 32-bit integers
takes 0.16 ms. The analysis counts the samples missing per moving-average span and present
per window that way, several times a trial.

What it replaces: ``numpy.cumsum`` of the mask; ``tests/util/test_median.py`` holds the two
equal on any mask.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["running_count"]


def running_count(mask: npt.ArrayLike, *, initial: bool = False
                  ) -> npt.NDArray[np.signedinteger]:
    """``numpy.cumsum(mask)`` of a 1-D boolean array.

    Parameters
    ----------
    mask : array_like of bool
    initial : bool
        Start with a 0: the counts before each element, then the total.

    Returns
    -------
    ndarray of int32 (int64 beyond 2**31 - 1 elements)
    """
    a = np.asarray(mask, dtype=bool).ravel()
    out: npt.NDArray[np.signedinteger] = np.zeros(
        a.size + int(initial), dtype=np.int32 if a.size <= np.iinfo(np.int32).max else np.int64)
    np.cumsum(a, dtype=out.dtype, out=out[int(initial):])
    return out
