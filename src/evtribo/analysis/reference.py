"""The friction an ON window is compared with: the OFF windows' coefficient at its own time,
direction and stroke speed.

A fingertip's friction coefficient is not one number (``docs/analysis.md``): it rises as the
skin under the finger moistens (tens of percent within a trial), it differs between
forward and backward strokes, and it depends on the sliding speed. Since the inferred force
``F_t,on / mu - F_n,on`` moves by about ``(F_n + F_el)`` times any relative error of ``mu``,
a 1 % error in ``mu`` is 5 mN at 0.5 N: at low voltages, more than the force itself. One
``mu`` per trial compared with ON windows at other times is such an error.

The OFF windows of a reference (an alternating trial, or a subject's whole-OFF trials) are
therefore described by a linear model of their friction coefficient, fitted by weighted
least squares::

    F_t,i / F_n,i = b0 + sum_k b_k P_k(x_i) + c d_i + e v_i + error,   weights F_n,i

with ``P_k`` Legendre polynomials of the window's time scaled to the OFF windows' span
(continued as straight lines beyond it), ``d`` the sliding direction (+1 / -1) and ``v``
the logarithm of the stroke's rate (one over its duration: the strokes of a hand cover
about the same length, so a stroke's rate stands in for its speed). With the constant
alone, the fit is the ratio of means ``sum F_t / sum F_n``. The time terms are only offered
for a reference within one trial (its own clock); how many of them, and whether the
stroke's rate enters, is chosen by the corrected Akaike criterion (AICc) among the models
the windows can support. Each ON window is then compared with the model at its own time,
direction and stroke rate: the comparison of each treatment phase with the baseline that
brackets it, as in the ABAB (reversal) designs of single-case experiments and the
interrupted time series with a trend (Huitema & McKean 2000).

Uncertainty: the model's coefficients are resampled by a wild cluster bootstrap (Cameron,
Gelbach & Miller 2008): each replicate adds the fit's residuals back to the fitted values,
their signs flipped together per stroke (windows of one stroke share its speed) with
Webb's six-point weights, the residuals scaled by ``1/sqrt(1 - h_ii)`` (HC2: unbiased
variances with few windows). The design stays fixed, so no replicate loses a direction or
a phase of the trial.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from itertools import product

import numpy as np
import numpy.typing as npt
from numpy.polynomial import legendre

from evtribo.errors import AnalysisError

__all__ = ["MAX_DEGREE", "MuModel", "WindowFacts", "fit_mu_model"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: Highest degree of the time polynomial.
MAX_DEGREE = 3
#: Seconds of OFF windows' span per degree of the time polynomial.
SPAN_PER_DEGREE_S = 4.0
#: Webb's six-point weights for the wild bootstrap (each drawn with probability 1/6).
WEBB = np.array([-np.sqrt(1.5), -1.0, -np.sqrt(0.5), np.sqrt(0.5), 1.0, np.sqrt(1.5)])


@dataclass(frozen=True)
class WindowFacts:
    """What locates windows in their trial, beside their forces (one value per window).

    Attributes
    ----------
    t_s : ndarray of float, s
        Middle of each window on its trial's clock (NaN: unknown).
    direction : ndarray of float
        Sliding direction, +1 / -1 (0: unknown).
    rate : ndarray of float
        Logarithm of the stroke's rate, ``-log(stroke duration / s)`` (NaN: unknown).
    cluster : ndarray of int
        Windows with the same number share a stroke: they are resampled together.
    stratum : ndarray of int
        The trial of each window (ON windows are averaged within a trial over both
        directions alike).
    """

    t_s: FloatArray
    direction: FloatArray
    rate: FloatArray
    cluster: IntArray
    stratum: IntArray

    @classmethod
    def plain(cls, n: int) -> WindowFacts:
        """*n* windows of which nothing is known but their forces (each its own stroke)."""
        return cls(np.full(n, np.nan), np.zeros(n), np.full(n, np.nan),
                   np.arange(n, dtype=np.int64), np.zeros(n, dtype=np.int64))

    def take(self, sel: npt.NDArray[np.bool_] | npt.NDArray[np.intp]) -> WindowFacts:
        """The facts of the windows *sel* (a mask or indices)."""
        return WindowFacts(self.t_s[sel], self.direction[sel], self.rate[sel],
                           self.cluster[sel], self.stratum[sel])

    def __len__(self) -> int:
        return int(self.t_s.size)


@dataclass(frozen=True)
class MuModel:
    """A reference's friction coefficient as a function of a window's facts.

    Attributes
    ----------
    degree : int
        Degree of the time polynomial (0: no trend; -1 never).
    direction : bool
        Whether the direction term is in.
    rate : bool
        Whether the stroke's rate term is in.
    t_lo, t_hi : float, s
        The OFF windows' span (the polynomial's domain).
    rate_mean : float
        Centre of the stroke-rate term.
    coef : ndarray
        The coefficients, in the order of :meth:`design`'s columns.
    unit : ndarray, shape (n_off, p)
        ``(X' W X)^-1 X' W`` transposed: how each OFF window's ratio moves the coefficients.
    resid : ndarray
        The OFF windows' residuals, HC2-scaled.
    cluster : ndarray of int
        The OFF windows' strokes.
    """

    degree: int
    direction: bool
    rate: bool
    t_lo: float
    t_hi: float
    rate_mean: float
    coef: FloatArray
    unit: FloatArray
    resid: FloatArray
    cluster: IntArray

    @property
    def trend(self) -> bool:
        """Whether the coefficient changes with time."""
        return self.degree > 0

    def design(self, facts: WindowFacts) -> FloatArray:
        """The model's columns for *facts* (constant, time polynomial, direction, rate)."""
        cols = [np.ones(len(facts))]
        if self.degree > 0:
            cols += list(_time_basis(facts.t_s, self.t_lo, self.t_hi, self.degree).T)
        if self.direction:
            cols.append(facts.direction.astype(np.float64))
        if self.rate:
            cols.append(np.where(np.isfinite(facts.rate), facts.rate - self.rate_mean, 0.0))
        return np.column_stack(cols)

    def at(self, facts: WindowFacts) -> FloatArray:
        """The coefficient at each window of *facts*."""
        return self.design(facts) @ self.coef

    def replicates(self, rng: np.random.Generator, n_boot: int) -> FloatArray:
        """Wild cluster bootstrap replicates of the coefficients, shape (n_boot, p)."""
        _, inverse = np.unique(self.cluster, return_inverse=True)
        signs = WEBB[rng.integers(0, WEBB.size, size=(n_boot, int(inverse.max()) + 1))]
        return self.coef + (signs[:, inverse] * self.resid) @ self.unit

    def change_per_s(self) -> float:
        """Mean rate of change of the coefficient over the OFF span (0 without trend)."""
        if not self.trend or self.t_hi <= self.t_lo:
            return 0.0
        ends = WindowFacts(np.array([self.t_lo, self.t_hi]), np.zeros(2), np.full(2, np.nan),
                           np.zeros(2, np.int64), np.zeros(2, np.int64))
        lo, hi = self.at(ends)
        return float((hi - lo) / (self.t_hi - self.t_lo))


def _time_basis(t: FloatArray, lo: float, hi: float, degree: int) -> FloatArray:
    """Legendre polynomials 1..degree of *t* scaled from [lo, hi] to [-1, 1], continued as
    straight lines (value and slope at the end) beyond it; columns per degree."""
    half = 0.5 * (hi - lo) if hi > lo else 1.0
    x = (np.asarray(t, dtype=np.float64) - 0.5 * (hi + lo)) / half
    x = np.where(np.isfinite(x), x, 0.0)
    edge = np.clip(x, -1.0, 1.0)
    out = []
    for k in range(1, degree + 1):
        c = np.zeros(k + 1)
        c[k] = 1.0
        slope = legendre.legval(edge, legendre.legder(c))
        out.append(legendre.legval(edge, c) + slope * (x - edge))
    return np.column_stack(out)


def _fit(X: FloatArray, ratio: FloatArray, weight: FloatArray
         ) -> tuple[FloatArray, FloatArray, FloatArray, float] | None:
    """Weighted least squares: coefficients, ``unit`` (see :class:`MuModel`), HC2-scaled
    residuals and the weighted residual sum of squares; None when singular."""
    sw = np.sqrt(weight)
    A = X * sw[:, None]
    try:
        q, r = np.linalg.qr(A)
        if np.min(np.abs(np.diag(r))) < 1e-10 * np.max(np.abs(np.diag(r))):
            return None
        coef = np.linalg.solve(r, q.T @ (ratio * sw))
        unit = np.linalg.solve(r, (q * sw[:, None]).T).T  # (n, p): d coef / d ratio_i
    except np.linalg.LinAlgError:
        return None
    resid = ratio - X @ coef
    lever = np.clip(np.sum(q * q, axis=1), 0.0, 0.999)
    rss = float(np.sum(weight * resid**2))
    return coef, unit, resid / np.sqrt(1.0 - lever), rss


def _aicc(rss: float, n: int, p: int) -> float:
    k = p + 1  # the coefficients and the variance
    if n - k - 1 <= 0:
        return np.inf
    return n * np.log(max(rss, 1e-300) / n) + 2 * k + 2 * k * (k + 1) / (n - k - 1)


def _offers(facts: WindowFacts, time_trend: bool) -> tuple[list[int], list[bool], list[bool]]:
    """The degrees, direction and rate terms the windows can support."""
    n = len(facts)
    t = facts.t_s
    degrees = [0]
    if time_trend and np.isfinite(t).all() and n >= 6:
        span = float(t.max() - t.min())
        top = min(MAX_DEGREE, int(span // SPAN_PER_DEGREE_S), n // 4)
        degrees = list(range(top + 1))
    d = facts.direction
    both = int(np.sum(d > 0)) >= 2 and int(np.sum(d < 0)) >= 2
    rates = facts.rate
    varied = bool(np.isfinite(rates).all() and n >= 6 and np.ptp(rates) > 0)
    return degrees, [both] if both else [False], [False, True] if varied else [False]


def fit_mu_model(normal_N: npt.ArrayLike, friction_N: npt.ArrayLike, facts: WindowFacts, *,
                 time_trend: bool) -> MuModel:
    """The friction coefficient of a reference's OFF windows as a model of their facts.

    Parameters
    ----------
    normal_N, friction_N : array_like of float, N
        Mean normal force and friction magnitude of each OFF window.
    facts : WindowFacts
        Their times, directions, strokes' rates and strokes.
    time_trend : bool
        Whether a trend in time may be fitted (the windows share one trial's clock).

    Returns
    -------
    MuModel
        The model of least AICc (the constant alone is the ratio of means).

    Raises
    ------
    AnalysisError
        No OFF windows, or a non-positive normal force.
    """
    fn = np.asarray(normal_N, dtype=np.float64)
    ft = np.asarray(friction_N, dtype=np.float64)
    if fn.size == 0:
        raise AnalysisError("no OFF windows to estimate the friction coefficient from")
    if not np.all(fn > 0):
        raise AnalysisError("an OFF window's normal force is not positive")
    ratio = ft / fn
    t = facts.t_s
    finite = t[np.isfinite(t)]
    lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 0.0)
    rates = facts.rate[np.isfinite(facts.rate)]
    rate_mean = float(np.average(rates)) if rates.size else 0.0
    best: tuple[float, MuModel] | None = None
    for degree, direction, rate in product(*_offers(facts, time_trend)):
        model = MuModel(degree, direction, rate, lo, hi, rate_mean, np.empty(0),
                        np.empty((0, 0)), np.empty(0), facts.cluster)
        X = model.design(facts)
        found = _fit(X, ratio, fn)
        if found is None:
            continue
        coef, unit, resid, rss = found
        score = _aicc(rss, fn.size, X.shape[1]) if fn.size > X.shape[1] + 2 else (
            np.inf if X.shape[1] > 1 else 0.0)
        if best is None or score < best[0]:
            best = (score, MuModel(degree, direction, rate, lo, hi, rate_mean, coef, unit,
                                   resid, facts.cluster))
    if best is None:
        raise AnalysisError("the OFF windows do not determine a friction coefficient")
    return best[1]


def stack_facts(parts: Sequence[WindowFacts]) -> WindowFacts:
    """Several sets of window facts as one, in order."""
    return WindowFacts(*(np.concatenate([getattr(p, f) for p in parts])
                         for f in ("t_s", "direction", "rate", "cluster", "stratum")))
