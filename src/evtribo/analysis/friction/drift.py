"""How the friction coefficient moved within a subject's trials, and what the analysis says
of it.

Every trial with enough OFF windows gets ``mu_change_per_10s`` in trials.csv: the change of
its OFF windows' friction coefficient per 10 s of the trial, from the model of
:mod:`evtribo.analysis.friction.reference` fitted to them with a trend in time (0 when no trend
is supported). The notes say what such changes, differences between directions and
between strokes do to the electrostatic force, and what the analysis did about them.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pandas as pd

from evtribo.analysis.friction.reference import MuModel, fit_mu_model
from evtribo.analysis.friction.window_facts import (
    MAX_DEGREE,
    SPAN_PER_DEGREE_S,
    WindowFacts,
    time_basis,
)
from evtribo.errors import AnalysisError
from evtribo.model.friction_law import AMONTONS, LoadLaw
from evtribo.warning.collect import emitter
from evtribo.warning.record import Scope, WarningRecord

__all__ = [
    "CONFOUNDED",
    "MAX_PHASE_LENGTHS",
    "MAX_PHASE_SAMPLES",
    "MIN_OFF_WINDOWS",
    "NOTABLE_CHANGE",
    "NOTABLE_SE",
    "TrialDrift",
    "clear_phase_s",
    "drift_notes",
    "phase_confounding",
    "phase_notes",
    "relative_scatter",
    "stroke_notes",
    "trial_confounding",
    "trial_drifts",
    "window_facts",
]

emit = emitter(__name__)

FloatArray = npt.NDArray[np.float64]

#: Fewest OFF windows a trial needs for its ``mu_change_per_10s``.
MIN_OFF_WINDOWS = 6
#: A change of mu over a trial, relative to mu, worth a note.
NOTABLE_CHANGE = 0.05
#: ... when it also stands this many standard errors from zero (a trend the model's terms
#: chose from noise is no change of the finger).
NOTABLE_SE = 3.0
#: An alternating trial's phases are too long when a drift of mu and the ON phases share so
#: much that F_el's variance grows by this factor (its standard error by its root, 1.4).
CONFOUNDED = 2.0
#: The phase length suggested instead keeps the variance's growth within this factor.
CLEAR = 1.3


def window_facts(frame: pd.DataFrame) -> WindowFacts:
    """The facts of the windows of *frame* (windows.csv's columns): each window's middle in
    its trial, direction, stroke rate, stroke (numbered across trials) and trial.

    Parameters
    ----------
    frame : pandas.DataFrame
        Windows; their times, ``direction``, ``stroke`` and ``stroke_s`` are optional.

    Returns
    -------
    WindowFacts
    """
    n = len(frame)
    t = (0.5 * (frame.t_start_s.to_numpy(float) + frame.t_end_s.to_numpy(float))
         if {"t_start_s", "t_end_s"} <= set(frame.columns) else np.full(n, np.nan))
    direction = (frame.direction.to_numpy(float) if "direction" in frame
                 else np.zeros(n))
    with np.errstate(divide="ignore", invalid="ignore"):
        rate = (-np.log(frame.stroke_s.to_numpy(float)) if "stroke_s" in frame
                else np.full(n, np.nan))
    names = frame.trial.astype(str) if "trial" in frame else pd.Series([""] * n)
    trial = np.array([zlib.crc32(name.encode()) for name in names], dtype=np.int64)
    # a window's stroke, numbered alike in every frame of the same windows: its trial's
    # checksum and its number there (a window without one is a stroke of its own)
    stroke = (frame.stroke.to_numpy(float) if "stroke" in frame else np.full(n, -1.0))
    own = -1 - np.asarray(frame.index, dtype=np.int64)
    known = np.isfinite(stroke) & (stroke >= 0)
    cluster = np.where(known, trial * (1 << 20) + np.where(known, stroke, 0).astype(np.int64),
                       own)
    return WindowFacts(t, np.nan_to_num(direction), np.where(np.isfinite(rate), rate, np.nan),
                       cluster, trial)


@dataclass(frozen=True)
class TrialDrift:
    """One trial's friction coefficient over its OFF windows.

    Attributes
    ----------
    change_per_10s : float
        Change of mu per 10 s (0 without a supported trend).
    relative : float
        Its change over the OFF windows' span, relative to their mean mu.
    mu : float
        The mean of the model over the trial's OFF windows.
    model : MuModel
    relative_se : float
        Standard error of :attr:`relative`.
    """

    change_per_10s: float
    relative: float
    mu: float
    model: MuModel
    relative_se: float = 0.0

    @property
    def notable(self) -> bool:
        """Whether the change is worth a note: :data:`NOTABLE_CHANGE` of ``mu`` or more,
        and :data:`NOTABLE_SE` standard errors from zero."""
        return (abs(self.relative) >= NOTABLE_CHANGE
                and abs(self.relative) >= NOTABLE_SE * self.relative_se)


def trial_drifts(off: pd.DataFrame, models: dict[object, MuModel] | None = None, *,
                 rate_slope: float = 0.0, law: LoadLaw = AMONTONS
                 ) -> dict[object, TrialDrift]:
    """Each trial's drift of mu, from its OFF windows, at a constant stroke pace and press
    (the subject's friction law's terms taken out, so that strokes that slow down over a
    trial, or a press that wanders, are not taken for a finger that dries).

    Parameters
    ----------
    off : pandas.DataFrame
        A subject's OFF windows (windows.csv's columns).
    models : dict, optional
        Models already fitted to a trial's OFF windows alone (its alternating reference),
        by trial name: used as they are.
    rate_slope : float
        The subject's stroke rate's term
        (:class:`~evtribo.analysis.friction.laws.fit.FittedLaw`).
    law : LoadLaw
        Its friction law's load term, as its forces use it
        (:class:`~evtribo.analysis.friction.laws.choice.ChosenLaw`).

    Returns
    -------
    dict
        By trial name; trials with fewer than :data:`MIN_OFF_WINDOWS` OFF windows are
        left out.
    """
    out: dict[object, TrialDrift] = {}
    for trial, rows in off.groupby("trial", sort=False):
        if len(rows) < MIN_OFF_WINDOWS:
            continue
        facts = window_facts(rows)
        model = (models or {}).get(trial)
        if model is None:
            try:
                model = fit_mu_model(rows.normal_force_N, rows.friction_force_N, facts,
                                     time_trend=True, rate_slope=rate_slope, law=law)
            except AnalysisError:
                continue
        mu = float(np.mean(model.at(facts)))
        per_s = model.change_per_s()
        span = model.t_hi - model.t_lo
        out[trial] = TrialDrift(10.0 * per_s, per_s * span / mu if mu > 0 else 0.0, mu,
                                model, model.change_se() * span / mu if mu > 0 else 0.0)
    return out


def drift_notes(subject: str, drifts: dict[object, TrialDrift], *, compared_in_trial: bool,
                on_trials_alone: list[object]) -> list[WarningRecord]:
    """Say what a subject's drifts are worth saying (``drift-followed``,
    ``drift-unseen``).

    Parameters
    ----------
    subject : str
    drifts : dict
        :func:`trial_drifts`.
    compared_in_trial : bool
        Whether ON windows were compared with their own trial's OFF windows (alternating
        trials).
    on_trials_alone : list
        Trials whose ON windows were compared with other trials' OFF windows.

    Returns
    -------
    list of WarningRecord
        The warnings said.
    """
    notable = {t: d for t, d in drifts.items() if d.notable}
    if not notable:
        return []
    worst = max(notable, key=lambda t: abs(notable[t].relative))
    rel = np.array([d.relative for d in notable.values()])
    said = {"changed": len(notable), "trials": len(drifts),
            "change_pct": 100 * notable[worst].relative, "worst": str(worst),
            "direction": "rising" if np.median(rel) > 0 else "falling",
            "same": int(np.sum(np.sign(rel) == np.sign(np.median(rel))))}
    notes = []
    if compared_in_trial:
        notes.append(emit("drift-followed", Scope(str(subject)), **said))
    if on_trials_alone:
        notes.append(emit("drift-unseen", Scope(str(subject)), **said,
                          on_trials=", ".join(str(t) for t in on_trials_alone[:4])))
    return notes


def stroke_notes(subject: str, models: dict[int, MuModel], off_ratio_sd: float,
                 rate_gap: float | None) -> list[WarningRecord]:
    """Say what a subject's references say of friction that differs between strokes
    (``pace``, ``mu-scatter``).

    Parameters
    ----------
    subject : str
    models : dict
        The subject's reference models.
    off_ratio_sd : float
        Relative standard deviation of the OFF windows' friction coefficient about their
        models.
    rate_gap : float or None
        Relative difference of the ON strokes' rate from the OFF strokes' (None: unknown).

    Returns
    -------
    list of WarningRecord
        The warnings said.
    """
    notes = []
    if any(m.rate for m in models.values()):
        slower = ("" if rate_gap is None or abs(rate_gap) < 0.1 else
                  f"; the ON strokes were {100 * abs(rate_gap):.0f} % "
                  f"{'slower' if rate_gap < 0 else 'faster'} than the OFF ones")
        notes.append(emit("pace", Scope(str(subject)), slower=slower))
    elif off_ratio_sd > 0.03:
        notes.append(emit("mu-scatter", Scope(str(subject)), scatter_pct=100 * off_ratio_sd))
    return notes


def relative_scatter(models: dict[int, MuModel], ratios: dict[int, npt.NDArray[np.float64]]
                     ) -> float:
    """Relative standard deviation of the OFF windows' ``F_t/F_n`` about their models.

    Parameters
    ----------
    models : dict
        Reference models by index.
    ratios : dict
        Each reference's OFF windows' ``F_t/F_n``.

    Returns
    -------
    float
    """
    parts = []
    for r, model in models.items():
        if r in ratios and ratios[r].size > model.coef.size + 1:
            resid = model.resid  # CR2-scaled residuals: of log(F_t/F_n), or of the ratio
            parts.append(resid if model.log else resid / np.mean(ratios[r]))
    return float(np.std(np.concatenate(parts))) if parts else 0.0


def _degree(span_s: float) -> int:
    """The highest degree of drift a trial of *span_s* seconds is fitted with."""
    return max(1, min(MAX_DEGREE, int(span_s // SPAN_PER_DEGREE_S)))


def phase_confounding(t_s: npt.ArrayLike, group: npt.ArrayLike,
                      weight: npt.ArrayLike | None = None) -> float:
    """How much a drift of the friction in time and the ON phases of an alternating trial
    are confounded: the factor by which the variance of an ON group's level grows when a
    polynomial drift of the degree the trial's span allows is fitted beside it (the
    variance inflation of ordinary regression; 1: the design tells them apart).

    Parameters
    ----------
    t_s : array_like of float, s
        The trial's windows' times, OFF and ON.
    group : array_like of float
        Each window's ON group (NaN: OFF).
    weight : array_like of float, optional
        The fit's weights (the windows' normal forces).

    Returns
    -------
    float
        The largest factor over the ON groups (1 without ON windows or times).
    """
    t = np.asarray(t_s, dtype=np.float64)
    g = np.asarray(group, dtype=np.float64)
    w = np.ones(t.size) if weight is None else np.asarray(weight, dtype=np.float64)
    if t.size < 4 or not np.isfinite(t).all() or np.ptp(t) <= 0:
        return 1.0
    groups = np.unique(g[np.isfinite(g)])
    if groups.size == 0 or not (~np.isfinite(g)).any():
        return 1.0
    on = np.column_stack([(g == x).astype(np.float64) for x in groups])
    trend = time_basis(t, float(t.min()), float(t.max()), _degree(float(np.ptp(t))))
    sw = np.sqrt(w)[:, None]

    def variances(cols: list[FloatArray]) -> FloatArray:
        X = np.column_stack(cols) * sw
        try:
            return np.asarray(np.diag(np.linalg.pinv(X.T @ X))[-groups.size:])
        except np.linalg.LinAlgError:
            return np.full(groups.size, np.inf)

    plain = variances([np.ones(t.size), on])
    full = variances([np.ones(t.size), trend, on])
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(plain > 0, full / plain, np.inf)
    return float(np.max(ratio))


#: Most times sampled, and most phase lengths tried, by :func:`clear_phase_s`: a trial's
#: span is the clock's, which a jump of the logger's clock can make a day long, and the
#: search costs no more for it than for a trial of 400 s.
MAX_PHASE_SAMPLES = 4000
MAX_PHASE_LENGTHS = 400


def clear_phase_s(span_s: float, guard_s: float = 0.15) -> float:
    """The longest ON/OFF phase (a grid of 0.5-s steps) with which a trial of *span_s*
    seconds keeps the drift apart from the ON effect (:func:`phase_confounding` within
    :data:`CLEAR`), sampled every 0.1 s outside the guards about each switch.

    A trial longer than 400 s is sampled and searched on grids coarser in proportion
    (:data:`MAX_PHASE_SAMPLES` times, :data:`MAX_PHASE_LENGTHS` lengths, each a multiple
    of 0.5 s): the confounding depends on the phases' share of the span, and the search's
    cost stays that of a 400-s trial however long the span.

    Parameters
    ----------
    span_s : float, s
    guard_s : float, s

    Returns
    -------
    float, s
    """
    if not np.isfinite(span_s) or span_s <= 0:
        return 0.5
    dt = max(0.1, span_s / MAX_PHASE_SAMPLES)
    t = np.arange(0.5 * dt, span_s, dt)
    step = 0.5 * max(1.0, np.ceil(span_s / (2 * MAX_PHASE_LENGTHS) / 0.5))
    best = 0.5
    for length in np.arange(step, span_s / 2 + 1e-9, step):
        phase = np.floor(t / length)
        edge = np.minimum(t - phase * length, (phase + 1) * length - t)
        keep = edge > guard_s
        group = np.where(phase % 2 == 1, 1.0, np.nan)
        if phase_confounding(t[keep], group[keep]) <= CLEAR:
            best = float(length)
    return best


def phase_notes(subject: str, confounded: dict[object, tuple[float, float]]
                ) -> list[WarningRecord]:
    """Say of a subject whose alternating trials' phases are too long to tell a drift of
    the friction from the voltage's effect (``long-phases``).

    Parameters
    ----------
    subject : str
    confounded : dict
        ``{trial: (phase_confounding, span_s)}`` of its alternating trials.

    Returns
    -------
    list of WarningRecord
        The warning said, if any.
    """
    bad = {t: v for t, v in confounded.items() if v[0] >= CONFOUNDED}
    if not bad:
        return []
    worst = max(v[0] for v in bad.values())
    span = float(np.median([v[1] for v in bad.values()]))
    names = ", ".join(str(t) for t in list(bad)[:4]) + (", ..." if len(bad) > 4 else "")
    return [emit("long-phases", Scope(str(subject)), trials=names, widening=float(np.sqrt(worst)),
                 trial_s=span, phase_s=clear_phase_s(span))]


def trial_confounding(windows: pd.DataFrame) -> dict[object, tuple[float, float]]:
    """Each trial's :func:`phase_confounding` and its windows' span, s.

    Parameters
    ----------
    windows : pandas.DataFrame
        A subject's windows of its alternating trials (windows.csv's columns).

    Returns
    -------
    dict
        ``{trial: (factor, span_s)}``.
    """
    out: dict[object, tuple[float, float]] = {}
    if not {"t_start_s", "t_end_s"} <= set(windows.columns):
        return out
    for trial, rows in windows.groupby("trial", sort=False):
        t = 0.5 * (rows.t_start_s.to_numpy(float) + rows.t_end_s.to_numpy(float))
        on = (rows.condition == "on").to_numpy()
        group = np.where(on, pd.factorize(rows.amplitude_V)[0].astype(float), np.nan)
        if np.isfinite(t).all() and t.size >= 4:
            out[trial] = (phase_confounding(t, group, rows.normal_force_N.to_numpy(float)),
                          float(np.ptp(t)))
    return out
