"""The spread of a weighted least-squares solution: the Jacobian's covariance, with the
directions the data do not determine made infinite, and refits to bootstrap replicates of
the measured values (see :mod:`evtribo.fit.fit`)."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from evtribo.errors import ConfigError

__all__ = ["RUNAWAY", "covariance", "refit_replicates"]

#: A refit's step that takes a parameter this many times past the solution's scale has left
#: the region the replicate determines: the parameter counts as infinite in that refit.
RUNAWAY = 1e6


def covariance(jac: NDArray[np.float64],
                x: NDArray[np.float64]) -> NDArray[np.float64]:
    """(J^T J)^-1 by SVD, infinite along directions the data do not determine.

    A direction is not determined when its singular value is zero to the precision of the
    Jacobian (a ratio to the largest beyond 1e-6 means a correlation indistinguishable from
    1), or when it mixes several parameters and one standard error along it moves every
    one of them by more than its own value (the combination the data cannot see, whatever
    the scale the solution ended at).

    Parameters
    ----------
    jac : ndarray, shape (n_residuals, n_parameters)
        Jacobian of the weighted residuals at the solution.
    x : ndarray, shape (n_parameters,)
        The solution (in the parameters of *jac*).

    Returns
    -------
    ndarray, shape (n_parameters, n_parameters)
        The covariance, with infinite rows and columns for the undetermined parameters.
    """
    _, s, vt = np.linalg.svd(jac, full_matrices=False)
    tol = np.finfo(float).eps * max(jac.shape) * (s[0] if s.size else 0.0)
    bad = (s <= tol) | (s < 1e-6 * (s[0] if s.size else 0.0))
    involved = np.abs(vt) > 1e-3
    with np.errstate(divide="ignore"):
        move = np.abs(vt) / np.where(bad, 1.0, s)[:, None]
    unseen = (involved.sum(axis=1) > 1) & np.all(~involved | (move > np.abs(x)), axis=1)
    bad = bad | unseen
    s_inv2 = np.where(bad, 0.0, 1.0 / np.where(bad, 1.0, s) ** 2)
    cov = (vt.T * s_inv2) @ vt
    if bad.any():
        undetermined = np.any(involved[bad], axis=0)
        cov[undetermined, :] = np.inf
        cov[:, undetermined] = np.inf
    return cov


class _Weighted:
    """The model's forces at the scaled parameters and their weighted Jacobian (at the
    solution, the start of every refit: :func:`refit_replicates`)."""

    def __init__(self, model: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                 sigma: NDArray[np.float64]) -> None:
        self.model, self.sigma = model, sigma

    def __call__(self, x: NDArray[np.float64]) -> tuple[NDArray[np.float64],
                                                       NDArray[np.float64]]:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            m = self.model(x)
            jac = np.empty((m.size, x.size))
            for i in range(x.size):
                h = 1e-7 * max(abs(x[i]), 1.0)
                xi = x.copy()
                xi[i] += h
                jac[:, i] = (self.model(xi) - m) / h / self.sigma
        return m, jac


def refit_replicates(model: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                      x0: NDArray[np.float64], targets: NDArray[np.float64],
                      sigma: NDArray[np.float64], lower: NDArray[np.float64],
                      *, upper: NDArray[np.float64] | None = None, max_iter: int = 30,
                      tol: float = 1e-6,
                      many: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None = None
                      ) -> NDArray[np.float64]:
    """Weighted least-squares solution for each row of *targets*, by Gauss-Newton from *x0*.

    Parameters
    ----------
    model : callable
        Model forces at the (scaled) parameters, N.
    x0 : ndarray
        The solution for the measured forces (the start of every refit).
    targets : ndarray, shape (n_replicates, n_points), N
        Replicates of the measured forces.
    sigma : ndarray, N
        Weights (the same as the fit's).
    lower : ndarray
        Lower bounds of the scaled parameters.
    upper : ndarray, optional
        Upper bounds (none by default).
    max_iter : int
        Iterations before a refit counts as failed.
    tol : float
        Convergence: the size of the next Gauss-Newton step relative to the parameters
        (which are scaled so that 1 is the solution for the measured forces).
    many : callable, optional
        *model* at each row of a (K, n_parameters) array at once, shape (K, n_points), NaN
        where the parameters are not valid: the replicates are then refitted side by side,
        each step of each the same numbers as one by one. It must give *model*'s numbers
        at every row (:attr:`evtribo.fit.problem.Problem.side_by_side` says where
        :meth:`~evtribo.fit.problem.Problem.model_many` does); as a check, it is used only
        where it gives them at *x0*.

    Returns
    -------
    ndarray, shape (n_converged, n_parameters)
        The refitted (scaled) parameters of the replicates whose refit converged; a
        parameter that ran off (:data:`RUNAWAY`) is infinite there.
    """
    high = np.full(x0.size, np.inf) if upper is None else upper
    side_by_side = many is not None and _gives_the_same(model, many, x0)
    return _Refits(model, many if side_by_side else None, sigma,
                   (lower, high, max_iter, tol)).refit(x0, targets)


def _gives_the_same(model: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                    many: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                    x0: NDArray[np.float64]) -> bool:
    """Whether *many* gives *model*'s numbers at *x0* (a model that cannot take its
    parameters side by side fails this, or raises)."""
    try:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            return bool(np.array_equal(many(x0[None, :])[0], model(x0), equal_nan=True))
    except (ConfigError, FloatingPointError, ValueError, TypeError, np.linalg.LinAlgError):
        return False


def _step(g: NDArray[np.float64], r: NDArray[np.float64]) -> NDArray[np.float64]:
    """The Gauss-Newton step of weighted Jacobian *g* and weighted residuals *r*."""
    return np.asarray(np.linalg.lstsq(g, r, rcond=None)[0], dtype=float)


class _Refits:
    """The replicates' refits, every replicate still moving taking its Gauss-Newton step at
    once: the model evaluated for all of them by *many*, or one after the other by *model*
    (*many* None). Each refit's numbers are the same either way.

    *bounds*: the lower and upper bounds, the iterations allowed and the tolerance.
    """

    def __init__(self, model: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                 many: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None,
                 sigma: NDArray[np.float64], bounds: _Bounds) -> None:
        self.model, self.weighted, self.sigma = model, _Weighted(model, sigma), sigma
        self.many = many if many is not None else self._each
        self.lower, self.high, self.max_iter, self.tol = bounds

    def _each(self, xs: NDArray[np.float64]) -> NDArray[np.float64]:
        """The model at each row of *xs*, one after the other: NaN where it has no value
        (parameters not finite, or not valid: the model raises)."""
        out = np.full((len(xs), self.sigma.size), np.nan)
        for k, x in enumerate(xs):
            if np.all(np.isfinite(x)):
                try:
                    out[k] = self.model(x)
                except (ConfigError, FloatingPointError, ValueError, np.linalg.LinAlgError):
                    pass
        return out

    def misfits(self, t: NDArray[np.float64], xs: NDArray[np.float64]
                ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """The weighted misfit of each row of *xs* against the same row of *t* (infinite
        where the model or its Jacobian has no finite value), the forces and the weighted
        Jacobians there."""
        k, p = xs.shape
        h = 1e-7 * np.maximum(np.abs(xs), 1.0)
        shifted = [xs] + [xs + np.eye(p)[i] * h[:, i:i + 1] for i in range(p)]
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            values = self.many(np.concatenate(shifted))
            m = values[:k]
            g = np.empty((k, m.shape[1], p))
            for i in range(p):
                g[:, :, i] = (values[(i + 1) * k:(i + 2) * k] - m) / h[:, i:i + 1] / self.sigma
        finite = np.all(np.isfinite(xs), axis=1)
        costs = np.full(k, math.inf)
        for j in range(k):
            if finite[j] and np.all(np.isfinite(m[j])) and np.all(np.isfinite(g[j])):
                costs[j] = float(np.sum(((t[j] - m[j]) / self.sigma) ** 2))
        return costs, m, g

    def refit(self, x0: NDArray[np.float64], targets: NDArray[np.float64]
              ) -> NDArray[np.float64]:
        """The converged refits, in the order of *targets*' finite rows."""
        sigma, lower, high, tol = self.sigma, self.lower, self.high, self.tol
        m0, g0 = self.weighted(x0)
        self.t = t = np.asarray([r for r in targets if np.all(np.isfinite(r))], dtype=float)
        k = len(t)
        self.x, self.m = np.tile(x0, (k, 1)), np.tile(m0, (k, 1))
        self.g = np.tile(g0, (k, 1, 1))
        self.cost = np.array([float(np.sum(((t[j] - m0) / sigma) ** 2)) for j in range(k)])
        self.out: list[NDArray[np.float64] | None] = [None] * k
        x, m, g, out = self.x, self.m, self.g, self.out
        active = list(range(k))
        for _ in range(self.max_iter):
            if not active:
                break
            moving: dict[int, NDArray[np.float64]] = {}
            for j in active:
                step = _step(g[j], (t[j] - m[j]) / sigma)
                if not np.all(np.isfinite(step)):
                    continue  # the data do not determine the step: this refit failed
                if np.all(np.abs(step) <= tol * np.maximum(np.abs(x[j]), 1.0)):
                    out[j] = np.clip(x[j] + step, lower, high)
                elif np.any(np.abs(x[j] + step) > RUNAWAY * np.maximum(np.abs(x0), 1.0)):
                    out[j] = np.where(np.abs(x[j] + step) > RUNAWAY, np.inf * np.sign(step),
                                      x[j])
                else:
                    moving[j] = step
            active = self._descend(moving)
        return np.asarray([r for r in out if r is not None], dtype=float).reshape(-1, x0.size)

    def _descend(self, moving: dict[int, NDArray[np.float64]]) -> list[int]:
        """Each moving refit's step (by replicate), halved while it raises the misfit (up
        to 10 tries), taken; the refits still moving."""
        x, m, g, cost = self.x, self.m, self.g, self.cost
        taken = []
        for _ in range(10):
            if not moving:
                break
            rows = list(moving)
            trial = np.clip(x[rows] + np.asarray(list(moving.values())), self.lower,
                            self.high)
            costs, ms, gs = self.misfits(self.t[rows], trial)
            for n, j in enumerate(rows):
                if costs[n] <= cost[j]:
                    x[j], m[j], g[j], cost[j] = trial[n], ms[n], gs[n], costs[n]
                    taken.append(j)
                    del moving[j]
                else:
                    moving[j] = moving[j] / 2.0
        for j in moving:  # no descent left: a minimum to the model's precision
            self.out[j] = x[j].copy()
        return sorted(taken)


#: A refit's lower and upper bounds, the iterations allowed and the tolerance.
_Bounds = tuple[NDArray[np.float64], NDArray[np.float64], int, float]
