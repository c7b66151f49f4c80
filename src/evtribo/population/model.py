"""The power law across subjects: ``log F = a + n log U``, subjects as random effects.

Each subject's cells (its electrostatic forces at several amplitudes) are measured, not
exact: their errors have a known covariance ``C_i`` (each cell's interval as its standard
error, correlated as the subject's bootstrap replicates are). The model is fitted by REML
with statsmodels' :class:`~statsmodels.regression.mixed_linear_model.MixedLM`, random
intercepts, and random slopes (the subjects' own exponents) when at least three subjects
have three or more amplitudes.

MixedLM has no known per-observation variance, so each subject's cells are first whitened
by the Cholesky factor of ``C_i``: the model becomes ``V_i = phi C_i + Z_i G Z_i'`` with
``phi``, MixedLM's residual scale, estimated. ``phi = 1`` when the intervals are right;
``phi > 1`` widens the intervals when the subjects' points scatter about their lines more
than their intervals allow (a power law that does not quite hold); ``phi < 1`` is not
allowed to narrow them (the fixed effects' covariance is taken at ``max(phi, 1)``, as
fit.py never shrinks an interval below what the points' errors give).

The intervals of the fixed effects use Student's t with Satterthwaite's degrees of freedom
(as R's lmerTest does; statsmodels has none for MixedLM), from the numerical Hessian of the
REML deviance at MixedLM's estimate: about k - 1 when the subjects' spread dominates, more
when the measurements' errors do.
"""
from __future__ import annotations

import logging
import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import stats

from evtribo.population.stats import MIN_SUBJECTS

log = logging.getLogger(__name__)

__all__ = ["Estimate", "PowerLawFit", "SubjectCells", "fit_power_law"]

_Q95 = 0.975


