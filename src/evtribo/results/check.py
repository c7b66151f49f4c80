"""A check of one trial: what its analysis used and what it left out, and why.

:func:`check_trial` decodes a trial of a study through the cache and analyses it with the
study's settings, as ``evtribo analyze`` does (:func:`~evtribo.analysis.trial.
analyze_signals`, the same code), keeping what each continuous piece worked on
(:class:`~evtribo.analysis.observed.PieceState`): the forces as tared, the ON/OFF condition
of every grid point, the finger-lifted stretches and the steady-sliding windows. Its windows
are those of ``windows.csv`` when the study has not changed since it was analysed.

:func:`excluded_stretches` names what no window may use: the guard times around ON/OFF
switches, stretches whose state no status frame tells, the finger leaving or touching down
around a lifted stretch, holes in the load cells' data and pauses of the log.
Everything else outside the windows is what the window search found not to be steady
sliding (reversals, rests, stick phases; :mod:`evtribo.analysis.friction.windows`).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from evtribo.analysis.forces.conditions import EXCLUDED, OFF, ON
from evtribo.analysis.forces.lifted import EDGE_S
from evtribo.analysis.friction.windows import true_runs
from evtribo.analysis.heard import heard_warnings
from evtribo.analysis.observed import PieceState
from evtribo.analysis.settings import AnalysisSettings
from evtribo.analysis.trial import TrialMeta, analyze_signals, trial_start
from evtribo.canlog.cache import load_trial
from evtribo.canlog.rig import Calibration
from evtribo.canlog.signals import TrialSignals
from evtribo.errors import SidecarError, StudyError, UserInputError
from evtribo.results.pipeline import study_settings
from evtribo.results.workers import trial_meta
from evtribo.study import Study, TrialRef, load_study

__all__ = ["MIN_HOLE_S", "STRETCH_LABELS", "Stretch", "TrialCheck", "check_signals", "check_trial",
           "excluded_stretches", "find_trial", "settings_of", "trial_signals"]

#: Holes in the load cells' data, and stretches of unknown state, shorter than this are not
#: listed (a frame or two lost; the moment before the amplifier's first status frame), s.
MIN_HOLE_S = 0.02

#: What each kind of :class:`Stretch` is, in a few words (a figure's legend).
STRETCH_LABELS = {
    "lifted": "finger lifted: zero read",
    "lift-edge": "finger leaving / touching down",
    "switch": "ON/OFF switch (guard)",
    "unknown": "ON/OFF unknown (no status)",
    "hole": "load-cell frames missing",
    "pause": "pause in the log",
}


@dataclass(frozen=True)
class Stretch:
    """A stretch of a trial that the windows do not use, and why.

    Attributes
    ----------
    t_start, t_end : float, s
        From the trial's start.
    kind : str
        A key of :data:`STRETCH_LABELS`: ``lifted`` (the zero was read there), ``lift-edge``,
        ``switch``, ``unknown``, ``hole`` or ``pause``.
    """

    t_start: float
    t_end: float
    kind: str

    @property
    def label(self) -> str:
        """What the stretch is, in a few words."""
        return STRETCH_LABELS[self.kind]


@dataclass
class TrialCheck:
    """A trial as its analysis saw it.

    Attributes
    ----------
    subject, trial : str
        The trial's names.
    t0 : float, s
        The trial's start on the log's clock (window times count from it).
    pieces : list of PieceState
        Each continuous piece analysed, in order.
    windows : pandas.DataFrame
        The trial's rows of ``windows.csv``.
    row : dict
        Its row of ``trials.csv``.
    warnings : list of str
        What its analysis warned of.
    """

    subject: str
    trial: str
    t0: float
    pieces: list[PieceState]
    windows: pd.DataFrame
    row: dict[str, Any]
    warnings: list[str] = field(default_factory=list)

    @property
    def key(self) -> str:
        """``subject/trial``."""
        return f"{self.subject}/{self.trial}"


def check_signals(signals: TrialSignals, meta: TrialMeta, *,
                  settings: AnalysisSettings | None = None,
                  calibration: Calibration | None = None) -> TrialCheck:
    """Analyse a decoded trial as ``evtribo analyze`` does and keep what it worked on.

    Parameters
    ----------
    signals : TrialSignals
        The decoded trial.
    meta : TrialMeta
        Its names and sidecar values.
    settings : AnalysisSettings, optional
        The analysis settings (default: the package's).
    calibration : Calibration, optional
        The rig's ``[rig.calibration]``.

    Returns
    -------
    TrialCheck

    Raises
    ------
    AnalysisError
        The trial cannot be analysed.
    """
    pieces: list[PieceState] = []
    result = analyze_signals(signals, meta, settings=settings, calibration=calibration,
                             observe=pieces.append)
    return TrialCheck(subject=meta.subject, trial=meta.trial, t0=trial_start(signals),
                      pieces=pieces, windows=result.windows, row=result.row,
                      warnings=result.warnings)


def find_trial(study: Study, subject: str, trial: str) -> TrialRef:
    """The trial *subject*/*trial* of a study.

    Parameters
    ----------
    study : Study
        The loaded study.
    subject, trial : str
        The names.

    Returns
    -------
    TrialRef

    Raises
    ------
    StudyError
        No such subject or trial, naming those there are.
    """
    subjects = study.subjects
    if subject not in subjects:
        raise StudyError(f"no subject {subject!r}; its subjects: {', '.join(subjects) or 'none'}",
                         path=study.root)
    trials = [t for t in study.trials if t.subject == subject]
    for ref in trials:
        if ref.name == trial:
            return ref
    raise StudyError(f"subject {subject} has no trial {trial!r}; its trials: "
                     f"{', '.join(t.name for t in trials)}", path=study.root / subject)


def settings_of(study: Study, settings: AnalysisSettings | Mapping[str, Any] | None
                ) -> AnalysisSettings:
    """The settings to analyse a study's trials with.

    Parameters
    ----------
    study : Study
        The study (its ``[analysis]`` table).
    settings : AnalysisSettings or mapping or None
        None: the study's (the package's defaults, then ``[analysis]``); settings: those; a
        mapping (``summary.json``'s ``settings``, say): its keys that are settings, on the
        package's defaults (the others, such as ``mu_estimator``, are descriptions).

    Returns
    -------
    AnalysisSettings
    """
    if settings is None:
        return study_settings(study)
    if isinstance(settings, AnalysisSettings):
        return settings
    names = {f.name for f in dataclasses.fields(AnalysisSettings)}
    values = {k: (tuple(v) if isinstance(v, list) else v) for k, v in settings.items()
              if k in names}
    return AnalysisSettings().updated(values, table="settings")


def trial_signals(ref: TrialRef, study: Study, cache_dir: str | os.PathLike[str] | None = None
                  ) -> TrialSignals:
    """The trial's decoded signals, from the channel its sidecar names (as analyze reads
    them).

    Parameters
    ----------
    ref : TrialRef
        The trial.
    study : Study
        Its study.
    cache_dir : path-like, optional
        The decoded-trial cache.

    Returns
    -------
    TrialSignals
    """
    assert study.rig is not None
    channel = ref.sidecar.extra.get("log_channel")
    channel = channel if isinstance(channel, str) and channel else None
    try:
        return load_trial(ref.log_path, study.rig, cache_dir, channel=channel)
    except UserInputError as err:
        if channel is None or err.key != "channel":
            raise
        raise SidecarError(err.message, path=ref.sidecar_path, key="log_channel") from err


def check_trial(study: Study | str | os.PathLike[str], subject: str, trial: str, *,
                settings: AnalysisSettings | Mapping[str, Any] | None = None,
                cache_dir: str | os.PathLike[str] | None = None) -> TrialCheck:
    """Check one trial of a study: decode it through the cache, analyse it with the study's
    settings, keep what the analysis worked on. What the analysis warns of is kept in the
    check's ``warnings`` and logged as debug messages only (``evtribo analyze`` says it).

    Parameters
    ----------
    study : Study or path-like
        The study, or its folder.
    subject, trial : str
        The trial.
    settings : AnalysisSettings or mapping, optional
        As :func:`settings_of` takes them (default: the study's).
    cache_dir : path-like, optional
        The decoded-trial cache (default: ``$EVTRIBO_CACHE_DIR`` or ``~/.cache/evtribo``).

    Returns
    -------
    TrialCheck

    Raises
    ------
    StudyError
        No such study, subject or trial.
    AnalysisError
        The trial cannot be analysed.
    """
    if not isinstance(study, Study):
        study = load_study(Path(study))
    ref = find_trial(study, subject, trial)
    assert study.rig is not None
    with heard_warnings():  # evtribo analyze said them; the check keeps them in .warnings
        return check_signals(trial_signals(ref, study, cache_dir), trial_meta(ref),
                             settings=settings_of(study, settings),
                             calibration=study.rig.calibration)


def _runs_of(mask: npt.NDArray[np.bool_], t: npt.NDArray[np.float64], dt: float
             ) -> list[tuple[int, int, float, float]]:
    """``(i0, i1, t_start, t_end)`` of the runs of True in *mask*."""
    return [(a, b, float(t[a]), float(t[b - 1] + dt)) for a, b in true_runs(mask)]


def _condition_stretches(piece: PieceState, t: npt.NDArray[np.float64], dt: float
                         ) -> list[Stretch]:
    """Guard times around switches, and where no status frame tells the state."""
    cond = piece.condition
    out = []
    for a, b, t_start, t_end in _runs_of(cond == EXCLUDED, t, dt):
        before = int(cond[a - 1]) if a > 0 else EXCLUDED
        after = int(cond[b]) if b < cond.size else EXCLUDED
        kind = "switch" if {before, after} == {ON, OFF} else "unknown"
        if kind == "switch" or t_end - t_start >= MIN_HOLE_S:
            out.append(Stretch(t_start, t_end, kind))
    return out


def _lift_stretches(piece: PieceState, t0: float, span: tuple[float, float]) -> list[Stretch]:
    """The finger-lifted stretches and the margins around them that no window uses."""
    out = []
    lo, hi = span
    for s in piece.lifted:
        a, b = s.t_start - t0, s.t_end - t0
        out.append(Stretch(a, b, "lifted"))
        if a > lo:
            out.append(Stretch(max(lo, a - 2 * EDGE_S), a, "lift-edge"))
        if b < hi:
            out.append(Stretch(b, min(hi, b + 2 * EDGE_S), "lift-edge"))
    return out


def excluded_stretches(check: TrialCheck) -> list[Stretch]:
    """What the windows of a trial could not use, and why, in time order.

    Parameters
    ----------
    check : TrialCheck
        The trial's check.

    Returns
    -------
    list of Stretch
        Lifted stretches (where the zero was read) and the finger leaving or touching down
        around them, guard times around ON/OFF switches, stretches of unknown state and holes
        in the load cells' data of at least :data:`MIN_HOLE_S`, and pauses between the
        pieces of a trial; times from the trial's start.
    """
    out: list[Stretch] = []
    previous_end = None
    for piece in check.pieces:
        f = piece.forces
        if f.t.size == 0:
            continue
        dt = 1.0 / f.rate_Hz
        t = f.t - check.t0
        span = (float(t[0]), float(t[-1] + dt))
        if previous_end is not None and span[0] > previous_end:
            out.append(Stretch(previous_end, span[0], "pause"))
        previous_end = span[1]
        out += _condition_stretches(piece, t, dt)
        out += _lift_stretches(piece, check.t0, span)
        hole = ~(np.isfinite(f.normal) & np.isfinite(f.tangential))
        out += [Stretch(a, b, "hole") for _, _, a, b in _runs_of(hole, t, dt)
                if b - a >= MIN_HOLE_S]
    return sorted(out, key=lambda s: (s.t_start, s.t_end))
