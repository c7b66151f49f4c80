"""The spread of a weighted least-squares solution: the Jacobian's covariance, with the
directions the data do not determine made infinite, and refits to bootstrap replicates of
the measured values (see :mod:`evtribo.fit.fit`)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

__all__ = ["covariance", "refit_replicates"]


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
        The refitted (scaled) parameters of the replicates whose refit converged.
    """
    def weighted(x: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        m = model(x)
        jac = np.empty((m.size, x.size))
        for i in range(x.size):
            h = 1e-7 * max(abs(x[i]), 1.0)
            xi = x.copy()
            xi[i] += h
            jac[:, i] = (model(xi) - m) / h / sigma
        return m, jac

    high = np.full(x0.size, np.inf) if upper is None else upper
    m0, g0 = weighted(x0)
    out = []
    for t in targets:
        if not np.all(np.isfinite(t)):
            continue
        x, m, g = x0, m0, g0
        cost = float(np.sum(((t - m) / sigma) ** 2))
        for _ in range(max_iter):
            step = np.linalg.lstsq(g, (t - m) / sigma, rcond=None)[0]
            if np.all(np.abs(step) <= tol * np.maximum(np.abs(x), 1.0)):
                out.append(np.clip(x + step, lower, high))  # Gauss-Newton's last step is tiny
                break
            for _ in range(10):  # backtrack while the step raises the misfit
                x_new = np.clip(x + step, lower, high)
                m_new, g_new = weighted(x_new)
                cost_new = float(np.sum(((t - m_new) / sigma) ** 2))
                if cost_new <= cost:
                    break
                step = step / 2.0
            else:
                out.append(x)  # no descent left: a minimum to the model's precision
                break
            x, m, g, cost = x_new, m_new, g_new, cost_new
    return np.asarray(out, dtype=float).reshape(-1, x0.size)