@dataclass(frozen=True)
class SubjectCells:
    """One subject's cells in one condition: log amplitudes, log forces and their errors.

    Attributes
    ----------
    subject : str
    log_u : ndarray
        Natural log of each amplitude, V.
    log_f : ndarray
        Natural log of each electrostatic force, N.
    cov : ndarray
        The known covariance of the errors of *log_f*.
    """

    subject: str
    log_u: NDArray[np.float64]
    log_f: NDArray[np.float64]
    cov: NDArray[np.float64]

    def own_fit(self, log_u0: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The subject's own weighted line ``(log F at log_u0, slope)`` and its covariance.

        Parameters
        ----------
        log_u0 : float
            Where the intercept is taken.

        Returns
        -------
        (ndarray, ndarray)
            Shape (2,) and (2, 2); needs two amplitudes or more.
        """
        x = _design(self.log_u - log_u0)
        w = np.linalg.solve(self.cov, x)
        info = x.T @ w
        cov = np.linalg.inv(info)
        return cov @ (w.T @ self.log_f), cov


def _design(x: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.column_stack([np.ones_like(x), x])


@dataclass(frozen=True)
class _Group:
    """One subject's whitened cells: response, fixed and random designs."""

    y: NDArray[np.float64]
    x: NDArray[np.float64]
    z: NDArray[np.float64]


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
        """The 95 % interval, Student's t with :attr:`df` degrees of freedom."""
        half = float(stats.t.ppf(_Q95, self.df)) * self.se
        return self.value - half, self.value + half


@dataclass(frozen=True)
class PowerLawFit:
    """The population's power law ``log F = a + n (log U - log_u0)``, fitted by REML.

    Attributes
    ----------
    beta : ndarray
        ``(a, n)``: the population's log force at ``log_u0`` and its exponent.
    log_u0 : float
        The centre of the log amplitudes.
    cov_re : ndarray
        The between-subject covariance of ``(a, n)`` (1 x 1 without random slopes).
    scale : float
        MixedLM's residual scale phi (1 when the cells' intervals are right).
    random_slopes : bool
        Whether the subjects have their own exponents in the model.
    subjects : tuple of str
        The subjects fitted.
    method : str
        How it was estimated, for people.
    """

    beta: NDArray[np.float64]
    log_u0: float
    cov_re: NDArray[np.float64]
    scale: float
    random_slopes: bool
    subjects: tuple[str, ...]
    method: str
    _batches: tuple[tuple[NDArray[np.float64], ...], ...] = field(repr=False, default=())
    _theta: NDArray[np.float64] = field(repr=False, default_factory=lambda: np.zeros(0))
    _theta_cov: NDArray[np.float64] | None = field(repr=False, default=None)

    @property
    def between_sd(self) -> NDArray[np.float64]:
        """Between-subject standard deviations of ``(a, n)`` (n's is NaN without random
        slopes: the subjects' exponents then differ only through phi, not estimated)."""
        d = np.sqrt(np.clip(np.diag(self.cov_re), 0.0, None))
        return d if d.size == 2 else np.array([d[0], math.nan])

    def between_sd_of(self, c: ArrayLike) -> float:
        """Between-subject standard deviation of ``c @ (a_i, n_i)`` (NaN when it involves
        the exponent and the model has no random slopes)."""
        cv = np.asarray(c, dtype=float)
        if not self.random_slopes and cv[1] != 0.0:
            return math.nan
        cv = cv[: self.cov_re.shape[0]]
        return float(math.sqrt(max(float(cv @ self.cov_re @ cv), 0.0)))

    def estimate(self, c: ArrayLike) -> Estimate:
        """``c @ beta`` with its standard error (phi at least 1) and Satterthwaite's
        degrees of freedom.

        Parameters
        ----------
        c : array_like, shape (2,)

        Returns
        -------
        Estimate
        """
        cv = np.asarray(c, dtype=float)
        var = float(cv @ _fe_cov(self._batches, self._theta, floor=True) @ cv)
        df = _satterthwaite(self._batches, self._theta, cv, self._theta_cov,
                            fallback=float(len(self.subjects) - 1))
        return Estimate(float(cv @ self.beta), math.sqrt(max(var, 0.0)), df)

    def at(self, log_u: float) -> Estimate:
        """The population's log force at one log amplitude."""
        return self.estimate([1.0, log_u - self.log_u0])


def _theta_matrices(theta: NDArray[np.float64], q: int) -> tuple[float, NDArray[np.float64]]:
    """phi and G from the parameters ``(sqrt phi, Cholesky factor of G by rows)``."""
    low = np.zeros((q, q))
    low[np.tril_indices(q)] = theta[1:]
    return float(theta[0]) ** 2, low @ low.T


def _batches(groups: Sequence[_Group]) -> list[tuple[NDArray[np.float64], ...]]:
    """The groups stacked by their number of cells: (y, x, z) arrays of shape (m, n, ...)."""
    sizes = sorted({g.y.size for g in groups})
    return [tuple(np.stack([getattr(g, a) for g in groups if g.y.size == n])
                  for a in ("y", "x", "z")) for n in sizes]


def _pieces(batches: Sequence[tuple[NDArray[np.float64], ...]], theta: NDArray[np.float64],
            *, floor: bool = False
            ) -> tuple[float, NDArray[np.float64], NDArray[np.float64], float]:
    """Sum of log|V_i|, the information X'V^-1X, X'V^-1y and y'V^-1y."""
    q = batches[0][2].shape[2]
    phi, g = _theta_matrices(theta, q)
    if floor:
        phi = max(phi, 1.0)
    p = batches[0][1].shape[2]
    logdet, info, xy, yy = 0.0, np.zeros((p, p)), np.zeros(p), 0.0
    for y, x, z in batches:
        v = phi * np.eye(y.shape[1]) + z @ g @ np.swapaxes(z, 1, 2)
        chol = np.linalg.cholesky(v)
        logdet += 2.0 * float(np.sum(np.log(np.diagonal(chol, axis1=1, axis2=2))))
        wx = np.linalg.solve(chol, x)
        wy = np.linalg.solve(chol, y[..., None])[..., 0]
        info += np.einsum("mni,mnj->ij", wx, wx)
        xy += np.einsum("mni,mn->i", wx, wy)
        yy += float(np.sum(wy * wy))
    return logdet, info, xy, yy


Batches = Sequence[tuple[NDArray[np.float64], ...]]


def _deviance(theta: NDArray[np.float64], batches: Batches) -> float:
    """The REML deviance (-2 log-likelihood, without constants) at *theta*."""
    try:
        logdet, info, xy, yy = _pieces(batches, theta)
        beta = np.linalg.solve(info, xy)
        sign, logdet_info = np.linalg.slogdet(info)
    except np.linalg.LinAlgError:
        return math.inf
    if sign <= 0:
        return math.inf
    return logdet + float(logdet_info) + yy - float(xy @ beta)


def _fe_cov(batches: Batches, theta: NDArray[np.float64], *,
            floor: bool = False) -> NDArray[np.float64]:
    """The fixed effects' covariance (X'V^-1X)^-1 at *theta*."""
    _, info, _, _ = _pieces(batches, theta, floor=floor)
    return np.asarray(np.linalg.inv(info), dtype=float)


def _theta_covariance(batches: Batches, theta: NDArray[np.float64]
                      ) -> NDArray[np.float64] | None:
    """The covariance of the variance parameters: twice the (pseudo-)inverse Hessian of the
    REML deviance at *theta* (None when it cannot be computed)."""
    from statsmodels.tools.numdiff import approx_hess3

    try:
        hess = approx_hess3(theta, _deviance, args=(batches,))
        cov = 2.0 * np.linalg.pinv(hess, hermitian=True)
    except (np.linalg.LinAlgError, ValueError):
        return None
    return cov if np.all(np.isfinite(cov)) else None


def _satterthwaite(batches: Batches, theta: NDArray[np.float64], c: NDArray[np.float64],
                   theta_cov: NDArray[np.float64] | None, *, fallback: float) -> float:
    """Satterthwaite's degrees of freedom of ``c @ beta``: 2 var^2 / (g' A g), with A the
    covariance of the variance parameters and g the gradient of the variance; *fallback*
    when they cannot be computed."""
    from statsmodels.tools.numdiff import approx_fprime

    if theta_cov is None:
        return fallback

    def variance(t: NDArray[np.float64]) -> float:
        return float(c @ _fe_cov(batches, t) @ c)

    try:
        grad = approx_fprime(theta, variance, centered=True)
        var = variance(theta)
    except (np.linalg.LinAlgError, ValueError):
        return fallback
    denom = float(grad @ theta_cov @ grad)
    if not (math.isfinite(denom) and denom > 0 and math.isfinite(var)):
        return fallback
    return float(min(max(2.0 * var * var / denom, 1.0), 1e6))


def _whiten(cells: Sequence[SubjectCells], log_u0: float, slopes: bool) -> list[_Group]:
    groups = []
    for s in cells:
        chol = np.linalg.cholesky(s.cov)
        x = np.linalg.solve(chol, _design(s.log_u - log_u0))
        groups.append(_Group(np.linalg.solve(chol, s.log_f), x, x if slopes else x[:, :1]))
    return groups


def _mixedlm(groups: Sequence[_Group]) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                                 float]:
    """Fit the whitened model with MixedLM (REML): its fixed effects, between-subject
    covariance and scale.

    Powell's method: on these whitened cells the gradient methods stop short of the
    optimum from MixedLM's start about half the time (by up to 30 in the deviance, on
    simulated populations of 5-12 subjects), Powell's reached it every time (within 0.01).
    """
    from statsmodels.regression.mixed_linear_model import MixedLM

    y = np.concatenate([g.y for g in groups])
    x = np.vstack([g.x for g in groups])
    z = np.vstack([g.z for g in groups])
    labels = np.repeat(np.arange(len(groups)), [g.y.size for g in groups])
    with warnings.catch_warnings():
        # "on the boundary" (a variance of zero is a valid REML estimate), a Hessian for
        # MixedLM's own standard errors that is not used here
        warnings.simplefilter("ignore")
        try:
            res = MixedLM(y, x, groups=labels, exog_re=z).fit(
                reml=True, method=["powell"], maxiter=5000)
        except ValueError as err:
            raise np.linalg.LinAlgError(str(err)) from err
    cov_re = np.atleast_2d(np.asarray(res.cov_re, dtype=float))
    scale = float(res.scale)
    if not (np.all(np.isfinite(cov_re)) and math.isfinite(scale) and scale > 0):
        raise np.linalg.LinAlgError("MixedLM gave no finite estimate")
    return np.asarray(res.fe_params, dtype=float), cov_re, scale


