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

from evtribo.analysis.friction.facts import WindowFacts
from evtribo.analysis.friction.reference import MuModel, fit_mu_model
from evtribo.errors import AnalysisError

__all__ = ["MIN_OFF_WINDOWS", "NOTABLE_CHANGE", "TrialDrift", "drift_notes", "relative_scatter",
           "stroke_notes", "trial_drifts", "window_facts"]

#: Fewest OFF windows a trial needs for its ``mu_change_per_10s``.
MIN_OFF_WINDOWS = 6
#: A change of mu over a trial, relative to mu, worth a note.
NOTABLE_CHANGE = 0.05


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
    """

    change_per_10s: float
    relative: float
    mu: float
    model: MuModel


def trial_drifts(off: pd.DataFrame, models: dict[object, MuModel] | None = None
                 ) -> dict[object, TrialDrift]:
    """Each trial's drift of mu, from its OFF windows.

    Parameters
    ----------
    off : pandas.DataFrame
        A subject's OFF windows (windows.csv's columns).
    models : dict, optional
        Models already fitted to a trial's OFF windows alone (its alternating reference),
        by trial name: used as they are.

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
                                     time_trend=True)
            except AnalysisError:
                continue
        mu = float(np.mean(model.at(facts)))
        per_s = model.change_per_s()
        span = model.t_hi - model.t_lo
        out[trial] = TrialDrift(10.0 * per_s, per_s * span / mu if mu > 0 else 0.0, mu,
                                model)
    return out


def drift_notes(subject: str, drifts: dict[object, TrialDrift], *, compared_in_trial: bool,
                on_trials_alone: list[object]) -> list[str]:
    """What a subject's drifts are worth saying.

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
    list of str
    """
    notable = {t: d for t, d in drifts.items() if abs(d.relative) >= NOTABLE_CHANGE}
    if not notable:
        return []
    worst = max(notable, key=lambda t: abs(notable[t].relative))
    rel = np.array([d.relative for d in notable.values()])
    text = (f"{subject}: the friction coefficient changed within {len(notable)} of "
            f"{len(drifts)} trials (by {100 * notable[worst].relative:+.0f} % over trial "
            f"{worst}; {'rising' if np.median(rel) > 0 else 'falling'} in "
            f"{int(np.sum(np.sign(rel) == np.sign(np.median(rel))))}: a fingertip "
            "moistening or drying)")
    notes = []
    if compared_in_trial:
        notes.append(text + "; each ON window was compared with its trial's OFF friction at "
                     "its own time (mu_change_per_10s in trials.csv)")
    if on_trials_alone:
        names = ", ".join(str(t) for t in on_trials_alone[:4])
        notes.append(text + f"; trials {names} are ON throughout and were compared with "
                     "other trials' OFF windows, so such a change goes into their "
                     "electrostatic force unseen: alternate ON and OFF within each trial")
    return notes


def stroke_notes(subject: str, models: dict[int, MuModel], off_ratio_sd: float,
                 rate_gap: float | None) -> list[str]:
    """What a subject's references say of friction that differs between strokes.

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
    list of str
    """
    notes = []
    if any(m.rate for m in models.values()):
        slower = ("" if rate_gap is None or abs(rate_gap) < 0.1 else
                  f"; the ON strokes were {100 * abs(rate_gap):.0f} % "
                  f"{'slower' if rate_gap < 0 else 'faster'} than the OFF ones")
        notes.append(f"{subject}: the friction follows the strokes' pace (faster strokes, "
                     f"other friction){slower}; each ON window was compared with the OFF "
                     "friction at its own stroke's pace (docs/analysis.md, \"Speed and "
                     "direction\")")
    elif off_ratio_sd > 0.03:
        notes.append(f"{subject}: the OFF windows' friction coefficient scatters by "
                     f"{100 * off_ratio_sd:.0f} % between strokes (speed, posture) beyond "
                     "what the strokes' pace explains; the intervals include it: strokes of "
                     "an even pace and length narrow them")
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
            resid = model.resid  # HC2-scaled residuals of the ratio
            parts.append(resid / np.mean(ratios[r]))
    return float(np.std(np.concatenate(parts))) if parts else 0.0
