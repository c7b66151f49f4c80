"""Cross-talk between the load cells' axes, as the data show it.

Two-axis cells, and two cells on one mount, read a few percent of one axis on the other unless
a calibration matrix undoes it (``[rig.calibration] matrix``)::

    F_n,read = F_n + a F_t        F_t,read = F_t + b F_n

- ``a``, the tangential force read by the normal cell, shows at every reversal of the
  strokes: the friction swings from ``+F`` to ``-F`` within a fraction of a second while
  the finger's pressing hardly changes, and the normal reading swings by ``-2 a F`` with it.
  :func:`reversal_sums` takes the forces just before and just after each reversal (the end
  of one steady window and the start of the next one in the other direction); ``a`` is the
  least-squares slope of the normal reading's change on the tangential one's, pooled over
  a trial's or a study's reversals. A person who presses harder in one direction than in
  the other looks the same; a calibration recording (``evtribo calibrate``) tells them
  apart.
- ``b``, the normal force read by the tangential cell, adds ``b F_n`` to the friction in
  both directions: a tangential reading that follows the normal force whatever the
  direction. From sliding alone it cannot be told from friction that differs between
  directions (:func:`direction_share` measures their sum); pressing without sliding can.

Neither changes the electrostatic force as the analysis estimates it (both directions weigh
alike, each against its own friction), but both change the forces the tables report.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pandas as pd
from scipy import special  # stats.t.sf is special.stdtr, stats.norm.cdf special.ndtr

from evtribo.warning.collect import emitter
from evtribo.warning.record import Scope, WarningRecord

__all__ = ["EDGE_S", "MAX_GAP_S", "NOTE_SIGMA", "ReversalSums", "crosstalk_notes",
           "direction_share", "pooled_over_trials", "reversal_sums"]

emit = emitter(__name__)

#: Length of the stretch at the end of one window and the start of the next that gives the
#: forces before and after a reversal, s.
EDGE_S = 0.2
#: Two windows of opposite directions at most this far apart frame one reversal, s.
MAX_GAP_S = 1.0
#: A study's cross-talk is noted when it stands this far from zero: the two-sided tail of
#: so many normal standard deviations (0.27 %), in Student's t over the trials.
NOTE_SIGMA = 3.0


@dataclass(frozen=True)
class ReversalSums:
    """Sums over reversals of the changes of the two readings, to pool and to fit.

    Attributes
    ----------
    n : int
        Reversals.
    sxx, sxy, syy : float, N^2
        Sums of ``dF_t^2``, ``dF_t dF_n``, ``dF_n^2``.
    """

    n: int = 0
    sxx: float = 0.0
    sxy: float = 0.0
    syy: float = 0.0

    def __add__(self, other: ReversalSums) -> ReversalSums:
        return ReversalSums(self.n + other.n, self.sxx + other.sxx, self.sxy + other.sxy,
                            self.syy + other.syy)

    @property
    def slope(self) -> float:
        """``a``: the normal reading's change per unit of the tangential one's (NaN with
        fewer than 3 reversals)."""
        return self.sxy / self.sxx if self.n >= 3 and self.sxx > 0 else float("nan")

    @property
    def slope_se(self) -> float:
        """Standard error of :attr:`slope`."""
        if self.n < 3 or not self.sxx > 0:
            return float("nan")
        rss = max(self.syy - self.sxy**2 / self.sxx, 0.0)
        return float(np.sqrt(rss / (self.n - 1) / self.sxx))


def reversal_sums(forces_t: npt.NDArray[np.float64], normal: npt.NDArray[np.float64],
                  tangential: npt.NDArray[np.float64], windows: pd.DataFrame) -> ReversalSums:
    """The changes of the readings across each reversal of a trial's strokes.

    Parameters
    ----------
    forces_t : ndarray of float, s
        The grid's times.
    normal, tangential : ndarray of float, N
        The readings on the grid (tangential with its sign).
    windows : pandas.DataFrame
        The steady-sliding windows (:func:`~evtribo.analysis.friction.windows.find_windows`:
        ``i_start``, ``i_stop``, ``t_start``, ``t_end``, ``direction``), in time order.

    Returns
    -------
    ReversalSums
    """
    if len(windows) < 2 or forces_t.size < 2:
        return ReversalSums()
    dt = float(forces_t[1] - forces_t[0])
    m = max(1, round(EDGE_S / dt))
    rows = windows.sort_values("t_start")
    i0, i1 = rows.i_start.to_numpy(np.int64), rows.i_stop.to_numpy(np.int64)
    t0, t1 = rows.t_start.to_numpy(float), rows.t_end.to_numpy(float)
    d = rows.direction.to_numpy(float)
    pairs = np.flatnonzero((d[1:] != d[:-1]) & (t0[1:] - t1[:-1] <= MAX_GAP_S))
    dx: list[float] = []
    dy: list[float] = []
    for k in pairs:
        before = slice(max(int(i1[k]) - m, int(i0[k])), int(i1[k]))
        after = slice(int(i0[k + 1]), min(int(i0[k + 1]) + m, int(i1[k + 1])))
        x = _mean(tangential[after]) - _mean(tangential[before])
        y = _mean(normal[after]) - _mean(normal[before])
        if np.isfinite(x) and np.isfinite(y):
            dx.append(x)
            dy.append(y)
    if not dx:
        return ReversalSums()
    xs, ys = np.asarray(dx, dtype=np.float64), np.asarray(dy, dtype=np.float64)
    return ReversalSums(int(xs.size), float(np.dot(xs, xs)), float(np.dot(xs, ys)),
                        float(np.dot(ys, ys)))


def _mean(x: npt.NDArray[np.float64]) -> float:
    """The mean of the finite values of *x* (NaN when none)."""
    good = x[np.isfinite(x)]
    return float(good.mean()) if good.size else float("nan")


def direction_share(windows: pd.DataFrame) -> float:
    """The part of the tangential reading that follows the normal force whatever the
    direction, per unit of normal force: ``(r+ + r-) / 2`` with ``r`` each direction's
    signed ratio of mean tangential to mean normal force over OFF windows (the cross-talk
    ``b`` plus half the friction's difference between the directions); NaN without OFF
    windows in both directions.

    Parameters
    ----------
    windows : pandas.DataFrame
        Windows with ``condition``, ``direction``, ``normal_force_N`` and the signed mean
        tangential force ``tangential_N``.

    Returns
    -------
    float
    """
    off = windows[windows.condition == "off"]
    ratios = []
    for d in (1, -1):
        part = off[off.direction == d]
        if len(part) < 2 or not part.normal_force_N.sum() > 0:
            return float("nan")
        ratios.append(float(part.tangential_N.sum() / part.normal_force_N.sum()))
    return 0.5 * (ratios[0] + ratios[1])


def pooled_over_trials(values: npt.ArrayLike, se: npt.ArrayLike | None = None
                       ) -> tuple[float, float, float]:
    """A rig's constant from its trials' estimates, with the trials' own variation between
    them: a random-effects mean (DerSimonian & Laird's between-trial variance; without
    standard errors, the plain mean) and its Hartung-Knapp standard error, in Student's t
    with one degree of freedom less than the trials.

    A trial's standard error counts its reversals as independent; what differs from trial
    to trial (the finger's posture, how it presses in each direction) does not average out
    within a trial, and a mean weighted by those errors alone is far surer of itself than
    the trials are of each other.

    Parameters
    ----------
    values : array_like of float
        Each trial's estimate.
    se : array_like of float, optional
        Their standard errors.

    Returns
    -------
    mean, se, p : float
        The pooled value, its standard error, and the two-sided p-value of its difference
        from zero (NaN with fewer than 2 trials).
    """
    x = np.asarray(values, dtype=np.float64)
    k = x.size
    if k < 2:
        return (float(x[0]) if k else float("nan")), float("nan"), float("nan")
    if se is None:
        w = np.ones(k)
    else:
        v = np.asarray(se, dtype=np.float64) ** 2
        w0 = 1.0 / v
        mean0 = float(np.sum(w0 * x) / np.sum(w0))
        q = float(np.sum(w0 * (x - mean0) ** 2))
        tau2 = max(0.0, (q - (k - 1)) / (np.sum(w0) - np.sum(w0**2) / np.sum(w0)))
        w = 1.0 / (v + tau2)
    mean = float(np.sum(w * x) / np.sum(w))
    var = float(np.sum(w * (x - mean) ** 2) / ((k - 1) * np.sum(w)))
    err = float(np.sqrt(var))
    p = float(2.0 * special.stdtr(k - 1, -abs(mean) / err)) if err > 0 else (
        0.0 if mean != 0 else 1.0)
    return mean, err, p


def crosstalk_notes(trials: pd.DataFrame) -> list[WarningRecord]:
    """Say what the trials' cross-talk columns say of the rig (``crosstalk-normal``,
    ``crosstalk-tangential``), pooled over the study's trials with their variation between
    them (:func:`pooled_over_trials`).

    Parameters
    ----------
    trials : pandas.DataFrame
        trials.csv's rows (``crosstalk_normal``, ``crosstalk_normal_se``,
        ``tangential_direction_share``).

    Returns
    -------
    list of WarningRecord
        The warnings said.
    """
    notes = []
    alpha = float(2.0 * special.ndtr(-NOTE_SIGMA))
    if {"crosstalk_normal", "crosstalk_normal_se"} <= set(trials.columns):
        a = pd.to_numeric(trials.crosstalk_normal, errors="coerce").to_numpy(float)
        se = pd.to_numeric(trials.crosstalk_normal_se, errors="coerce").to_numpy(float)
        ok = np.isfinite(a) & np.isfinite(se) & (se > 0)
        if ok.sum() >= 3:
            pooled, pooled_se, p = pooled_over_trials(a[ok], se[ok])
            if p < alpha and abs(pooled) > 0.005:
                notes.append(emit("crosstalk-normal", Scope(), share_pct=100 * pooled,
                                  share_se_pct=100 * pooled_se, trials=int(ok.sum()),
                                  matrix_b=-pooled))
    if "tangential_direction_share" in trials.columns:
        b = pd.to_numeric(trials.tangential_direction_share, errors="coerce").dropna()
        if len(b) >= 3:
            mean, _, p = pooled_over_trials(b.to_numpy(float))
            if p < alpha and abs(mean) > 0.01:
                notes.append(emit("crosstalk-tangential", Scope(), share_pct=100 * mean,
                                  trials=len(b)))
    return notes
