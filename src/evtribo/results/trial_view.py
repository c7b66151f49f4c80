"""A view of one trial: what its analysis used and what it left out, and why.

:func:`view_trial` decodes a trial of a study through the cache and analyses it with the
study's settings, as ``evtribo analyze`` does (:func:`~evtribo.analysis.trial.
analyze_signals`, the same code), keeping what each continuous piece worked on
(:class:`~evtribo.analysis.piece_observer.PieceState`): the forces as tared, the ON/OFF condition
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

import pandas as pd

from evtribo.analysis.piece_observer import PieceState
from evtribo.analysis.settings import AnalysisSettings
from evtribo.analysis.trial import TrialMeta, analyze_signals, trial_start
from evtribo.canlog.cache import load_trial
from evtribo.canlog.rig import Calibration
from evtribo.canlog.signals import TrialSignals
from evtribo.errors import SidecarError, StudyError, UserInputError
from evtribo.results.pipeline import study_settings
from evtribo.results.reuse import OutcomeStore, analysis_context
from evtribo.results.trial_sketch import (
    MIN_HOLE_S,
    STRETCH_LABELS,
    Sketcher,
    Stretch,
    TrialSketch,
)
from evtribo.results.workers import trial_meta
from evtribo.store.memo import default_cache_dir
from evtribo.study import StudyFolder, TrialRef, load_study
from evtribo.warning.collect import collecting
from evtribo.warning.record import Scope, WarningRecord

__all__ = ["MIN_HOLE_S", "STRETCH_LABELS", "Stretch", "TrialView", "excluded_stretches",
           "find_trial", "kept_sketches", "settings_of", "sketch_of", "trial_signals",
           "view_signals", "view_trial"]

@dataclass
class TrialView:
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
    warnings : list of WarningRecord
        What its decoding and analysis warned of.
    """

    subject: str
    trial: str
    t0: float
    pieces: list[PieceState]
    windows: pd.DataFrame
    row: dict[str, Any]
    warnings: list[WarningRecord] = field(default_factory=list)

    @property
    def key(self) -> str:
        """``subject/trial``."""
        return f"{self.subject}/{self.trial}"


