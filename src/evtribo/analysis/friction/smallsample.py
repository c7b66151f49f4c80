"""The small-sample calibration of a percentile-bootstrap interval (see
:mod:`evtribo.analysis.friction.estimate`): a Welch-Satterthwaite Student factor for few windows."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy import special  # stats.t.ppf is special.stdtrit, stats.norm.ppf special.ndtri

__all__ = ["DEFAULT_CONFIDENCE", "small_sample_scale"]

DEFAULT_CONFIDENCE = 0.95


def small_sample_scale(variances: npt.ArrayLike, counts: npt.ArrayLike,
                       confidence: float = DEFAULT_CONFIDENCE, *,
                       dofs: npt.ArrayLike | None = None) -> tuple[float, float]:
    """Stretch of a percentile-bootstrap interval for few windows (Welch-Satterthwaite).

    Parameters
    ----------
    variances : array_like of float, N^2
        Bootstrap (plug-in) variance of each independent error source of the estimate.
    counts : array_like of int
        Windows (or strokes) behind each source.
    confidence : float
        Coverage of the interval.
    dofs : array_like of float, optional
        Degrees of freedom of each source (default: ``counts - 1``, a mean's).

    Returns
    -------
    scale : float
        ``sqrt(sum w_i / sum v_i) * t(q, nu) / z(q)`` with ``w_i = v_i n_i / f_i`` and
        ``f_i`` the source's degrees of freedom (1 when the variances are all zero).
    dof : float
        ``nu = (sum w_i)^2 / sum(w_i^2 / f_i)`` (inf when the variances are zero).
    """
    v = np.asarray(variances, dtype=np.float64).ravel()
    n = np.asarray(counts, dtype=np.float64).ravel()
    f = n - 1.0 if dofs is None else np.asarray(dofs, dtype=np.float64).ravel()
    use = np.isfinite(v) & (v > 0) & (f > 0)
    if not use.any():
        return 1.0, float("inf")
    v, n, f = v[use], n[use], f[use]
    w = v * n / f
    dof = float(np.sum(w) ** 2 / np.sum(w**2 / f))
    q = 1.0 - (1.0 - confidence) / 2.0
    ratio = float(special.stdtrit(dof, q) / special.ndtri(q))  # t and normal quantiles
    return float(np.sqrt(np.sum(w) / np.sum(v))) * ratio, dof
