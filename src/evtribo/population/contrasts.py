"""Contrasts between two conditions the subjects were measured in: population_contrasts.csv.

Paired within subjects: for each subject measured in both conditions, the mean over the
amplitudes it has in both of log F_el(b) - log F_el(a) (the log of its geometric mean
ratio) and the difference of its own weighted exponents, each with its variance from the
subject's cells' covariance (which carries their correlation across conditions); then pooled
across subjects (:func:`~evtribo.population.stats.pool`): the ratio (exp of the
mean) and the difference, with their 95 % intervals.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence

import numpy as np
from numpy.typing import NDArray

from evtribo.population.data import (
    Collector,
    Condition,
    SubjectData,
    condition_label,
    exp_or_nan,
)

__all__ = ["contrast"]


def _pairs(subjects: Sequence[SubjectData], a: Condition, b: Condition
           ) -> Iterator[tuple[str, NDArray[np.int64], NDArray[np.int64]]]:
    """Each subject's cells of *a* and *b* at the amplitudes it has in both."""
    for s in subjects:
        ia, ib = s.select(a), s.select(b)
        amp = s.cells["amplitude_V"].to_numpy(float)
        common = [x for x in amp[ia] if np.isclose(amp[ib], x).any()]
        if common:
            ia = np.array([i for i in ia if np.isclose(common, amp[i]).any()])
            ib = np.array([i for i in ib if np.isclose(common, amp[i]).any()])
            yield s.name, ia, ib


def contrast(rows: Collector, subjects: Sequence[SubjectData], a: Condition, b: Condition) -> None:
    """The ratio of the forces of *b* to *a*, and the difference of their exponents.

    Parameters
    ----------
    rows : Collector
        Where the rows (and outliers, notes) go.
    subjects : sequence of SubjectData
    a, b : (str, float)
        The conditions: waveform and drive frequency, Hz.

    Returns
    -------
    None
    """
    la, lb = condition_label(*a), condition_label(*b)
    by_name = {s.name: s for s in subjects}
    ratio: tuple[list[str], list[float], list[float]] = ([], [], [])
    slope: tuple[list[str], list[float], list[float]] = ([], [], [])
    for name, ia, ib in _pairs(subjects, a, b):
        s = by_name[name]
        w = np.concatenate([-np.ones(ia.size), np.ones(ib.size)]) / ia.size
        idx = np.concatenate([ia, ib])
        _append(ratio, name, float(w @ s.cells["log_f"].to_numpy(float)[idx]),
                float(w @ s.cov[np.ix_(idx, idx)] @ w))
        if ia.size >= 2:
            log_u = np.log(s.cells["amplitude_V"].to_numpy(float)[ia])
            wd = np.concatenate([-_slope_weights(log_u, s.cov[np.ix_(ia, ia)]),
                                 _slope_weights(log_u, s.cov[np.ix_(ib, ib)])])
            _append(slope, name, float(wd @ s.cells["log_f"].to_numpy(float)[idx]),
                    float(wd @ s.cov[np.ix_(idx, idx)] @ wd))
    for name, (names, y, v), exp in (("electrostatic_force_N", ratio, True),
                                     ("exponent", slope, False)):
        if not names:
            continue
        what = ("F_el ratio" if exp else "exponent difference") + f", {lb} to {la}"
        got = rows.pooled(what, names, np.array(y), np.array(v), check=False)
        if got is None:
            continue
        p = got[0]
        f = exp_or_nan if exp else float
        rows.contrasts.append({"condition_a": la, "condition_b": lb, "quantity": name,
                               "ratio": f(p.estimate) if exp else math.nan,
                               "difference": math.nan if exp else p.estimate,
                               "ci_low": f(p.ci_low), "ci_high": f(p.ci_high),
                               "n_subjects": p.n_subjects})


def _slope_weights(log_u: NDArray[np.float64], cov: NDArray[np.float64]
                   ) -> NDArray[np.float64]:
    """The weights that give a subject's weighted power-law exponent from its log forces."""
    x = np.column_stack([np.ones(log_u.size), log_u - log_u.mean()])
    cx = np.linalg.solve(cov, x)
    return np.asarray(np.linalg.solve(x.T @ cx, cx.T)[1], dtype=float)


def _append(into: tuple[list[str], list[float], list[float]], name: str, value: float,
            variance: float) -> None:
    if math.isfinite(value) and math.isfinite(variance) and variance > 0:
        into[0].append(name)
        into[1].append(value)
        into[2].append(variance)
