"""Fitting the nonlinear mixed model of :mod:`evtribo.population.nonlinear`, with checks that
cannot be fooled, and what is inferred from it.

:func:`fit_nonlinear` minimises the (restricted) deviance with each of :data:`OPTIMISERS`
from the same start, as lme4's ``allFit`` does, and keeps the lowest; the fit is checked
(:mod:`evtribo.population.convergence`: a finite deviance, a positive-definite Hessian, the
optimisers' agreement, a determined exponent), each failed check said.

Inference: the fixed effects' covariance is twice the inverse Hessian of the deviance at the
optimum (the linearised information underestimated the exponent's standard error by about a
tenth in our simulations), widened by what a cells' error scale phi below 1 took off; the 95 %
intervals use Student's t with Satterthwaite's degrees of freedom, from the linearised
covariance's gradient in the variance parameters and their covariance.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

# scipy.stats' distributions' functions are scipy.special's (the same numbers, without its import)
from scipy import optimize, special

from evtribo.population.convergence import (
    OPTIMISERS,
    Convergence,
    OptimiserRun,
    checks,
    determined,
    positive_definite,
    singular,
)
from evtribo.population.nonlinear import NonlinearData, _Objective, _Spec, _start, _unpack

log = logging.getLogger(__name__)

__all__ = ["OPTIMISERS", "Convergence", "Estimate", "NonlinearFit", "OptimiserRun",
           "fit_nonlinear"]

Array = NDArray[np.float64]

_Q95 = 0.975


@dataclass(frozen=True)
class Estimate:
    """A linear combination of the fixed effects: value, standard error, degrees of freedom.

    Attributes
    ----------
    value, se, df : float
    """

    value: float
    se: float
    df: float

    def interval(self) -> tuple[float, float]:
        """The 95 % interval, Student's t with :attr:`df` degrees of freedom.

        Returns
        -------
        (float, float)
        """
        half = float(special.stdtrit(self.df, _Q95)) * self.se
        return self.value - half, self.value + half


@dataclass(frozen=True)
class NonlinearFit:
    """The population's power law on the linear scale, fitted and checked.

    Attributes
    ----------
    subjects : tuple of str
    log_u0 : float
        The centre c of the log amplitudes (ln V).
    beta : ndarray
        ``(a, n)``: the population's log force (ln N) at ``exp(c)`` and its exponent.
    cov_beta : ndarray
        Their covariance: twice the inverse Hessian of the deviance at the optimum, widened
        by what a cells' error scale phi below 1 took off (phi at least 1).
    cov_re : ndarray, shape (2, 2)
        The between-subject covariance of ``(log k_i, n_i)`` (zero for the exponent
        without random slopes).
    phi : float
        The cells' error scale (1: as their intervals say).
    random_slopes : bool
    deviance : float
        The restricted deviance at the optimum.
    convergence : Convergence
    modes : ndarray, shape (k, 2)
        Each subject's own ``(log F at exp(c), n)`` (its conditional mode).
    method : str
        How it was estimated, for people.
    """

    subjects: tuple[str, ...]
    log_u0: float
    beta: Array
    cov_beta: Array
    cov_re: Array
    phi: float
    random_slopes: bool
    deviance: float
    convergence: Convergence
    modes: Array
    method: str
    _cov_lin: Array = field(repr=False, default_factory=lambda: np.full((2, 2), np.nan))
    _dcov: Array = field(repr=False, default_factory=lambda: np.zeros((0, 2, 2)))
    _dre: Array = field(repr=False, default_factory=lambda: np.zeros((0, 2, 2)))
    _theta_cov: Array | None = field(repr=False, default=None)

    @property
    def between_sd(self) -> Array:
        """Between-subject SDs of ``(log k, n)`` (n's NaN without random slopes)."""
        d = np.sqrt(np.clip(np.diag(self.cov_re), 0.0, None))
        return d if self.random_slopes else np.array([d[0], math.nan])

    def between_sd_of(self, c: ArrayLike) -> float:
        """Between-subject SD of ``c @ (a_i, n_i)`` (NaN when it involves the exponent and
        the model has no random slopes).

        Parameters
        ----------
        c : array_like, shape (2,)

        Returns
        -------
        float
        """
        cv = np.asarray(c, dtype=float)
        if not self.random_slopes and cv[1] != 0.0:
            return math.nan
        with np.errstate(invalid="ignore", over="ignore"):
            var = float(cv @ self.cov_re @ cv)
        return math.sqrt(var) if var >= 0 else math.nan if math.isnan(var) else 0.0

    def estimate(self, c: ArrayLike) -> Estimate:
        """``c @ beta`` with its standard error and Satterthwaite's degrees of freedom.

        Parameters
        ----------
        c : array_like, shape (2,)

        Returns
        -------
        Estimate
        """
        cv = np.asarray(c, dtype=float)
        with np.errstate(invalid="ignore", over="ignore"):  # a covariance not determined
            var = float(cv @ self.cov_beta @ cv)            # (infinite): NaN, said by the
            lin = float(cv @ self._cov_lin @ cv)            # fit's checks
        se = math.sqrt(var) if var >= 0 else math.nan if math.isnan(var) else 0.0
        return Estimate(float(cv @ self.beta), se, self._satterthwaite(cv, lin))

    def at(self, log_u: float) -> Estimate:
        """The population's log force (ln N) at one log amplitude (ln V).

        Parameters
        ----------
        log_u : float

        Returns
        -------
        Estimate
        """
        return self.estimate([1.0, log_u - self.log_u0])

    def _satterthwaite(self, c: Array, var: float) -> float:
        """2 var^2 / (g' A g): *var* the linearised variance of ``c @ beta``, g its gradient
        in the variance parameters, A their covariance."""
        fallback = float(max(len(self.subjects) - 1, 1))
        if self._theta_cov is None or self._dcov.size == 0:
            return fallback
        with np.errstate(invalid="ignore", over="ignore"):
            grad = np.einsum("i,tij,j->t", c, self._dcov, c)
            denom = float(grad @ self._theta_cov @ grad)
        if not (math.isfinite(denom) and denom > 0 and math.isfinite(var)):
            return fallback
        return float(min(max(2.0 * var * var / denom, 1.0), 1e6))

    def between_sd_interval(self, c: ArrayLike) -> tuple[float, float]:
        """The 95 % interval of :meth:`between_sd_of`: Satterthwaite's chi-square
        approximation for a variance, ``nu tau^2 / chi2(nu)`` with ``nu = 2 tau^4 /
        Var(tau^2)`` (NaN when it cannot be computed; ``(0, NaN)`` at zero).

        Parameters
        ----------
        c : array_like, shape (2,)

        Returns
        -------
        (float, float)
        """
        cv = np.asarray(c, dtype=float)
        tau2 = self.between_sd_of(cv) ** 2
        if not math.isfinite(tau2):
            return math.nan, math.nan
        if tau2 <= 1e-12:
            return 0.0, math.nan
        if self._theta_cov is None or self._dre.size == 0:
            return math.nan, math.nan
        with np.errstate(invalid="ignore", over="ignore"):
            grad = np.einsum("i,tij,j->t", cv, self._dre, cv)
            var = float(grad @ self._theta_cov @ grad)
        if not (math.isfinite(var) and var > 0):
            return math.nan, math.nan
        nu = 2.0 * tau2 * tau2 / var
        q_hi = 2.0 * float(special.gammaincinv(nu / 2.0, _Q95))  # chi2.ppf
        q_lo = 2.0 * float(special.gammaincinv(nu / 2.0, 1.0 - _Q95))
        lo = nu * tau2 / q_hi if q_hi > 0 else 0.0
        hi = nu * tau2 / q_lo if q_lo > 0 else math.inf  # next to no degrees of freedom
        return math.sqrt(lo), math.sqrt(hi)

    def prediction_interval(self, c: ArrayLike) -> tuple[float, float]:
        """The 95 % interval of a new subject's ``c @ (a_i, n_i)``: Student's t with k - 2
        degrees of freedom (Higgins, Thompson and Spiegelhalter 2009) on the between-subject
        variance plus the estimate's.

        Parameters
        ----------
        c : array_like, shape (2,)

        Returns
        -------
        (float, float)
        """
        cv = np.asarray(c, dtype=float)
        tau = self.between_sd_of(cv)
        est = self.estimate(cv)
        if not math.isfinite(tau) or len(self.subjects) < 3:
            return math.nan, math.nan
        half = float(special.stdtrit(len(self.subjects) - 2, _Q95)) * math.sqrt(
            tau * tau + est.se * est.se)
        return est.value - half, est.value + half


def _minimise(objective: _Objective, p0: Array, method: str
              ) -> tuple[OptimiserRun, Array] | None:
    """One optimiser's run from *p0* (the random effects' modes started afresh)."""
    objective.v = np.zeros_like(objective.v)
    # the modes to 1e-10 where finite differences give the gradient, else to 1e-7 (a
    # deviance error of about 1e-14 for a simplex or a line search)
    objective.tol = 1e-10 if method == "L-BFGS-B" else 1e-7
    n = p0.size
    options: dict[str, object] = {"maxiter": 4000}
    bounds: list[tuple[float | None, float | None]] | None = None
    if method == "Nelder-Mead":  # a first simplex a tenth wide in every parameter
        options.update(xatol=1e-3, fatol=1e-4, adaptive=n > 4, maxfev=4000,
                       initial_simplex=p0 + np.vstack([np.zeros(n), 0.1 * np.eye(n)]))
    elif method == "Powell":
        options.update(xtol=1e-3, ftol=1e-6, direc=0.1 * np.eye(n))
    elif method == "L-BFGS-B":
        options.update(eps=1e-6)
        bounds = [(None, None)] * n
        if objective.spec.fit_phi:
            bounds[-1] = (-10.0, 10.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            res = optimize.minimize(objective, p0, method=method, bounds=bounds,
                                    options=options)
            if method == "Nelder-Mead":  # once more from its end: a simplex that
                # collapsed early is built afresh (as is usual with Nelder and Mead's method)
                options["initial_simplex"] = res.x + np.vstack([np.zeros(n), 0.02 * np.eye(n)])
                res = optimize.minimize(objective, res.x, method=method, options=options)
        except (ValueError, np.linalg.LinAlgError, FloatingPointError) as err:
            log.info("population: %s failed: %s", method, err)
            return None
    x = _canonical(np.asarray(res.x, dtype=float), objective.spec)
    objective.tol = 1e-10
    dev = float(objective(x))
    if not math.isfinite(dev) or dev >= 1e299:
        return None
    return OptimiserRun(method, dev, (float(x[0]), float(x[1])), bool(res.success)), x


def _canonical(p: Array, spec: _Spec) -> Array:
    """The loadings' columns signed so that their diagonal is not negative (the deviance
    is the same)."""
    p = p.copy()
    if p[2] < 0:
        p[2] = -p[2]
        if spec.q == 2:
            p[3] = -p[3]
    if spec.q == 2 and p[4] < 0:
        p[4] = -p[4]
    return p


def _fit_phi(data: NonlinearData, q: int) -> bool:
    """Whether the cells' error scale can be estimated: at least as many cells beyond each
    subject's own random effects as there are subjects."""
    return int(np.sum(np.clip(data.n_cells - q, 0, None))) >= max(data.k, 5)


def _loadings_derivative(p: Array, spec: _Spec) -> Array:
    """d G / d theta (theta: the loadings, then log phi), shape (len(theta), 2, 2)."""
    _, load, _ = _unpack(p, spec)
    out = []
    n_load = spec.q * (spec.q + 1) // 2
    for t in range(n_load + int(spec.fit_phi)):
        d = np.zeros((2, spec.q))
        if t < n_load:
            pos = [(0, 0), (1, 0), (1, 1)][t] if spec.q == 2 else (0, 0)
            d[pos] = 1.0
        out.append(d @ load.T + load @ d.T)
    return np.array(out)


def _hessian(objective: _Objective, p: Array) -> Array:
    from statsmodels.tools.numdiff import approx_hess3

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return np.asarray(approx_hess3(p, objective, epsilon=1e-4), dtype=float)


def _cov_linear(objective: _Objective, p: Array, *, floor: bool = False) -> Array:
    """The fixed effects' covariance linearised at the modes, at *p* (phi at least 1 with
    *floor*)."""
    q = p.copy()
    if floor and objective.spec.fit_phi:
        q[-1] = max(q[-1], 0.0)
    info = objective.pieces(q)[3]
    return np.asarray(np.linalg.inv(info), dtype=float)


def _cov_derivative(objective: _Objective, p: Array) -> Array:
    """d cov_beta / d theta, central differences (beta held)."""
    out = []
    for t in range(2, p.size):
        step = np.zeros_like(p)
        step[t] = 1e-4
        out.append((_cov_linear(objective, p + step) - _cov_linear(objective, p - step))
                   / 2e-4)
    return np.array(out)


def _covariances(objective: _Objective, p: Array, hess: Array, cov_lin: Array
                 ) -> tuple[Array, Array | None, Array]:
    """The fixed effects' covariance (twice the inverse Hessian; the linearised one where
    the Hessian has none), the variance parameters' and d cov_lin / d theta."""
    if not np.all(np.isfinite(hess)):
        return cov_lin, None, np.zeros((0, 2, 2))
    full = np.asarray(2.0 * np.linalg.pinv(hess, hermitian=True), dtype=float)
    cov = full[:2, :2]
    if not (np.all(np.isfinite(cov)) and positive_definite(cov)):
        cov = cov_lin
    return cov, full[2:, 2:], _cov_derivative(objective, p)


def fit_nonlinear(data: NonlinearData, *, random_slopes: bool = True,
                  optimisers: Sequence[str] = OPTIMISERS, reml: bool = True,
                  nodes: int = 1) -> NonlinearFit:
    """Fit the population's power law on the linear scale (see the module's notes).

    Parameters
    ----------
    data : NonlinearData
        The subjects' cells (:func:`~evtribo.population.nonlinear.nonlinear_data`).
    random_slopes : bool
        Subjects' own exponents (random slopes) besides their own levels.
    optimisers : sequence of str
        scipy's methods, run in turn from the same start; the first is the primary.
    reml : bool
        The approximate restricted likelihood (else maximum likelihood).
    nodes : int
        Gauss-Hermite nodes per random effect (1: the Laplace approximation).

    Returns
    -------
    NonlinearFit

    Raises
    ------
    numpy.linalg.LinAlgError
        When no optimiser reaches a finite deviance.
    """
    q = 2 if random_slopes else 1
    spec = _Spec(q, _fit_phi(data, q), reml, nodes)
    objective = _Objective(data, spec)
    p0 = _start(data, spec)
    found = [r for r in (_minimise(objective, p0, m) for m in optimisers) if r is not None]
    if not found:
        raise np.linalg.LinAlgError("no optimiser reached a finite deviance")
    best, p = min(found, key=lambda r: r[0].deviance)
    objective.v = np.zeros_like(objective.v)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        dev, v, *_ = objective.pieces(p)
        beta, load, phi = _unpack(p, spec)
        cov_re = np.zeros((2, 2))
        cov_re[:q, :q] = (load @ load.T)[:q, :q]
        try:
            cov_lin = _cov_linear(objective, p)
            # what phi below 1 took off (none at 1 or more): added back
            widen = (_cov_linear(objective, p, floor=True) - cov_lin if phi < 1.0
                     else np.zeros((2, 2)))
        except np.linalg.LinAlgError:
            cov_lin = widen = np.full((2, 2), np.nan)
        hess = _hessian(objective, p)
        cov_beta, theta_cov, dcov = _covariances(objective, p, hess, cov_lin)
        convergence = checks(dev, hess, [r for r, _ in found], best, cov_beta=cov_beta,
                              singular=singular(cov_re, q))
        cov_beta = cov_beta + widen
    modes = beta[None, :] + v @ load.T
    fit = NonlinearFit(data.subjects, data.log_u0, beta.copy(), cov_beta, cov_re, phi,
                       q == 2, dev, convergence, modes, "", cov_lin, dcov,
                       _loadings_derivative(p, spec), theta_cov)
    n = fit.estimate([0.0, 1.0])
    convergence = determined(convergence, n.value, *n.interval(), n.df)
    random = "intercept and exponent" if q == 2 else "intercept"
    method = (f"nonlinear mixed model on the linear scale ({'REML' if reml else 'ML'}, "
              f"{'Laplace' if nodes <= 1 else f'adaptive Gauss-Hermite, {nodes} nodes'}; "
              f"random {random} by subject; each cell's own error; Satterthwaite t)")
    log.info("population: %s: n = %.3f, deviance %.2f, %s", method, beta[1], dev,
             convergence.summary())
    return dataclasses.replace(fit, convergence=convergence, method=method)
