"""A subject's friction against the pace of its strokes, from all its trials at once.

Finger-pad friction depends on the sliding speed (``mu ~ v**beta``, beta about 0.1-0.2;
Pasumarty et al. 2011, Adams et al. 2013), and a person's strokes differ in speed. The rig
rarely logs the finger's position, but each stroke's duration is in the data (from one
reversal of the friction to the next) and a hand's strokes cover about the same length, so
the stroke's rate follows its speed. :func:`pooled_rate_slope` fits the friction
coefficient's dependence on it over all of a subject's trials (it is the finger's, not one
trial's); :mod:`evtribo.analysis.friction.reference` takes every window's reference to its own
stroke's rate with it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from evtribo.analysis.friction.reference import (
    MAX_DEGREE,
    SPAN_PER_DEGREE_S,
    WindowFacts,
    time_basis,
)

__all__ = ["pooled_rate_slope"]

FloatArray = npt.NDArray[np.float64]


def pooled_rate_slope(parts: Sequence[tuple[npt.ArrayLike, npt.ArrayLike, WindowFacts,
                                            npt.ArrayLike]]) -> tuple[float, float]:
    """A subject's friction's dependence on its strokes' rate, from all its trials.

    Within each trial, ``log(F_t / F_n)`` and the windows' log stroke rate are freed of the
    trial's own level, each ON group's, the direction's and a trend in time
    (weighted least squares, weights ``F_n``); the slope of the one on the other, pooled
    over the trials, is the relative change of the friction coefficient per unit of log
    stroke rate (the finger's speed exponent, as far as the stroke rate follows the speed).

    Parameters
    ----------
    parts : sequence of (normal_N, friction_N, facts, group)
        Windows (OFF and ON), their facts (``stratum`` tells the trials) and their groups
        (NaN for OFF windows).

    Returns
    -------
    slope, se : float
        The slope and its standard error (NaN when the trials cannot tell it).
    """
    sxx = sxy = syy = 0.0
    dof = 0
    for fn_a, ft_a, facts, group_a in parts:
        fn, ft = np.asarray(fn_a, dtype=np.float64), np.asarray(ft_a, dtype=np.float64)
        group = np.asarray(group_a, dtype=np.float64)
        for s in np.unique(facts.stratum):
            sel = (facts.stratum == s) & (fn > 0) & (ft > 0) & np.isfinite(facts.rate)
            if sel.sum() < 8:
                continue
            part = facts.take(sel)
            Z = _nuisance(part, group[sel])
            if sel.sum() <= Z.shape[1] + 2:
                continue
            sw = np.sqrt(fn[sel])
            q, _ = np.linalg.qr(Z * sw[:, None])
            x = part.rate * sw
            y = np.log(ft[sel] / fn[sel]) * sw
            rx, ry = x - q @ (q.T @ x), y - q @ (q.T @ y)
            sxx, sxy, syy = sxx + rx @ rx, sxy + rx @ ry, syy + ry @ ry
            dof += int(sel.sum()) - Z.shape[1] - 1
    if not (sxx > 0 and dof > 0):
        return float("nan"), float("nan")
    slope = sxy / sxx
    return float(slope), float(np.sqrt(max(syy - slope * sxy, 0.0) / dof / sxx))


def _nuisance(facts: WindowFacts, group: FloatArray) -> FloatArray:
    """The within-trial terms the stroke rate is freed of: level, ON groups, direction and
    a trend in time (of the degree the trial's models may take)."""
    cols = [np.ones(len(facts))]
    for g in np.unique(group[np.isfinite(group)]):
        cols.append((group == g).astype(np.float64))
    if np.ptp(facts.direction) > 0:
        cols.append(facts.direction.astype(np.float64))
    t = facts.t_s
    if np.isfinite(t).all() and np.ptp(t) > 0:
        degree = min(MAX_DEGREE, int(np.ptp(t) // SPAN_PER_DEGREE_S))
        if degree:
            cols += list(time_basis(t, float(t.min()), float(t.max()), degree).T)
    return np.column_stack(cols)
