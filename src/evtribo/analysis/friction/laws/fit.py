"""A subject's friction law fitted from all its trials at once: how the friction grows with
the load, and how it follows the pace of the strokes (which law the forces then use is the
choice of ``[analysis] friction_law``, :mod:`evtribo.analysis.friction.laws`).

The load. A finger pad on smooth glass is a soft Hertzian contact: its real area grows as
``W**(2/3)`` and the friction follows the area, so ``F_t = c * W**m`` with ``m`` from 2/3 (a
dry pad, ``mu ~ W**(-1/3)``) towards 1 as the contact saturates; finger pads give about
0.67-0.9 (Adams et al., J. R. Soc. Interface 2013; Dzidek et al., J. R. Soc. Interface
2017). Amontons' law is ``m = 1`` (the law itself: :class:`evtribo.model.friction_law.LoadLaw`).
The electrostatic force loads the same contact: ON, ``W = F_n + F_el``, and the force is
``F_el = (F_t,on / c)**(1/m) - F_n,on`` (:mod:`evtribo.analysis.friction.estimate`), which
is ``F_t,on/mu - F_n,on`` only when ``m = 1``; with ``m`` taken as 1 where it is 0.75, F_el
comes out about a quarter low.

The pace. Finger-pad friction depends on the sliding speed (``mu ~ v**beta``, beta about
0.1-0.2; Pasumarty et al. 2011, Adams et al. 2013), and a person's strokes differ in speed.
The rig rarely logs the finger's position, but each stroke's duration is in the data (from
one reversal of the friction to the next) and a hand's strokes cover about the same
length, so the stroke's rate follows its speed.

:func:`fit_subject_law` fits both over all of a subject's trials (they are the finger's, not
one trial's): within each trial, ``log F_t`` and the regressors are freed of the trial's
own level, each ON group's level and its change with the load, the direction's term and a
trend in time (weighted least squares, weights ``F_n``); ``m`` is then the slope of
``log F_t`` on ``log F_n`` over the OFF windows (the ON windows' own slope is left out:
``F_el`` grows slower than ``F_n``, which would pull it down), and ``beta`` the slope on
the stroke's log rate over all windows, both pooled over the trials. Their standard errors
are cluster-robust over strokes (CR1). The presses tell ``m`` when its 95 % interval is
narrower than the span from the dry contact's 2/3 to Amontons' 1 (:data:`TOLD_WIDTH`):
a press held within a few percent does not, a press that wanders by +/- 0.1-0.2 N or OFF
phases at two or three target presses do (:attr:`FittedLaw.told`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import special

from evtribo.analysis.friction.window_facts import (
    MAX_DEGREE,
    SPAN_PER_DEGREE_S,
    WindowFacts,
    stack_facts,
    time_basis,
)
from evtribo.warning.collect import emitter
from evtribo.warning.record import Scope, WarningRecord

__all__ = ["RATE_SE", "SENSITIVITY_EXPONENT", "TOLD_WIDTH", "FittedLaw", "fit_subject_law",
           "untold_note"]

emit = emitter(__name__)

FloatArray = npt.NDArray[np.float64]

#: The presses tell ``m`` when its 95 % interval is at most this wide (from 2/3 to 1).
TOLD_WIDTH = 1.0 / 3.0
#: The exponent of the sensitivity row where the presses do not tell ``m`` (the ``m075``
#: columns of electrostatic.csv).
SENSITIVITY_EXPONENT = 0.75
#: A subject's friction follows its strokes' rate when the pooled slope stands this many
#: standard errors from zero.
RATE_SE = 3.0
#: Fewest windows a trial needs to join the pooled fit, beyond its nuisance terms.
MIN_FREE = 3


@dataclass(frozen=True)
class FittedLaw:
    """A subject's friction law as its windows give it: ``F_t = c W_0 (W / W_0)**m`` with
    the ``m`` of :attr:`estimate`, times the stroke rate's factor ``exp(rate_slope * (rate -
    its mean))`` (the mean is each reference's).

    Attributes
    ----------
    estimate, estimate_se : float
        ``m`` as the OFF windows give it and its standard error (NaN when the presses
        give no spread to fit it to).
    told : bool
        Whether the presses tell ``m`` (its interval narrower than :data:`TOLD_WIDTH`).
    dof : float
        Degrees of freedom of the estimate (strokes less the coefficients).
    rate_slope, rate_se : float
        The coefficient's change per unit of log stroke rate, relative (0 when not
        supported) and its standard error (NaN when the trials cannot tell it).
    load_ref_N : float, N
        ``W_0``: the OFF windows' mean normal force, where ``c`` is the coefficient.
    press_spread : float
        Standard deviation of the OFF windows' ``log F_n`` about their trials' means.
    """

    estimate: float = float("nan")
    estimate_se: float = float("nan")
    told: bool = False
    dof: float = 0.0
    rate_slope: float = 0.0
    rate_se: float = float("nan")
    load_ref_N: float = 1.0
    press_spread: float = 0.0

    @property
    def holds_amontons(self) -> bool:
        """Whether the presses tell ``m`` and its 95 % interval holds 1: the data are
        Amontons' as far as they can tell."""
        low, high = self.interval
        return self.told and bool(low <= 1.0 <= high)

    @property
    def interval(self) -> tuple[float, float]:
        """The 95 % interval of :attr:`estimate` (Student's t with :attr:`dof`)."""
        if not (np.isfinite(self.estimate_se) and self.dof > 0):
            return float("nan"), float("nan")
        half = float(special.stdtrit(self.dof, 0.975)) * self.estimate_se
        return self.estimate - half, self.estimate + half