def view_signals(signals: TrialSignals, meta: TrialMeta, *,
                  settings: AnalysisSettings | None = None,
                  calibration: Calibration | None = None) -> TrialView:
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
    TrialView

    Raises
    ------
    AnalysisError
        The trial cannot be analysed.
    """
    pieces: list[PieceState] = []
    result = analyze_signals(signals, meta, settings=settings, calibration=calibration,
                             observe=pieces.append)
    return TrialView(subject=meta.subject, trial=meta.trial, t0=trial_start(signals),
                     pieces=pieces, windows=result.windows, row=result.row,
                     warnings=result.warnings)


def find_trial(study: StudyFolder, subject: str, trial: str) -> TrialRef:
    """The trial *subject*/*trial* of a study.

    Parameters
    ----------
    study : StudyFolder
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


def settings_of(study: StudyFolder, settings: AnalysisSettings | Mapping[str, Any] | None
                ) -> AnalysisSettings:
    """The settings to analyse a study's trials with.

    Parameters
    ----------
    study : StudyFolder
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


def trial_signals(ref: TrialRef, study: StudyFolder, cache_dir: str | os.PathLike[str] | None = None
                  ) -> TrialSignals:
    """The trial's decoded signals, from the channel its sidecar names (as analyze reads
    them).

    Parameters
    ----------
    ref : TrialRef
        The trial.
    study : StudyFolder
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


def view_trial(study: StudyFolder | str | os.PathLike[str], subject: str, trial: str, *,
                settings: AnalysisSettings | Mapping[str, Any] | None = None,
                cache_dir: str | os.PathLike[str] | None = None) -> TrialView:
    """Check one trial of a study: decode it through the cache, analyse it with the study's
    settings, keep what the analysis worked on. What the analysis warns of is kept in the
    check's ``warnings`` and not said again (``evtribo analyze`` says it).

    Parameters
    ----------
    study : StudyFolder or path-like
        The study, or its folder.
    subject, trial : str
        The trial.
    settings : AnalysisSettings or mapping, optional
        As :func:`settings_of` takes them (default: the study's).
    cache_dir : path-like, optional
        The decoded-trial cache (default: ``$EVTRIBO_CACHE_DIR`` or ``~/.cache/evtribo``).

    Returns
    -------
    TrialView

    Raises
    ------
    StudyError
        No such study, subject or trial.
    AnalysisError
        The trial cannot be analysed.
    """
    if not isinstance(study, StudyFolder):
        study = load_study(Path(study))
    ref = find_trial(study, subject, trial)
    assert study.rig is not None
    # evtribo analyze said them; the check keeps them in .warnings
    with collecting(Scope(subject, trial), quiet=True):
        return view_signals(trial_signals(ref, study, cache_dir), trial_meta(ref),
                             settings=settings_of(study, settings),
                             calibration=study.rig.calibration)


def excluded_stretches(check: TrialView) -> list[Stretch]:
    """What the windows of a trial could not use, and why, in time order.

    Parameters
    ----------
    check : TrialView
        The trial's check.

    Returns
    -------
    list of Stretch
        Lifted stretches (where the zero was read) and the finger leaving or touching down
        around them, guard times around ON/OFF switches, stretches of unknown state and holes
        in the load cells' data of at least :data:`MIN_HOLE_S`, and pauses between the
        pieces of a trial; times from the trial's start.
    """
    return sketch_of(check).stretches


def sketch_of(check: TrialView) -> TrialSketch:
    """What the figure of a trial's check draws, from the check (as analyze keeps it).

    Parameters
    ----------
    check : TrialView
        The trial's check.

    Returns
    -------
    TrialSketch
    """
    sketcher = Sketcher(check.t0)
    for piece in check.pieces:
        sketcher(piece)
    return sketcher.sketch(check.subject, check.trial, check.row)


def _relative(path: str | os.PathLike[str], root: Path) -> str:
    """A file's name as summary.json's inputs give it (relative to the study folder)."""
    try:
        return Path(path).resolve().relative_to(root).as_posix()
    except ValueError:
        return str(Path(path).resolve())


def kept_sketches(study: StudyFolder, summary: Mapping[str, Any],
                  cache_dir: str | os.PathLike[str] | None = None) -> dict[str, TrialSketch]:
    """The sketches ``evtribo analyze`` kept of a study's trials when it wrote *summary*:
    those of the trials it analysed with these settings and this rig, each log as it hashed
    it (``summary.json``'s ``inputs``, ``settings`` and ``strict``).

    Parameters
    ----------
    study : StudyFolder
        The study, as loaded now (its trials named and described as when analysed).
    summary : mapping
        The analysis's ``summary.json``.
    cache_dir : path-like, optional
        The cache folder the analysis used (default: :func:`~evtribo.store.memo.
        default_cache_dir`).

    Returns
    -------
    dict
        ``{"subject/trial": TrialSketch}``; a trial whose sketch is not kept (another cache
        folder, a trial or its sidecar changed since, a cache cleared) is left out.
    """
    if study.rig is None:
        return {}
    settings = settings_of(study, summary.get("settings"))
    store = OutcomeStore(None, analysis_context(study.rig, settings,
                                                bool(summary.get("strict", False))),
                         sketches=default_cache_dir() if cache_dir is None else cache_dir)
    hashes = {str(r.get("file")): str(r.get("sha256")) for r in summary.get("inputs") or []
              if isinstance(r, Mapping) and r.get("role") == "log"}
    root = Path(study.root).resolve()
    out = {}
    for ref in study.trials:
        sha = hashes.get(_relative(ref.log_path, root))
        sketch = None if sha is None else store.get_sketch(store.ref_key(ref, sha))
        if sketch is not None and sketch.key == ref.key:
            out[ref.key] = sketch
    return out
