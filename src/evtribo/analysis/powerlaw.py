"""Power law ``F_el = k * U**n`` over a subject's amplitudes, with an interval on ``n``.

The fit is a least-squares line through ``(log U, log F_el)``. Two sources of uncertainty
are combined, and the reported interval covers both:

- the scatter of the points about the line (Student-t interval from the slope's standard
  error; needs three amplitudes or more), which holds any departure from a pure power law;
- the measurement error of each point (percentiles of the slope fitted to every bootstrap
  replicate of the forces, :func:`evtribo.analysis.estimate.estimate_electrostatic`), which
  works with two amplitudes as well.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import stats

from evtribo.errors import AnalysisError

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PowerLawFit:
    """A power law fitted over amplitudes.

    Attributes
    ----------
    exponent : float
        ``n``.
    exponent_ci_low, exponent_ci_high : float
        Interval on ``n`` (NaN when it cannot be estimated).
    prefactor_N : float, N
        ``k``, the force at ``U = 1 V``.
    n_points : int
        Amplitudes used (positive forces only).
    """

    exponent: float
    exponent_ci_low: float
    exponent_ci_high: float
    prefactor_N: float
    n_points: int


def fit_power_law(
    voltage_V: npt.ArrayLike,
    force_N: npt.ArrayLike,
    *,
    replicates_N: npt.ArrayLike | None = None,
    confidence: float = 0.95,
) -> PowerLawFit:
    """Fit ``F = k * U**n`` by least squares in log-log coordinates.

    Parameters
    ----------
    voltage_V : array_like of float, V
        Amplitudes.
    force_N : array_like of float, N
        Force at each amplitude; non-positive or non-finite points are left out.
    replicates_N : array_like of float, shape (n_boot, n_amplitudes), optional
        Bootstrap replicates of *force_N*; replicates with a non-positive value are left out.
    confidence : float
        Coverage of the interval on ``n``.

    Returns
    -------
    PowerLawFit

    Raises
    ------
    AnalysisError
        Fewer than two distinct positive amplitudes with a positive force.
    """
    u = np.asarray(voltage_V, dtype=np.float64).ravel()
    f = np.asarray(force_N, dtype=np.float64).ravel()
    keep = np.isfinite(u) & np.isfinite(f) & (u > 0) & (f > 0)
    x, y = np.log(u[keep]), np.log(f[keep])
    if np.unique(x).size < 2:
        raise AnalysisError(f"a power law needs two amplitudes or more with a positive force; "
                            f"got {np.unique(x).size}")
    xm = x.mean()
    sxx = float(np.sum((x - xm) ** 2))
    slope = float(np.sum((x - xm) * (y - y.mean())) / sxx)
    intercept = float(y.mean() - slope * xm)
    alpha = (1.0 - confidence) / 2.0
    lows, highs = [], []
    dof = x.size - 2
    if dof >= 1:
        resid = y - (intercept + slope * x)
        se = float(np.sqrt(np.sum(resid**2) / dof / sxx))
        q = float(stats.t.ppf(1.0 - alpha, dof))
        lows.append(slope - q * se)
        highs.append(slope + q * se)
    if replicates_N is not None:
        reps = np.asarray(replicates_N, dtype=np.float64)
        reps = reps[:, keep] if reps.ndim == 2 else reps.reshape(0, x.size)
        good = np.all(reps > 0, axis=1) & np.all(np.isfinite(reps), axis=1)
        if np.count_nonzero(good) >= 20:
            ly = np.log(reps[good])
            slopes = ((ly - ly.mean(axis=1, keepdims=True)) @ (x - xm)) / sxx
            lo, hi = np.quantile(slopes, [alpha, 1.0 - alpha])
            lows.append(float(lo))
            highs.append(float(hi))
    return PowerLawFit(
        exponent=slope,
        exponent_ci_low=min(lows) if lows else float("nan"),
        exponent_ci_high=max(highs) if highs else float("nan"),
        prefactor_N=float(np.exp(intercept)),
        n_points=int(x.size),
    )


__all__ = ["PowerLawFit", "fit_power_law"]