@dataclass
class _Sums:
    """The pooled within-trial cross products (regressors: ``log F_n`` of the OFF windows,
    the log stroke rate) and the scores per stroke for the robust covariance."""

    xx: FloatArray
    xy: FloatArray
    scores: list[FloatArray]
    resid_x: list[FloatArray]
    resid_y: list[FloatArray]
    weights: list[FloatArray]
    windows: int = 0
    coefs: int = 0
    spread: list[FloatArray] | None = None


def _trial_columns(fn: FloatArray, group: FloatArray, facts: WindowFacts, rated: bool
                   ) -> tuple[FloatArray, FloatArray]:
    """One trial's regressors ``[log F_n (OFF windows), rate]`` and its nuisance terms:
    level, each ON group's level and change with ``log F_n``, direction and a trend."""
    log_fn = np.log(fn)
    off = ~np.isfinite(group)
    cols = [np.ones(fn.size)]
    for g in np.unique(group[~off]):
        member = group == g
        cols.append(member.astype(np.float64))
        if member.sum() >= 3:
            cols.append(np.where(member, log_fn - log_fn[member].mean(), 0.0))
    if np.ptp(facts.direction) > 0:
        cols.append(facts.direction.astype(np.float64))
    t = facts.t_s
    if np.isfinite(t).all() and np.ptp(t) > 0:
        degree = min(MAX_DEGREE, int(np.ptp(t) // SPAN_PER_DEGREE_S))
        if degree:
            cols += list(time_basis(t, float(t.min()), float(t.max()), degree).T)
    x = np.column_stack([np.where(off, log_fn, 0.0),
                         facts.rate if rated else np.zeros(fn.size)])
    return x, np.column_stack(cols)


def _pooled(parts: Sequence[tuple[npt.ArrayLike, npt.ArrayLike, WindowFacts, npt.ArrayLike]]
            ) -> tuple[_Sums, list[npt.NDArray[np.int64]]]:
    """Every trial's windows (ON and OFF together), freed of its nuisance terms, summed."""
    fn_all = np.concatenate([np.asarray(p[0], dtype=np.float64) for p in parts]) \
        if parts else np.empty(0)
    ft_all = np.concatenate([np.asarray(p[1], dtype=np.float64) for p in parts]) \
        if parts else np.empty(0)
    group_all = np.concatenate([np.asarray(p[3], dtype=np.float64) for p in parts]) \
        if parts else np.empty(0)
    facts_all = stack_facts([p[2] for p in parts]) if parts else WindowFacts.plain(0)
    sums = _Sums(np.zeros((2, 2)), np.zeros(2), [], [], [], [], spread=[])
    clusters: list[npt.NDArray[np.int64]] = []
    good = (fn_all > 0) & (ft_all > 0) & np.isfinite(fn_all) & np.isfinite(ft_all)
    for s in np.unique(facts_all.stratum):
        sel = good & (facts_all.stratum == s)
        rated = bool(sel.any() and np.isfinite(facts_all.rate[sel]).all())
        part = facts_all.take(sel)
        x, z = _trial_columns(fn_all[sel], group_all[sel], part, rated)
        if sel.sum() < z.shape[1] + MIN_FREE:
            continue
        sw = np.sqrt(fn_all[sel])
        q, r = np.linalg.qr(z * sw[:, None])
        keep = np.abs(np.diag(r)) > 1e-10 * np.max(np.abs(np.diag(r)))
        q = q[:, keep]
        xw, yw = x * sw[:, None], np.log(ft_all[sel]) * sw
        rx = xw - q @ (q.T @ xw)
        ry = yw - q @ (q.T @ yw)
        sums.xx += rx.T @ rx
        sums.xy += rx.T @ ry
        sums.resid_x.append(rx)
        sums.resid_y.append(ry)
        sums.windows += int(sel.sum())
        sums.coefs += int(keep.sum())
        clusters.append(part.cluster)
        off = ~np.isfinite(group_all[sel])
        if off.sum() >= 2:
            lf = np.log(fn_all[sel][off])
            assert sums.spread is not None
            sums.spread.append(lf - lf.mean())
    return sums, clusters


def _robust_cov(sums: _Sums, clusters: list[npt.NDArray[np.int64]], coef: FloatArray,
                use: npt.NDArray[np.bool_]) -> tuple[FloatArray, int]:
    """The coefficients' covariance, and the strokes behind it: cluster-robust (CR1,
    strokes), but never below the classical one of independent windows (the robust one
    rests on the strokes' own scatter, which is itself uncertain with few of them; the
    presses are said to tell ``m`` from its interval, and a robust variance that came out
    small by chance would say so too often)."""
    a = sums.xx[np.ix_(use, use)]
    inv = np.linalg.inv(a)
    meat = np.zeros((use.sum(), use.sum()))
    n_clusters = 0
    rss = 0.0
    for rx, ry, cl in zip(sums.resid_x, sums.resid_y, clusters, strict=True):
        e = ry - rx[:, use] @ coef
        rss += float(e @ e)
        _, which = np.unique(cl, return_inverse=True)
        k = int(which.max()) + 1 if which.size else 0
        score = np.zeros((k, use.sum()))
        np.add.at(score, which, rx[:, use] * e[:, None])
        meat += score.T @ score
        n_clusters += k
    p = int(use.sum()) + sums.coefs
    n = sums.windows
    factor = (n_clusters / max(n_clusters - 1, 1)) * ((n - 1) / max(n - p, 1))
    robust = inv @ meat @ inv * factor
    classical = inv * rss / max(n - p, 1)
    scale = np.sqrt(np.maximum(np.diag(classical), np.diag(robust))
                    / np.maximum(np.diag(robust), 1e-300))
    return robust * np.outer(scale, scale), n_clusters


def fit_subject_law(parts: Sequence[tuple[npt.ArrayLike, npt.ArrayLike, WindowFacts,
                                          npt.ArrayLike]]) -> FittedLaw:
    """A subject's friction law from all its windows (ON and OFF, every trial).

    Parameters
    ----------
    parts : sequence of (normal_N, friction_N, facts, group)
        Windows, their facts (``stratum`` tells the trials: a trial's ON and OFF windows are
        fitted together whichever part they come in) and their groups (NaN for OFF
        windows). N for the forces.

    Returns
    -------
    FittedLaw
        Which law the forces use is chosen from it (:mod:`evtribo.analysis.friction.laws`).
    """
    sums, clusters = _pooled(parts)
    off_fn = np.concatenate([np.asarray(p[0], dtype=np.float64)[
        ~np.isfinite(np.asarray(p[3], dtype=np.float64))] for p in parts]) if parts \
        else np.empty(0)
    off_fn = off_fn[np.isfinite(off_fn) & (off_fn > 0)]
    ref = float(np.exp(np.mean(np.log(off_fn)))) if off_fn.size else 1.0
    spread = (float(np.std(np.concatenate(sums.spread))) if sums.spread else 0.0)
    use = np.diag(sums.xx) > 1e-12 * max(float(np.max(np.diag(sums.xx))), 1e-300)
    dof = 0.0
    coef = np.full(2, np.nan)
    cov = np.full((2, 2), np.nan)
    if use.any():
        coef_u = np.asarray(np.linalg.solve(sums.xx[np.ix_(use, use)], sums.xy[use]),
                            dtype=np.float64)
        cov_u, n_clusters = _robust_cov(sums, clusters, coef_u, use)
        coef[use] = coef_u
        cov[np.ix_(use, use)] = cov_u
        dof = float(max(n_clusters - sums.coefs - int(use.sum()), 0))
    m_hat, m_se = float(coef[0]), float(np.sqrt(cov[0, 0])) if np.isfinite(cov[0, 0]) \
        else float("nan")
    b_hat, b_se = float(coef[1]), float(np.sqrt(cov[1, 1])) if np.isfinite(cov[1, 1]) \
        else float("nan")
    rate = b_hat if np.isfinite(b_hat) and dof > 0 and abs(b_hat) > RATE_SE * b_se else 0.0
    told = bool(np.isfinite(m_se) and dof > 0
                and 2 * float(special.stdtrit(dof, 0.975)) * m_se <= TOLD_WIDTH)
    return FittedLaw(m_hat, m_se, told, dof, rate, b_se, ref, spread)


def untold_note(subject: str, law: FittedLaw) -> WarningRecord:
    """Say of a subject whose presses do not tell how the friction grows with the load
    (``law-untold``).

    Parameters
    ----------
    subject : str
    law : FittedLaw
        Its law, as :func:`fit_subject_law` found it.

    Returns
    -------
    WarningRecord
        The warning said.
    """
    low, high = law.interval
    found = (f"m = {law.estimate:.2f} [{low:.2f}, {high:.2f}]" if np.isfinite(low)
             else "no spread of the normal force to fit m to")
    return emit("law-untold", Scope(str(subject)), found=found,
                sensitivity=SENSITIVITY_EXPONENT)
