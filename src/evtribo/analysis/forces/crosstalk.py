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

__all__ = ["EDGE_S", "MAX_GAP_S", "ReversalSums", "crosstalk_notes", "direction_share",
           "reversal_sums"]

#: Length of the stretch at the end of one window and the start of the next that gives the
#: forces before and after a reversal, s.
EDGE_S = 0.2
#: Two windows of opposite directions at most this far apart frame one reversal, s.
MAX_GAP_S = 1.0


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


def crosstalk_notes(trials: pd.DataFrame) -> list[str]:
    """What the trials' cross-talk columns say of the rig, pooled over the study.

    Parameters
    ----------
    trials : pandas.DataFrame
        trials.csv's rows (``crosstalk_normal``, ``crosstalk_normal_se``,
        ``tangential_direction_share``).

    Returns
    -------
    list of str
    """
    notes = []
    if {"crosstalk_normal", "crosstalk_normal_se"} <= set(trials.columns):
        a = pd.to_numeric(trials.crosstalk_normal, errors="coerce").to_numpy(float)
        se = pd.to_numeric(trials.crosstalk_normal_se, errors="coerce").to_numpy(float)
        ok = np.isfinite(a) & np.isfinite(se) & (se > 0)
        if ok.sum() >= 2:
            w = 1.0 / se[ok] ** 2
            pooled, pooled_se = float(np.sum(w * a[ok]) / np.sum(w)), float(1 / np.sqrt(w.sum()))
            if abs(pooled) > max(3 * pooled_se, 0.005):
                notes.append(
                    f"the normal cell reads {100 * pooled:+.1f} % (+/- {100 * pooled_se:.1f}) "
                    "of the tangential force: its reading jumps with each reversal of the "
                    f"strokes ({int(ok.sum())} trials); cross-talk, or a finger pressing "
                    "harder one way. The electrostatic force weighs both directions alike "
                    "and is not biased by it, but the normal forces reported are: give "
                    f"[rig.calibration] matrix = [[1.0, {-pooled:.4f}], [0.0, 1.0]] in "
                    "study.toml, or measure the whole matrix with evtribo calibrate")
    if "tangential_direction_share" in trials.columns:
        b = pd.to_numeric(trials.tangential_direction_share, errors="coerce").dropna()
        if len(b) >= 3:
            med = float(b.median())
            if abs(med) > 0.01 and float(np.mean(np.sign(b) == np.sign(med))) >= 0.75:
                notes.append(
                    f"the tangential reading follows the normal force by {100 * med:+.1f} % "
                    f"of it in both sliding directions ({len(b)} trials): cross-talk from the "
                    "normal axis, or friction that differs between the directions; the "
                    "electrostatic force compares each direction with its own friction. "
                    "evtribo calibrate on a recording of the finger pressing without "
                    "sliding tells the two apart")
    return notes