def _theta_of(scale: float, cov_re: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(sqrt phi, Cholesky factor of G by rows)``, G made positive semi-definite."""
    w, vec = np.linalg.eigh((cov_re + cov_re.T) / 2.0)
    g = (vec * np.clip(w, 0.0, None)) @ vec.T
    q = g.shape[0]
    chol = np.linalg.cholesky(g + 1e-12 * np.eye(q))
    return np.concatenate([[math.sqrt(max(scale, 1e-12))], chol[np.tril_indices(q)]])


def fit_power_law(cells: Sequence[SubjectCells]) -> PowerLawFit:
    """Fit ``log F = a + n log U`` across subjects, subjects as random effects (REML).

    Parameters
    ----------
    cells : sequence of SubjectCells
        Each subject's cells (two amplitudes or more each).

    Returns
    -------
    PowerLawFit
        Random slopes when at least three subjects have three or more amplitudes (and the
        fit with them converges), else random intercepts only.

    Raises
    ------
    ValueError
        Fewer than :data:`MIN_SUBJECTS` subjects, or one with fewer than two amplitudes.
    numpy.linalg.LinAlgError
        When MixedLM cannot fit the data.
    """
    if len(cells) < MIN_SUBJECTS or any(np.unique(s.log_u).size < 2 for s in cells):
        raise ValueError(f"a power law across subjects needs at least {MIN_SUBJECTS} "
                         "subjects with two amplitudes or more each")
    log_u0 = float(np.mean(np.concatenate([s.log_u for s in cells])))
    rich = sum(np.unique(s.log_u).size >= 3 for s in cells)
    for slopes in ((True, False) if rich >= MIN_SUBJECTS else (False,)):
        groups = _whiten(cells, log_u0, slopes)
        try:
            beta, cov_re, scale = _mixedlm(groups)
        except np.linalg.LinAlgError as err:
            if not slopes:
                raise
            log.info("power law with random slopes failed (%s); random intercepts only", err)
            continue
        random = "intercept and exponent" if slopes else "intercept"
        method = (f"mixed-effects REML (statsmodels MixedLM; random {random} by subject; "
                  "cells weighted by their intervals; Satterthwaite t)")
        theta = _theta_of(scale, cov_re)
        batches = tuple(_batches(groups))
        return PowerLawFit(beta, log_u0, cov_re, scale, slopes,
                           tuple(s.subject for s in cells), method, batches, theta,
                           _theta_covariance(batches, theta))
    raise np.linalg.LinAlgError("the power law could not be fitted")  # pragma: no cover
