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
    """The model's forces at the scaled parameters and their weighted Jacobian, and the
    misfit of a replicate (:func:`refit_replicates`)."""

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

    def misfit(self, t: NDArray[np.float64], x: NDArray[np.float64]
               ) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
        """The cost at *x* (infinite where the model has no finite value there: a
        parameter run off to where the data no longer determine it)."""
        if not np.all(np.isfinite(x)):
            return math.inf, x, x
        try:
            m, g = self(x)
        except (ConfigError, FloatingPointError, ValueError, np.linalg.LinAlgError):
            return math.inf, x, x
        if not (np.all(np.isfinite(m)) and np.all(np.isfinite(g))):
            return math.inf, m, g
        return float(np.sum(((t - m) / self.sigma) ** 2)), m, g


def refit_replicates(model: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                      x0: NDArray[np.float64], targets: NDArray[np.float64],
                      sigma: NDArray[np.float64], lower: NDArray[np.float64],
                      *, upper: NDArray[np.float64] | None = None, max_iter: int = 30,
                      tol: float = 1e-6) -> NDArray[np.float64]:
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

    Returns
    -------
    ndarray, shape (n_converged, n_parameters)
        The refitted (scaled) parameters of the replicates whose refit converged; a
        parameter that ran off (:data:`RUNAWAY`) is infinite there.
    """
    weighted = _Weighted(model, sigma)
    high = np.full(x0.size, np.inf) if upper is None else upper
    m0, g0 = weighted(x0)
    misfit = weighted.misfit
    out = []
    for t in targets:
        if not np.all(np.isfinite(t)):
            continue
        x, m, g = x0, m0, g0
        cost = float(np.sum(((t - m) / sigma) ** 2))
        for _ in range(max_iter):
            step = np.linalg.lstsq(g, (t - m) / sigma, rcond=None)[0]
            if not np.all(np.isfinite(step)):
                break  # the data do not determine the step: this refit failed
            if np.all(np.abs(step) <= tol * np.maximum(np.abs(x), 1.0)):
                out.append(np.clip(x + step, lower, high))  # Gauss-Newton's last step is tiny
                break
            if np.any(np.abs(x + step) > RUNAWAY * np.maximum(np.abs(x0), 1.0)):
                # a parameter the replicate no longer holds (its force gone: an air gap
                # off to infinity): infinite in this refit, as the data leave it
                out.append(np.where(np.abs(x + step) > RUNAWAY, np.inf * np.sign(step), x))
                break
            for _ in range(10):  # backtrack while the step raises the misfit
                x_new = np.clip(x + step, lower, high)
                cost_new, m_new, g_new = misfit(t, x_new)
                if cost_new <= cost:
                    break
                step = step / 2.0
            else:
                out.append(x)  # no descent left: a minimum to the model's precision
                break
            x, m, g, cost = x_new, m_new, g_new, cost_new
    return np.asarray(out, dtype=float).reshape(-1, x0.size)
