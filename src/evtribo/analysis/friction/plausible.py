"""Results that physics rules out, and the rig file that most likely caused them.

A finger sliding on a screen presses steadily (the normal force is positive and keeps its
sign) while the friction changes sign with every stroke. A rig file that names the two cells
the other way round, or the same signal for both, gives numbers that look like results:
friction coefficients of 2-4, negative electrostatic forces. :func:`swapped_roles` looks at a
trial's forces for that evidence (the same that ``evtribo init`` guesses the roles from);
:func:`implausible_rows` looks at electrostatic.csv's rows for what no finger gives.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pandas as pd
from scipy import special  # stats.norm.cdf is special.ndtr, its inverse special.ndtri

from evtribo.util.running import moving_average
from evtribo.warning.collect import emitter
from evtribo.warning.record import Scope, WarningRecord

__all__ = ["FAMILY_ALPHA", "MAX_MU", "MIN_MU", "below_zero", "implausible_rows",
           "sign_behaviour", "swapped_roles"]

emit = emitter(__name__)

#: Friction coefficients of a fingertip on glass lie between these (Adams et al. 2013 and
#: Dzidek et al. 2017 measured 0.1-1.2; moist fingers reach the upper end).
MIN_MU, MAX_MU = 0.05, 1.5
#: Family-wise error rate of the study's check for forces below zero.
FAMILY_ALPHA = 0.05
#: A signal changes sign with the strokes at this many crossings a second or more.
STROKE_CROSSINGS_PER_S = 0.2
#: Hysteresis of a crossing: this share of the 90th percentile of |force|.
HYSTERESIS = 0.25


def sign_behaviour(x: npt.ArrayLike, rate_Hz: float) -> tuple[float, float]:
    """How a force keeps or changes its sign: the share of time it is positive and its
    crossings of zero per second (0.1-s means, with hysteresis).

    Parameters
    ----------
    x : array_like of float, N
        The force on a uniform grid (NaN in gaps).
    rate_Hz : float
        The grid's rate.

    Returns
    -------
    positive : float
        Share of the (0.1-s averaged) samples above zero.
    crossings_per_s : float
    """
    smooth = moving_average(x, max(1, round(0.1 * rate_Hz)), min_fraction=0.5)
    v = smooth[np.isfinite(smooth)]
    if v.size < 2:
        return float("nan"), float("nan")
    h = HYSTERESIS * float(np.percentile(np.abs(v), 90))
    state = np.where(v > h, 1, np.where(v < -h, -1, 0))
    state = state[state != 0]
    crossings = int(np.count_nonzero(np.diff(state))) if h > 0 else 0
    return float(np.mean(v > 0)), crossings * rate_Hz / v.size


def _strokes(positive: float, crossings: float) -> bool:
    return crossings >= STROKE_CROSSINGS_PER_S and 0.1 <= positive <= 0.9


def _steady(positive: float, crossings: float) -> bool:
    return crossings < STROKE_CROSSINGS_PER_S and (positive >= 0.9 or positive <= 0.1)


def swapped_roles(normal: npt.ArrayLike, tangential: npt.ArrayLike, rate_Hz: float
                  ) -> WarningRecord | None:
    """Say when the two cells' roles look swapped (``roles``): the signal named the normal
    force changes sign with the strokes while the one named the tangential force keeps its
    sign.

    Parameters
    ----------
    normal, tangential : array_like of float, N
        The forces as decoded (before any taring), on one uniform grid.
    rate_Hz : float

    Returns
    -------
    WarningRecord or None
        The warning said, if any.
    """
    pn, cn = sign_behaviour(normal, rate_Hz)
    pt, ct = sign_behaviour(tangential, rate_Hz)
    if not (_strokes(pn, cn) and _steady(pt, ct)):
        return None
    return emit("roles", normal_crossings=cn, normal_positive_pct=100 * pn,
                tangential_crossings=ct, tangential_positive_pct=100 * pt)


def below_zero(electrostatic: pd.DataFrame, alpha: float = FAMILY_ALPHA
               ) -> npt.NDArray[np.bool_]:
    """Which rows' electrostatic force is below zero beyond chance, over the whole table:
    each row's one-sided p-value of a force at or above zero (from its interval taken as
    a normal one), held to Holm's step-down at the family-wise level *alpha*, so that a
    study of many cells, every one of them truly at or above zero, flags one in no more
    than that share of studies (a 95 % interval alone misses below zero in 2.5 % of
    cells).

    Parameters
    ----------
    electrostatic : pandas.DataFrame
        electrostatic.csv's rows.
    alpha : float
        The family-wise error rate.

    Returns
    -------
    ndarray of bool
    """
    force = electrostatic.electrostatic_force_N.to_numpy(float)
    half = 0.5 * (electrostatic.electrostatic_force_ci_high_N.to_numpy(float)
                  - electrostatic.electrostatic_force_ci_low_N.to_numpy(float))
    with np.errstate(divide="ignore", invalid="ignore"):
        z = force / (half / special.ndtri(0.975))
    p = np.where(np.isfinite(z) & (half > 0), special.ndtr(z), np.where(force < 0, 0.0, 1.0))
    p = np.where(np.isfinite(force), p, 1.0)
    out = np.zeros(p.size, dtype=bool)
    for rank, i in enumerate(np.argsort(p, kind="stable")):
        if p[i] > alpha / (p.size - rank):
            break
        out[i] = True
    return out


def implausible_rows(electrostatic: pd.DataFrame) -> list[WarningRecord]:
    """Say what no finger gives: a subject's friction coefficient outside
    [:data:`MIN_MU`, :data:`MAX_MU`] (``mu-implausible``), an electrostatic force below zero
    beyond chance over the study's cells (:func:`below_zero`, ``negative-force``).

    Parameters
    ----------
    electrostatic : pandas.DataFrame
        electrostatic.csv's rows.

    Returns
    -------
    list of WarningRecord
        The warnings said.
    """
    out: list[WarningRecord] = []
    if electrostatic.empty:
        return out
    flagged = below_zero(electrostatic)
    for subject, rows in electrostatic.groupby("subject", sort=True):
        mu = float(np.nanmedian(rows.mu.to_numpy(float)))
        if not MIN_MU <= mu <= MAX_MU:
            out.append(emit("mu-implausible", Scope(str(subject)), mu=mu, mu_low=MIN_MU,
                            mu_high=MAX_MU))
        below = rows[flagged[electrostatic.index.get_indexer(rows.index)]]
        if len(below):
            amps = ", ".join(f"{a:g} V" for a in below.amplitude_V)
            out.append(emit("negative-force", Scope(str(subject)), amplitudes=amps,
                            cells=len(electrostatic), alpha_pct=100 * FAMILY_ALPHA))
    return out
