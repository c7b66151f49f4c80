"""The friction an ON window is compared with: its reference's coefficient at the window's own
time, direction and stroke pace (``docs/analysis.md``).

A fingertip's friction coefficient is not one number: it rises as the skin moistens, it
differs between forward and backward strokes, it depends on the sliding speed. Since the
inferred force ``F_t,on / mu - F_n,on`` moves by about ``(F_n + F_el)`` times any relative
error of ``mu``, a 1 % error in ``mu`` is 5 mN at 0.5 N: at low voltages, more than the
force itself.

A reference's OFF windows are described by a linear model of their friction coefficient,
fitted by weighted least squares (weights ``F_n``)::

    F_t,i / F_n,i = b0 + sum_k b_k P_k(x_i) + c d_i + error          (fit_mu_model)

with ``P_k`` Legendre polynomials of the window's time scaled to the span (straight lines
beyond it) and ``d`` the sliding direction; the constant alone is the ratio of means
``sum F_t / sum F_n``. An alternating trial's trend is fitted to its OFF and ON windows
together, in ``log(F_t/F_n)`` with one term per ON group (:func:`fit_trial_model`). The
terms are chosen by the corrected Akaike criterion (AICc); a stroke rate's fixed slope and
the friction law's factor of the load (the subject's,
:func:`~evtribo.analysis.friction.laws.fit.fit_subject_law`) multiply the coefficient. Each
ON window is compared with the model at its own time, direction, stroke rate and normal
force: each treatment phase against the baseline that brackets it, as in ABAB designs and
interrupted time series with a trend (Huitema & McKean 2000).

Uncertainty: a model keeps its residuals, CR2-scaled per stroke, and how each fitted window
moves its coefficients; the wild cluster bootstrap of
:class:`~evtribo.analysis.friction.bootstrap.References` (Cameron, Gelbach & Miller 2008)
draws a standard normal weight per stroke, adds the weighted residuals back to the fitted
values, and :meth:`MuModel.replicates_given` refits every candidate model to each replicate's
data, the design fixed, each replicate choosing its model again by AICc.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from itertools import product
from typing import Any

import numpy as np
import numpy.typing as npt

from evtribo.analysis.friction.window_facts import (
    MAX_DEGREE,
    SPAN_PER_DEGREE_S,
    WindowFacts,
    cr2_residuals,
    stack_facts,
    time_basis,
)
from evtribo.errors import AnalysisError
from evtribo.model.friction_law import AMONTONS, LoadLaw

__all__ = ["MATTERS_SE", "MuModel", "fit_mu_model", "fit_trial_model"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: A model's description names a term whose effect stands this many standard errors out.
MATTERS_SE = 3.0


@dataclass(frozen=True)
class _Fit:
    """What a model was fitted to: its design (with any group columns), response, weights,
    fitted values and AICc."""

    X: FloatArray
    y: FloatArray
    weight: FloatArray
    fitted: FloatArray
    aicc: float


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
        Whether the stroke's rate term (its fixed :attr:`rate_slope`) is in.
    t_lo, t_hi : float, s
        The OFF windows' span (the polynomial's domain).
    rate_mean : float
        Centre of the stroke-rate term.
    coef : ndarray
        The coefficients, in the order of :meth:`design`'s columns.
    unit : ndarray, shape (n_off, p)
        ``(X' W X)^-1 X' W`` transposed: how each OFF window's ratio moves the coefficients.
    resid : ndarray
        The fitted windows' residuals, CR2-scaled (per stroke).
    cluster : ndarray of int
        The fitted windows' strokes.
    log : bool
        A model of ``log(F_t / F_n)`` of a trial's OFF and ON windows together
        (:func:`fit_trial_model`); else of ``F_t / F_n`` over the OFF windows.
    smear : float
        Duan's smearing factor of the log model (the weighted mean of ``exp(residual)``),
        so that ``exp`` of the fit is the mean ratio, not the median.
    fit : _Fit or None
        The design, response and weights it was fitted to, and its AICc.
    rivals : tuple of MuModel
        The other candidates fitted to the same windows (each replicate chooses again).
    law : LoadLaw
        The friction law ``F_t ~ W**m`` (the subject's, :mod:`evtribo.analysis.friction.laws`;
        ``m = 1``: Amontons): the model's coefficient is the one at the law's load ``W_0``,
        and a window's is :meth:`mu_at`.
    log_load_mean : float
        The fitted OFF windows' mean of ``log(F_n / W_0)`` (weighted as the fit): where the
        coefficient is known best, whatever ``m``.
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
    log: bool = False
    smear: float = 1.0
    rate_slope: float = 0.0
    fit: _Fit | None = None
    rivals: tuple[MuModel, ...] = ()
    law: LoadLaw = AMONTONS
    log_load_mean: float = 0.0

    @property
    def trend(self) -> bool:
        """Whether the coefficient changes with time."""
        return self.degree > 0

    def design(self, facts: WindowFacts) -> FloatArray:
        """The model's columns for *facts* (constant, time polynomial, direction, rate)."""
        cols = [np.ones(len(facts))]
        if self.degree > 0:
            cols += list(time_basis(facts.t_s, self.t_lo, self.t_hi, self.degree).T)
        if self.direction:
            cols.append(facts.direction.astype(np.float64))
        return np.column_stack(cols)

    def rate_factor(self, facts: WindowFacts) -> FloatArray:
        """The stroke rate's factor on the coefficient at each window (1 without it)."""
        if not self.rate:
            return np.ones(len(facts))
        return np.exp(self.rate_slope * _centred(facts.rate, self.rate_mean))

    def load_factor(self, normal_N: npt.ArrayLike) -> FloatArray:
        """``(F_n / W_0)**(m - 1)`` at each normal force (ones for Amontons)."""
        return self.law.coefficient_factor(normal_N)

    def mu_at(self, facts: WindowFacts, normal_N: npt.ArrayLike) -> FloatArray:
        """The coefficient ``F_t / F_n`` without the voltage at each window of *facts*,
        at its normal force *normal_N* (N)."""
        return self.at(facts) * self.load_factor(normal_N)

    def at(self, facts: WindowFacts) -> FloatArray:
        """The coefficient at each window of *facts* (at the law's load ``W_0``)."""
        return self.at_replicates(facts, self.coef[None, :])[0]

    def at_replicates(self, facts: WindowFacts, coef: FloatArray) -> FloatArray:
        """The coefficient at each window of *facts* for each row of *coef* (replicates of
        :attr:`coef`), shape (rows, windows)."""
        X = self.design(facts)
        value = coef[:, :X.shape[1]] @ X.T
        base = self.smear * np.exp(value) if self.log else value
        return base * self.rate_factor(facts)

    def replicates_given(self, facts: WindowFacts, noise: FloatArray) -> FloatArray:
        """Bootstrap replicates of the coefficient at each window of *facts*, shape
        (n_boot, windows): the fitted values plus *noise* (the wild bootstrap's residuals
        times each replicate's weights, shape (n_boot, fitted windows)) fitted by every
        candidate model, each replicate taking the candidate its data give the least
        AICc."""
        n_boot = noise.shape[0]
        if not self.rivals or self.fit is None:
            return self.at_replicates(facts, self.coef + noise @ self.unit)
        data = self.fit.fitted + noise  # (n_boot, n)
        best_score = np.full(n_boot, np.inf)
        out = np.empty((n_boot, len(facts)))
        for model in (self, *self.rivals):
            assert model.fit is not None
            coef = data @ model.unit
            resid = data - coef @ model.fit.X.T
            score = _aicc(np.sum(model.fit.weight * resid**2, axis=1), resid.shape[1],
                          model.fit.X.shape[1])
            better = score < best_score
            if better.any():
                out[better] = model.at_replicates(facts, coef[better])
                best_score[better] = score[better]
        return out

    def change_per_s(self) -> float:
        """Mean rate of change of the coefficient over the OFF span (0 without trend)."""
        if not self.trend or self.t_hi <= self.t_lo:
            return 0.0
        ends = WindowFacts(np.array([self.t_lo, self.t_hi]), np.zeros(2), np.full(2, np.nan),
                           np.zeros(2, np.int64), np.zeros(2, np.int64))
        lo, hi = self.at(ends)
        return float((hi - lo) / (self.t_hi - self.t_lo))

    def change_se(self) -> float:
        """Standard error of :meth:`change_per_s`: the coefficients' covariance robust to
        the strokes (CR2, from the scaled residuals), through the change (0 without trend).
        """
        if not self.trend or self.t_hi <= self.t_lo or self.unit.size == 0:
            return 0.0
        ends = WindowFacts(np.array([self.t_lo, self.t_hi]), np.zeros(2), np.full(2, np.nan),
                           np.zeros(2, np.int64), np.zeros(2, np.int64))
        X = self.design(ends)
        jac = X * (self.at(ends) if self.log else self.rate_factor(ends))[:, None]
        grad = (jac[1] - jac[0]) / (self.t_hi - self.t_lo)
        share = (self.unit[:, :X.shape[1]] @ grad) * self.resid
        _, which = np.unique(self.cluster, return_inverse=True)
        return float(np.sqrt(np.sum(np.bincount(which, weights=share) ** 2)))

    def describe(self) -> str:
        """The terms that matter (``"constant"``, ``"time^2 + direction"``): AICc keeps a
        term whose fit is better by a little (about 1 in 6 of the terms of no effect, more
        with few windows), and the bootstrap carries that choice; a description names a
        term only where its effect stands :data:`MATTERS_SE` standard errors from zero
        (the drift over the span, the difference between the directions)."""
        terms = []
        if self.degree and abs(self.change_per_s()) > MATTERS_SE * self.change_se():
            terms.append(f"time^{self.degree}" if self.degree > 1 else "time")
        if self.direction and abs(self.coef[1 + self.degree]) > MATTERS_SE * self.coef_se(
                1 + self.degree):
            terms.append("direction")
        if self.rate:
            terms.append("stroke rate")
        return " + ".join(terms) or "constant"

    def coef_se(self, k: int) -> float:
        """Standard error of coefficient *k*, robust to the strokes (CR2)."""
        if self.unit.size == 0:
            return float("inf")
        _, which = np.unique(self.cluster, return_inverse=True)
        return float(np.sqrt(np.sum(np.bincount(which, weights=self.unit[:, k] * self.resid)
                                    ** 2)))


