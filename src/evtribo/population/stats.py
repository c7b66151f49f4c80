"""The statistics of a population of subjects, from estimates that each carry an interval.

Every subject's numbers (its electrostatic force at an amplitude, its friction coefficient,
its fitted air gap) are measurements with a known uncertainty, not exact values, and the
subjects are a sample of a population. With the within-subject variances taken as known and
the between-subject variance estimated:

:func:`pool`
    One value per subject: a random-effects meta-analysis (statsmodels'
    :func:`~statsmodels.stats.meta_analysis.combine_effects`), the between-subject variance
    by Paule and Mandel's estimator, the 95 % interval by Hartung and Knapp (Sidik and
    Jonkman): Student's t with k - 1 degrees of freedom and the variance of the mean
    estimated from the subjects' scatter, never below the plain random-effects variance (the
    "ad hoc" variant of Röver, Knapp and Friede 2015).

:func:`find_outliers`
    A subject whose value lies outside the prediction interval of the others (Higgins,
    Thompson and Spiegelhalter 2009: Student's t with k - 3 degrees of freedom for k - 1
    other subjects), at a level Bonferroni-corrected for the k subjects tested, is named an
    outlier. :mod:`evtribo.population.estimates` divides the study's 5 % among the quantities
    it checks, so that about one study in twenty of a population without outliers names
    one.

Several amplitudes per subject, fitted with a power law across subjects, are
:mod:`evtribo.population.model`'s.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import stats

log = logging.getLogger(__name__)

__all__ = ["MIN_SUBJECTS", "MIN_SUBJECTS_OUTLIERS", "OUTLIER_ALPHA", "POOL_METHOD", "Outlier",
           "Pooled", "find_outliers", "pool"]

#: Fewest subjects for a population estimate.
MIN_SUBJECTS = 3
#: Fewest subjects among whom an outlier can be named (a prediction interval from the
#: others needs at least four of them).
MIN_SUBJECTS_OUTLIERS = 5
#: Family-wise level of the outlier test.
OUTLIER_ALPHA = 0.05
_Q95 = 0.975

POOL_METHOD = ("random-effects meta-analysis (Paule-Mandel between-subject variance, "
               "Hartung-Knapp interval)")


@dataclass(frozen=True)
class Pooled:
    """A population's typical value from one value per subject.

    Attributes
    ----------
    estimate, ci_low, ci_high : float
        The population mean and its 95 % interval (on the scale of the values given).
    between_sd : float
        The between-subject standard deviation (tau).
    n_subjects : int
        Subjects pooled.
    method : str
        How it was estimated.
    """

    estimate: float
    ci_low: float
    ci_high: float
    between_sd: float
    n_subjects: int
    method: str = POOL_METHOD


def _pm(values: NDArray[np.float64], variances: NDArray[np.float64]) -> tuple[float, float,
                                                                               float]:
    """The random-effects mean, its Hartung-Knapp variance (ad hoc) and tau^2."""
    from statsmodels.stats.meta_analysis import combine_effects

    with np.errstate(divide="ignore", invalid="ignore"):  # I^2 of subjects that agree
        res = combine_effects(values, variances, method_re="iterated", use_t=True)
    tau2 = max(float(res.tau2), 0.0)
    var_hk = max(float(res.var_hksj_re), float(res.var_eff_w_re))
    return float(res.mean_effect_re), var_hk, tau2


def pool(values: ArrayLike, variances: ArrayLike) -> Pooled:
    """Random-effects meta-analysis of one value per subject with a known variance each.

    Parameters
    ----------
    values : array_like
        Each subject's estimate.
    variances : array_like
        Its variance (the square of its standard error), > 0.

    Returns
    -------
    Pooled
        The mean with its Hartung-Knapp 95 % interval (Student's t, k - 1 degrees of
        freedom) and tau.

    Raises
    ------
    ValueError
        With fewer than :data:`MIN_SUBJECTS` values, or a variance that is not > 0.
    """
    y = np.asarray(values, dtype=float)
    v = np.asarray(variances, dtype=float)
    if y.size < MIN_SUBJECTS or y.shape != v.shape:
        raise ValueError(f"pool needs at least {MIN_SUBJECTS} values with a variance each")
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(v)) and np.all(v > 0)):
        raise ValueError("values and variances must be finite, variances > 0")
    mean, var, tau2 = _pm(y, v)
    half = float(stats.t.ppf(_Q95, y.size - 1)) * math.sqrt(var)
    return Pooled(mean, mean - half, mean + half, math.sqrt(tau2), int(y.size))


@dataclass(frozen=True)
class Outlier:
    """A subject outside the prediction interval of the others.

    Attributes
    ----------
    subject : str
    value : float
        Its value.
    low, high : float
        The others' prediction interval at the corrected level.
    """

    subject: str
    value: float
    low: float
    high: float


def find_outliers(values: ArrayLike, variances: ArrayLike, subjects: Sequence[str], *,
                  alpha: float = OUTLIER_ALPHA) -> list[Outlier]:
    """The subjects each outside the others' prediction interval (Bonferroni over all).

    Parameters
    ----------
    values, variances : array_like
        Each subject's estimate and its variance.
    subjects : sequence of str
        Their names.
    alpha : float
        The level of the test for all *subjects* together (each is tested at alpha / k).

    Returns
    -------
    list of Outlier
        Empty with fewer than :data:`MIN_SUBJECTS_OUTLIERS` subjects.
    """
    y = np.asarray(values, dtype=float)
    v = np.asarray(variances, dtype=float)
    k = y.size
    if k < MIN_SUBJECTS_OUTLIERS:
        return []
    q = float(stats.t.ppf(1.0 - alpha / (2 * k), k - 3))
    found = []
    for i in range(k):
        others = np.arange(k) != i
        mean, var, tau2 = _pm(y[others], v[others])
        half = q * math.sqrt(tau2 + var + v[i])
        if abs(y[i] - mean) > half:
            found.append(Outlier(str(subjects[i]), float(y[i]), mean - half, mean + half))
    return found
