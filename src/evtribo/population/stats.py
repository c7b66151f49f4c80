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

Several amplitudes per subject, fitted with a power law across subjects, are the
population models' (:mod:`evtribo.population.models`: the mixed model of the power law, and
the meta-analysis of log F_el at each amplitude, which pools with :func:`pool`).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

# scipy.stats' distributions' functions are scipy.special's (the same numbers, without its import)
from scipy import optimize, special

log = logging.getLogger(__name__)

__all__ = ["MIN_SUBJECTS", "MIN_SUBJECTS_OUTLIERS", "OUTLIER_ALPHA", "POOL_METHOD", "Outlier",
           "Pooled", "find_outliers", "i_squared", "pool", "tau_interval", "typical_variance"]

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
    pi_low, pi_high : float
        The 95 % prediction interval of a new subject's value (Higgins, Thompson and
        Spiegelhalter 2009: Student's t with k - 2 degrees of freedom).
    tau_low, tau_high : float
        The 95 % interval of tau (Q-profile, Viechtbauer 2007).
    i2, i2_low, i2_high : float
        I^2, the share of the subjects' scatter that is between them rather than their
        measurements' (Higgins and Thompson 2002), and its 95 % interval (from tau's).
    """

    estimate: float
    ci_low: float
    ci_high: float
    between_sd: float
    n_subjects: int
    method: str = POOL_METHOD
    pi_low: float = math.nan
    pi_high: float = math.nan
    tau_low: float = math.nan
    tau_high: float = math.nan
    i2: float = math.nan
    i2_low: float = math.nan
    i2_high: float = math.nan


def _pm(values: NDArray[np.float64], variances: NDArray[np.float64]) -> tuple[float, float,
                                                                               float]:
    """The random-effects mean, its Hartung-Knapp variance (ad hoc) and tau^2."""
    from statsmodels.stats.meta_analysis import combine_effects

    with np.errstate(divide="ignore", invalid="ignore"):  # I^2 of subjects that agree
        res = combine_effects(values, variances, method_re="iterated", use_t=True)
    tau2 = max(float(res.tau2), 0.0)
    var_hk = max(float(res.var_hksj_re), float(res.var_eff_w_re))
    return float(res.mean_effect_re), var_hk, tau2


def _q_generalised(tau2: float, y: NDArray[np.float64], v: NDArray[np.float64]) -> float:
    w = 1.0 / (v + tau2)
    mean = float(np.sum(w * y) / np.sum(w))
    return float(np.sum(w * (y - mean) ** 2))


def tau_interval(values: ArrayLike, variances: ArrayLike) -> tuple[float, float]:
    """The 95 % interval of tau by the Q-profile method (Viechtbauer 2007): where the
    generalised Q statistic meets the 2.5 and 97.5 % points of chi-square with k - 1
    degrees of freedom.

    Parameters
    ----------
    values, variances : array_like
        Each subject's estimate and its variance.

    Returns
    -------
    (float, float)
        0 where Q is below the quantile at tau = 0.
    """
    y, v = np.asarray(values, dtype=float), np.asarray(variances, dtype=float)
    k = y.size
    ends = []
    for p in (_Q95, 1.0 - _Q95):
        target = 2.0 * float(special.gammaincinv((k - 1) / 2.0, p))  # chi2.ppf
        if _q_generalised(0.0, y, v) <= target:
            ends.append(0.0)
            continue
        hi = max(float(np.var(y, ddof=1)), float(np.max(v)), 1e-12)
        while _q_generalised(hi, y, v) > target:
            hi *= 4.0
        def excess(t: float, target: float = target) -> float:
            return _q_generalised(t, y, v) - target

        ends.append(float(optimize.brentq(excess, 0.0, hi, xtol=1e-14, rtol=1e-10)))
    return math.sqrt(ends[0]), math.sqrt(ends[1])


def typical_variance(variances: ArrayLike) -> float:
    """The "typical" within-subject variance of I^2 (Higgins and Thompson 2002):
    ``(k - 1) sum w / ((sum w)^2 - sum w^2)`` with ``w = 1 / variance``.

    Parameters
    ----------
    variances : array_like

    Returns
    -------
    float
    """
    w = 1.0 / np.asarray(variances, dtype=float)
    w = w[np.isfinite(w) & (w > 0)]
    denom = float(w.sum() ** 2 - np.sum(w * w))
    return (w.size - 1) * float(w.sum()) / denom if w.size > 1 and denom > 0 else math.nan


def i_squared(tau: float, typical: float) -> float:
    """``tau^2 / (tau^2 + typical)`` (NaN when either is not finite).

    Parameters
    ----------
    tau : float
    typical : float
        The typical within-subject variance.

    Returns
    -------
    float
    """
    if tau == math.inf and math.isfinite(typical):
        return 1.0
    if not (math.isfinite(tau) and math.isfinite(typical)):
        return math.nan
    return tau * tau / (tau * tau + typical)


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
        freedom), tau and I^2 with their intervals, and the prediction interval.

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
    k = y.size
    half = float(special.stdtrit(k - 1, _Q95)) * math.sqrt(var)
    pi = float(special.stdtrit(k - 2, _Q95)) * math.sqrt(tau2 + var)
    t_lo, t_hi = tau_interval(y, v)
    s2 = typical_variance(v)
    return Pooled(mean, mean - half, mean + half, math.sqrt(tau2), int(k),
                  pi_low=mean - pi, pi_high=mean + pi, tau_low=t_lo, tau_high=t_hi,
                  i2=i_squared(math.sqrt(tau2), s2), i2_low=i_squared(t_lo, s2),
                  i2_high=i_squared(t_hi, s2))


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
    q = float(special.stdtrit(k - 3, 1.0 - alpha / (2 * k)))
    found = []
    for i in range(k):
        others = np.arange(k) != i
        mean, var, tau2 = _pm(y[others], v[others])
        half = q * math.sqrt(tau2 + var + v[i])
        if abs(y[i] - mean) > half:
            found.append(Outlier(str(subjects[i]), float(y[i]), mean - half, mean + half))
    return found