def _fit(X: FloatArray, ratio: FloatArray, weight: FloatArray, cluster: IntArray
         ) -> tuple[FloatArray, FloatArray, FloatArray, float] | None:
    """Weighted least squares: coefficients, ``unit`` (see :class:`MuModel`), CR2-scaled
    residuals (per stroke, :func:`~evtribo.analysis.friction.window_facts.cr2_residuals`) and the
    weighted residual sum of squares; None when singular."""
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
    rss = float(np.sum(weight * resid**2))
    return coef, unit, cr2_residuals(q, resid, weight, cluster), rss


def _aicc(rss: float | FloatArray, n: int, p: int) -> FloatArray:
    """AICc of a least-squares fit of *p* coefficients to *n* values (and the variance)."""
    k = p + 1
    if n - k - 1 <= 0:
        return np.full(np.shape(rss), np.inf)
    return np.asarray(n * np.log(np.maximum(rss, 1e-300) / n) + 2 * k
                      + 2 * k * (k + 1) / (n - k - 1))


def _offers(facts: WindowFacts, time_trend: bool) -> tuple[list[int], list[bool]]:
    """The degrees and direction terms the windows can support."""
    n = len(facts)
    t = facts.t_s
    degrees = [0]
    if time_trend and np.isfinite(t).all() and n >= 6:
        span = float(t.max() - t.min())
        top = min(MAX_DEGREE, int(span // SPAN_PER_DEGREE_S), n // 4)
        degrees = list(range(top + 1))
    d = facts.direction
    both = int(np.sum(d > 0)) >= 2 and int(np.sum(d < 0)) >= 2
    return degrees, [False, True] if both else [False]


def fit_mu_model(normal_N: npt.ArrayLike, friction_N: npt.ArrayLike, facts: WindowFacts, *,
                 time_trend: bool, rate_slope: float = 0.0, law: LoadLaw = AMONTONS
                 ) -> MuModel:
    """The friction coefficient of a reference's OFF windows as a model of their facts.

    Parameters
    ----------
    normal_N, friction_N : array_like of float, N
        Mean normal force and friction magnitude of each OFF window.
    facts : WindowFacts
        Their times, directions, strokes' rates and strokes.
    time_trend : bool
        Whether a trend in time may be fitted (the windows share one trial's clock).
    rate_slope : float
        The coefficient's change per unit of log stroke rate, relative (the subject's,
        :func:`~evtribo.analysis.friction.laws.fit.fit_subject_law`; 0: none).
    law : LoadLaw
        The friction law (the subject's; its ``m`` 1: Amontons): the model's coefficient
        is ``F_t / F_n`` at its load ``W_0``.

    Returns
    -------
    MuModel
        The model of least AICc (the constant alone is the ratio of means of the frictions
        taken to the windows' mean stroke rate).

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
    shape = _Shape.of(facts, rate_slope, law, fn)
    load = shape.law.coefficient_factor(fn)
    ratio = ft / fn / shape.rate_factor(facts) / load
    candidates = []
    for degree, direction in product(*_offers(facts, time_trend)):
        template = shape.model(degree, direction, facts.cluster, log=False)
        fitted = _fitted(template, template.design(facts), ratio, fn * load)
        if fitted is not None:
            candidates.append(fitted)
    if not candidates:
        raise AnalysisError("the OFF windows do not determine a friction coefficient")
    return _choose(candidates)


@dataclass(frozen=True)
class _Shape:
    """What every candidate model of a set of windows shares: the time span, the stroke
    rates' centre and the rate's slope, the friction law."""

    t_lo: float
    t_hi: float
    rate_mean: float
    rate_slope: float
    law: LoadLaw = AMONTONS
    log_load_mean: float = 0.0

    @classmethod
    def of(cls, facts: WindowFacts, rate_slope: float, law: LoadLaw = AMONTONS,
           normal_N: FloatArray | None = None) -> _Shape:
        t = facts.t_s[np.isfinite(facts.t_s)]
        rates = facts.rate[np.isfinite(facts.rate)]
        mean = 0.0
        if normal_N is not None and normal_N.size and np.all(normal_N > 0):
            mean = float(np.average(np.log(normal_N / law.load_ref_N), weights=normal_N))
        return cls(float(t.min()) if t.size else 0.0, float(t.max()) if t.size else 0.0,
                   float(rates.mean()) if rates.size else 0.0,
                   rate_slope if rates.size else 0.0, law, mean)

    def rate_factor(self, facts: WindowFacts) -> FloatArray:
        return np.exp(self.rate_slope * _centred(facts.rate, self.rate_mean))

    def model(self, degree: int, direction: bool, cluster: IntArray, *, log: bool
              ) -> MuModel:
        return MuModel(degree, direction, self.rate_slope != 0, self.t_lo, self.t_hi,
                       self.rate_mean, np.empty(0), np.empty((0, 0)), np.empty(0), cluster,
                       log=log, rate_slope=self.rate_slope, law=self.law,
                       log_load_mean=self.log_load_mean)


def _centred(rate: FloatArray, mean: float) -> FloatArray:
    """Stroke rates less their centre (0 where unknown)."""
    return np.where(np.isfinite(rate), rate - mean, 0.0)


def _fitted(template: MuModel, X: FloatArray, y: FloatArray, weight: FloatArray
            ) -> MuModel | None:
    """*template* fitted to ``(X, y)`` by weighted least squares; None when singular or
    when the windows are too few to score it (the constant alone is always scored)."""
    found = _fit(X, y, weight, template.cluster)
    if found is None or (y.size <= X.shape[1] + 2 and X.shape[1] > 1):
        return None
    coef, unit, resid, rss = found
    score = float(_aicc(rss, y.size, X.shape[1])) if y.size > X.shape[1] + 2 else 0.0
    fitted = X @ coef
    smear = float(np.average(np.exp(y - fitted), weights=weight)) if template.log else 1.0
    return dataclasses.replace(template, coef=coef, unit=unit, resid=resid, smear=smear,
                               fit=_Fit(X, y, weight, fitted, score))


def _choose(candidates: list[MuModel]) -> MuModel:
    """The candidate of least AICc, with the others as its rivals."""
    scores = [m.fit.aicc if m.fit is not None else np.inf for m in candidates]
    k = int(np.argmin(scores))
    return dataclasses.replace(candidates[k],
                               rivals=tuple(candidates[:k] + candidates[k + 1:]))


def fit_trial_model(off: tuple[npt.ArrayLike, npt.ArrayLike, WindowFacts],
                    on: tuple[npt.ArrayLike, npt.ArrayLike, WindowFacts, npt.ArrayLike], *,
                    rate_slope: float = 0.0, law: LoadLaw = AMONTONS) -> MuModel:
    """A trial's friction coefficient in time, from its OFF and its ON windows together.

    ``log(F_t / F_n) = b0 + sum_k b_k P_k(x) + c d + sum_g a_g [window in ON group g]``
    (plus the stroke rate's fixed term) by weighted least squares (weights ``F_n``), the
    terms chosen by AICc: the ON windows tell the trend's shape and the direction's term as
    well as the OFF ones (the voltage multiplies the friction by about ``1 + F_el / F_n``,
    the same all through the trial), so the trend is known at every ON window, not
    extrapolated from the OFF windows around it. When the constant alone is chosen, the OFF
    windows' ratio of means (:func:`fit_mu_model`) is used.

    Parameters
    ----------
    off : (normal_N, friction_N, facts)
        The trial's OFF windows.
    on : (normal_N, friction_N, facts, group)
        Its ON windows and each one's group (an amplitude, say).
    rate_slope : float
        As :func:`fit_mu_model`'s.
    law : LoadLaw
        As :func:`fit_mu_model`'s.

    Returns
    -------
    MuModel
        Its coefficient is that of the OFF windows (the ON groups' terms left out).
    """
    fn_off, ft_off = (np.asarray(a, dtype=np.float64) for a in off[:2])
    fn_on, ft_on = (np.asarray(a, dtype=np.float64) for a in on[:2])
    group = np.asarray(on[3])
    facts = stack_facts([off[2], on[2]])
    fn, ft = np.concatenate([fn_off, fn_on]), np.concatenate([ft_off, ft_on])
    flat = fit_mu_model(fn_off, ft_off, off[2], time_trend=False, rate_slope=0.0, law=law)
    if not (np.all(fn > 0) and np.all(ft > 0)):
        return flat
    shape = _Shape.of(facts, rate_slope, law, fn_off)
    ons = _on_terms(fn_off.size, fn_on, group)
    y = (np.log(ft / fn) - shape.rate_slope * _centred(facts.rate, shape.rate_mean)
         - np.log(shape.law.coefficient_factor(fn)))
    candidates = []
    for degree, direction in product(*_offers(facts, True)):
        template = shape.model(degree, direction, facts.cluster, log=True)
        fitted = _fitted(template, np.column_stack([template.design(facts), ons]), y, fn)
        if fitted is not None and fn.size > fitted.coef.size + 2:
            candidates.append(fitted)
    if not candidates:
        return flat
    best = _choose(candidates)
    if best.degree == 0 and not best.direction:
        return fit_mu_model(fn_off, ft_off, off[2], time_trend=False, rate_slope=rate_slope,
                            law=law)
    return best


def _on_terms(n_off: int, fn_on: FloatArray, group: npt.NDArray[Any]) -> FloatArray:
    """The ON groups' columns of a trial's joint model: each group's level and, with 4
    windows or more, its change with the window's log normal force (the voltage's factor
    ``1 + F_el/F_n`` is smaller where the finger presses harder, ``F_el`` growing as the
    contact area does, slower than the load), so that a person's wandering force is not
    taken for a trend of the friction."""
    cols = []
    for g in np.unique(group):
        member = (group == g).astype(np.float64)
        cols.append(member)
        if member.sum() >= 4:
            log_fn = np.log(fn_on)
            cols.append(member * (log_fn - log_fn[member > 0].mean()))
    return np.concatenate([np.zeros((n_off, len(cols))), np.column_stack(cols)])
