"""The weights that make an average of ON windows fair to both sliding directions.

A finger's friction differs between forward and backward strokes, and a cell that reads a
few % of the other axis adds to one direction what it takes from the other: averaged over
windows as they come, such differences follow how many strokes went each way. Weighing
each direction alike within a trial (and each trial by its share of the windows) cancels
them to first order (docs/analysis.md).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["balanced_weights"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


def balanced_weights(counts: FloatArray, trial: IntArray, direction: FloatArray
                      ) -> FloatArray:
    """Weights of windows (summing to 1 in each row of *counts*, the windows' resampled
    counts) that give each trial its share of the windows and, within a trial, each sliding
    direction it has the same share.

    Parameters
    ----------
    counts : ndarray, shape (rows, windows)
        How often each window is drawn (ones for the estimate itself).
    trial, direction : ndarray, shape (windows,)
        Each window's trial and sliding direction.

    Returns
    -------
    ndarray, shape (rows, windows)
    """
    out = np.zeros(counts.shape)
    n = trial.size
    for s in np.unique(trial):
        in_trial = trial == s
        c = counts[:, in_trial]
        d = direction[in_trial]
        dirs = np.unique(d)
        totals = np.stack([c[:, d == x].sum(axis=1) for x in dirs], axis=1)  # (rows, dirs)
        present = (totals > 0).sum(axis=1, keepdims=True)
        which = np.searchsorted(dirs, d)
        per = np.where(totals[:, which] > 0, c / np.maximum(totals[:, which], 1e-300), 0.0)
        out[:, in_trial] = per / np.maximum(present, 1) * (in_trial.sum() / n)
    return out
