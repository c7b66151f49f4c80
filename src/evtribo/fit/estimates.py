"""Each fitted parameter's value, standard error and 95 % interval (:func:`parameter_estimates`):
from the bootstrap refits, the Jacobian, or the likelihood profile.

Every parameter keeps to the values the model takes
(:data:`~evtribo.model.params.PARAMETER_BOUNDS`, scaled into :class:`~evtribo.fit.problem.
Problem`'s ``lower`` and ``upper``): an interval never reaches below a parameter's lower
bound (a gap is never thinner than 0, however far a misfit stretches the refits), and an
end at its upper bound is open (infinity: the data cannot tell the value from larger ones).

Forces that do not differ from zero. When the fitted model gives every point a force within
a hundredth of the point's error of zero (:func:`sees_no_force`: a subject whose forces are
all at or below their errors, such as a drive of 1 V), the fit has run to where the model
gives no force at all (the air gap at its largest): where it stopped is no estimate. The
value is then absent (NaN) and the interval is what the data do say, from the profile: the
values whose forces the points would have seen are excluded (``h_L`` at least so thick),
the other end open.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Collection
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import optimize

from evtribo.fit.params import parameter_unit
from evtribo.fit.problem import Problem
from evtribo.warning.collect import emitter

log = logging.getLogger(__name__)
emit = emitter(__name__)

__all__ = ["ParameterEstimate", "parameter_estimates", "profile_intervals", "sees_no_force"]

#: A fitted force within this share of its point's error of zero is no force the point sees.
NO_FORCE = 0.01


@dataclass(frozen=True)
class ParameterEstimate:
    """One fitted parameter: value, standard error and 95 % interval, SI units (the value
    NaN where the data do not determine it)."""

    name: str
    value: float
    stderr: float
    ci_low: float
    ci_high: float
    unit: str

    def contains(self, value: float) -> bool:
        """Whether *value* lies inside the 95 % interval."""
        return self.ci_low <= value <= self.ci_high


def sees_no_force(problem: Problem, x: NDArray[np.float64]) -> bool:
    """Whether the model at *x* gives every point a force within :data:`NO_FORCE` of its
    error of zero: the fit found no force in the subject's points.

    Parameters
    ----------
    problem : Problem
        The subject's problem.
    x : ndarray
        Scaled values (the solution).

    Returns
    -------
    bool
    """
    model = problem.model_at(x)
    return bool(np.all(np.isfinite(model))
                and np.all(np.abs(model) <= NO_FORCE * problem.pts.sigma))


def profile_intervals(problem: Problem, x: NDArray[np.float64], best: float, threshold: float,
                      which: Collection[int]) -> dict[int, tuple[float, float]]:
    """The likelihood-ratio interval of each parameter in *which*: where the least sum of
    squares with it held (the others refitted) exceeds the minimum *best* by *threshold*.
    An end of the range the data cannot exclude is open: the lower bound's value (0 in log
    space) or infinity.

    Parameters
    ----------
    problem : Problem
        The subject's problem.
    x : ndarray
        The solution, scaled.
    best : float
        The least weighted sum of squares.
    threshold : float
        The interval's quantile squared, in units of the inflated variance.
    which : collection of int
        The parameters.

    Returns
    -------
    dict
        ``{i: (low, high)}``, SI units.
    """
    out = {}
    for i in which:
        def excess(xi: float, i: int = i) -> float:
            return problem.profile_cost(i, xi, x) - best - threshold

        ends = []
        for bound in (problem.lower[i], problem.upper[i]):
            if not math.isfinite(bound) or excess(float(bound)) < 0:
                below = bound < x[i] or (bound == x[i] and bound == problem.lower[i])
                ends.append(_open(problem, i, below))
            else:
                root = optimize.brentq(excess, float(bound), float(x[i]), xtol=1e-4)
                ends.append(float(problem.to_values(np.where(
                    np.arange(len(x)) == i, root, x))[i]))
        out[i] = (ends[0], ends[1])
    return out


def _open(problem: Problem, i: int, below: bool) -> float:
    """The value of an open end of parameter *i*'s interval: its lower bound (0 in log
    space), or infinity."""
    if not below:
        return math.inf
    return 0.0 if problem.is_log[i] else float(problem.start[i] * problem.lower[i])


def parameter_estimates(problem: Problem, x: NDArray[np.float64], cov_x: NDArray[np.float64],
                        boot: NDArray[np.float64] | None, quantile: float, *,
                        profile: dict[int, tuple[float, float]],
                        absent: Collection[int] = ()) -> list[ParameterEstimate]:
    """Each parameter's value, standard error and 95 % interval: the replicates'
    percentiles, else *quantile* standard errors either side, or for a resistance (fitted
    in log space) its *profile* interval; an end the profile cannot close is open (0 or
    infinity) with either method. The parameters in *absent* (the fit saw no force) have no
    value: NaN, their *profile* interval.

    Parameters
    ----------
    problem : Problem
        The subject's problem.
    x : ndarray
        The solution, scaled.
    cov_x : ndarray
        The scaled parameters' covariance.
    boot : ndarray or None
        The scaled parameters refitted to the bootstrap replicates.
    quantile : float
        The interval's quantile of the standard error.
    profile : dict
        :func:`profile_intervals` of the log-space parameters and of *absent*.
    absent : collection of int
        The parameters the data do not determine (:func:`sees_no_force`).

    Returns
    -------
    list of ParameterEstimate
    """
    values = problem.to_values(x)
    deriv = problem.derivative(x)
    if boot is not None:  # percentiles of the scaled values (a monotone map of the values)
        with np.errstate(over="ignore", invalid="ignore"):
            q = np.quantile(boot, [0.025, 0.975], axis=0)
            # refits run off to infinity: the percentile there is infinite, not NaN
            lo_b, hi_b = np.where(np.isnan(q), np.quantile(boot, [0.025, 0.975], axis=0,
                                                           method="higher"), q)
            spread = np.std(problem.to_values(boot), axis=0, ddof=1)
    estimates = []
    for i, name in enumerate(problem.names):
        se_x = float(np.sqrt(cov_x[i, i])) if np.isfinite(cov_x[i, i]) else math.inf
        se = float(deriv[i]) * se_x if math.isfinite(se_x) else math.inf
        p_lo, p_hi = profile.get(i, (math.nan, math.nan))
        value = float(values[i])
        if i in absent:
            value, lo, hi = math.nan, p_lo, p_hi
        elif boot is not None:
            se = float(spread[i]) if not problem.is_log[i] else se
            lo = _scaled_value(problem, i, float(lo_b[i]))
            hi = _scaled_value(problem, i, float(hi_b[i]))
            lo, hi = 0.0 if p_lo == 0.0 else lo, math.inf if p_hi == math.inf else hi
        elif problem.is_log[i]:
            lo, hi = p_lo, p_hi
        elif math.isfinite(se_x):
            lo = float(values[i] - quantile * se) if x[i] - quantile * se_x > problem.lower[i] \
                else float(problem.start[i] * problem.lower[i])
            hi = float(values[i] + quantile * se)
        else:
            lo, hi = float(problem.start[i] * problem.lower[i]), math.inf
        if i not in absent and not math.isfinite(se_x) and not (
                problem.is_log[i] and (p_lo > 0 or p_hi < math.inf)):
            emit("parameter-undetermined", subject=problem.subject, parameter=name)
        if not math.isnan(value):  # a value at a bound (the percentiles of refits that
            lo, hi = min(lo, value), max(hi, value)  # left it) lies in its interval
        estimates.append(ParameterEstimate(name, value, se, float(lo), float(hi),
                                           parameter_unit(name)))
    return estimates


def _scaled_value(problem: Problem, i: int, x: float) -> float:
    """The value of parameter *i* at scaled *x*, within its bounds: its lower bound's value
    below it (0 in log space), infinity at or beyond its upper bound (the data cannot tell
    it from larger values there)."""
    if x >= problem.upper[i]:
        return math.inf
    if x <= problem.lower[i]:
        return _open(problem, i, True)
    return float(problem.start[i] * (math.exp(x) if problem.is_log[i] else x))
