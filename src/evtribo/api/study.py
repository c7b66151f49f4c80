"""A study folder from Python: :func:`open_study`, its :class:`Study` and each :class:`Trial`.

A trial's forces come through the same path as the analysis's: the log decoded with the
study's rig (or read from the decoded-trial cache, :mod:`evtribo.canlog.cache`), the two load cells
put on one time grid (:func:`evtribo.analysis.forces.align.align_forces`), each continuous piece of
the trial on its own (:mod:`evtribo.analysis.forces.pieces`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from evtribo.analysis.forces.align import align_forces
from evtribo.analysis.forces.conditions import OFF, ON, condition_from_excitation
from evtribo.analysis.forces.pieces import check_seconds, continuous_pieces, restrict
from evtribo.analysis.settings import AnalysisSettings
from evtribo.analysis.trial import trial_start
from evtribo.canlog.cache import load_trial
from evtribo.canlog.rig import Rig
from evtribo.canlog.signals import ExcitationSignals, TrialSignals
from evtribo.errors import AnalysisError, SidecarError, UserInputError
from evtribo.results.pipeline import study_settings
from evtribo.study import StudyFolder, TrialRef, load_study
from evtribo.util.docstrings import fill_doc
from evtribo.warning.record import WarningRecord

__all__ = ["FORCE_COLUMNS", "Study", "Trial", "open_study", "trial_forces"]

#: The columns every :meth:`Trial.forces` table has; ``amplitude_V``, ``frequency_Hz`` and
#: ``waveform`` follow when the rig's status signals or the sidecar give them.
FORCE_COLUMNS = ("t_s", "normal_force_N", "tangential_force_N", "excitation_on")


@dataclass(frozen=True, eq=False)
class Trial:
    """One trial of a study: its names, its sidecar, and its forces on demand.

    Attributes
    ----------
    subject, name : str
        The subject and the trial (the log's name without its suffix).
    meta : dict
        The sidecar's content: ``waveform``, ``frequency_Hz``, ``amplitude_V``,
        ``condition``, ``notes`` and every other key it holds.
    log_path : Path
        The trial's log.
    sidecar_path : Path or None
        Its sidecar (None when it has none).
    study : Study
        The study it belongs to.
    """

    subject: str
    name: str
    meta: dict[str, Any]
    log_path: Path
    sidecar_path: Path | None
    study: Study = field(repr=False)
    _ref: TrialRef = field(repr=False)

    @property
    def key(self) -> str:
        """``subject/trial``, as the result tables and warnings name the trial."""
        return self._ref.key

    def __repr__(self) -> str:
        m = self.meta
        what = " ".join(f"{m[k]:g}{unit}" if isinstance(m.get(k), float | int) else str(m[k])
                        for k, unit in (("waveform", ""), ("frequency_Hz", " Hz"),
                                        ("amplitude_V", " V"), ("condition", ""))
                        if m.get(k) is not None)
        return f"Trial({self.key!r}{', ' + what if what else ''})"

    def forces(self, *, cache_dir: str | os.PathLike[str] | None = None,
               strict: bool = False) -> pd.DataFrame:
        """The trial's forces over time (see :func:`trial_forces`).

        Parameters
        ----------
        cache_dir : path-like, optional
            Where decoded trials are cached (default:
            :func:`evtribo.canlog.cache.default_cache_dir`).
        strict : bool
            A damaged line in the log is an error instead of a warning.

        Returns
        -------
        pandas.DataFrame
            One row per point of the time grid (:data:`FORCE_COLUMNS`, then what is known
            of the excitation).
        """
        return trial_forces(self._ref, self.study.rig, settings=self.study.settings,
                            cache_dir=cache_dir, strict=strict)


@dataclass(eq=False)
class Study:
    """A study folder, loaded and checked: ``study.toml``, its rig and its trials (their
    logs not read yet).

    Attributes
    ----------
    root : Path
        The study folder.
    name : str
        The study's name (``study.toml``'s ``name``, else the folder's).
    rig : Rig
        The rig: its DBC and which signal is which.
    trials : list of Trial
        In the study's order (by subject, then trial).
    settings : AnalysisSettings
        The analysis settings: the package's defaults and ``study.toml``'s ``[analysis]``.
    warnings : list of WarningRecord
        What loading the folder found worth saying (files it ignored), as records.
    """

    root: Path
    name: str
    rig: Rig
    trials: list[Trial]
    settings: AnalysisSettings
    warnings: list[WarningRecord]
    _folder: StudyFolder = field(repr=False)

    @property
    def subjects(self) -> list[str]:
        """The subjects, in order of first appearance."""
        return list(dict.fromkeys(t.subject for t in self.trials))

    def __repr__(self) -> str:
        return (f"Study({self.name!r}, root={str(self.root)!r}, subjects={self.subjects!r}, "
                f"{len(self.trials)} trials)")

    def trial(self, subject: str, name: str) -> Trial:
        """One trial, by its subject and name.

        Parameters
        ----------
        subject : str
            The subject (``"P01"``).
        name : str
            The trial (``"run-03"``).

        Returns
        -------
        Trial

        Raises
        ------
        KeyError
            The study has no such trial (the message lists the subject's trials).
        """
        for t in self.trials:
            if t.subject == subject and t.name == name:
                return t
        have = [t.name for t in self.trials if t.subject == subject]
        raise KeyError(f"{subject}/{name}: no such trial in {self.root} "
                       f"({subject}'s trials: {', '.join(have) or 'none'})")


def open_study(path: str | os.PathLike[str]) -> Study:
    """Open a study folder (study format §1): ``study.toml``, the rig's DBC, the trials.

    Parameters
    ----------
    path : path-like
        The study folder (or its ``study.toml``).

    Returns
    -------
    Study

    Raises
    ------
    StudyError, SidecarError, RigConfigError, ConfigError
        The folder is not a study, or one of its files is wrong (the message names the
        file, and the line or key): the errors ``evtribo analyze`` exits with code 2 for.
    """
    folder = load_study(path)
    assert folder.rig is not None
    study = Study(root=folder.root, name=folder.name, rig=folder.rig, trials=[],
                  settings=study_settings(folder), warnings=list(folder.warnings),
                  _folder=folder)
    study.trials = [Trial(ref.subject, ref.name, ref.sidecar.to_dict(), ref.log_path,
                          ref.sidecar_path, study, ref) for ref in folder.trials]
    return study


def _load(ref: TrialRef, rig: Rig, cache_dir: str | os.PathLike[str] | None,
          strict: bool) -> TrialSignals:
    """The trial's decoded signals, from the channel its sidecar's ``log_channel`` names
    (as the analysis reads them)."""
    channel = ref.sidecar.extra.get("log_channel")
    channel = channel if isinstance(channel, str) and channel else None
    try:
        return load_trial(ref.log_path, rig, cache_dir, strict, channel=channel)
    except UserInputError as err:
        if channel is None or err.key != "channel":
            raise
        raise SidecarError(err.message, path=ref.sidecar_path, key="log_channel") from err


def _held(grid: npt.NDArray[np.float64], t: npt.NDArray[np.float64],
          values: npt.NDArray[Any], dtype: type[np.generic]) -> npt.NDArray[Any]:
    """*values* sampled at *t*, held until the next sample, at the grid's times (missing,
    NaN or None, before the first sample)."""
    order = np.argsort(t, kind="stable")
    idx = np.searchsorted(t[order], grid, side="right") - 1
    out = np.asarray(values, dtype=dtype)[order][np.clip(idx, 0, None)]
    out[idx < 0] = None if dtype is np.object_ else np.nan
    return out


def _excitation_columns(grid: npt.NDArray[np.float64], exc: ExcitationSignals | None,
                        sidecar: dict[str, Any]) -> dict[str, Any]:
    """``excitation_on`` (True, False or missing where unknown, as around a switch) and the
    amplitude, frequency and waveform where the status signals or the sidecar give them."""
    n = grid.size
    cols: dict[str, Any] = {}
    if exc is not None and len(exc.t) and exc.enabled is not None:
        te = np.asarray(exc.t, dtype=np.float64)
        code = condition_from_excitation(grid, te, np.asarray(exc.enabled, dtype=bool),
                                         guard_s=0.0)
        on = pd.array(code == ON, dtype="boolean")
        on[(code != ON) & (code != OFF)] = pd.NA
        cols["excitation_on"] = on
    else:
        te = np.asarray(exc.t, dtype=np.float64) if exc is not None else np.empty(0)
        cond = sidecar.get("condition")
        value = True if cond == "on" else False if cond == "off" else pd.NA
        cols["excitation_on"] = pd.array([value] * n, dtype="boolean")
    for name, attr, dtype in (("amplitude_V", "amplitude", np.float64),
                              ("frequency_Hz", "frequency", np.float64),
                              ("waveform", "waveform", np.object_)):
        signal = getattr(exc, attr, None) if exc is not None else None
        if signal is not None and te.size:
            cols[name] = _held(grid, te, signal, dtype)
        elif sidecar.get(name) is not None:
            cols[name] = np.full(n, sidecar[name], dtype=dtype)
    return cols


@fill_doc
def trial_forces(ref: TrialRef, rig: Rig, *, settings: AnalysisSettings | None = None,
                 cache_dir: str | os.PathLike[str] | None = None,
                 strict: bool = False) -> pd.DataFrame:
    """A trial's forces and excitation on one time grid, as the analysis reads them.

    The forces are those the load cells sent (decoded with the rig's DBC and its
    ``[rig.calibration]``), their zero offsets not removed (``trials.csv`` gives the
    offsets the analysis removed). Points inside a gap of a load cell are NaN, never
    interpolated; a trial with a long pause (its pieces, :mod:`evtribo.analysis.forces.pieces`)
    has no grid points across it.

    Parameters
    ----------
    ref : TrialRef
        The trial (:attr:`evtribo.study.StudyFolder.trials`).
    %(rig)s
    settings : AnalysisSettings, optional
        The analysis settings (their ``max_gap_periods``); default: the package's.
    %(cache_dir)s
    %(strict)s

    Returns
    -------
    pandas.DataFrame
        ``t_s`` (seconds from the trial's first sample), ``normal_force_N``,
        ``tangential_force_N`` (with its sign), ``excitation_on`` (nullable boolean:
        missing where the status is unknown, e.g. between the last status sample before a
        switch and the first after it, or for an alternating trial without status signals),
        then ``amplitude_V``, ``frequency_Hz``, ``waveform`` when the amplifier's status
        signals (held until the next sample) or the sidecar give them.

    Raises
    ------
    LogFormatError
        The log cannot be read (or has a damaged line, under *strict*).
    AnalysisError
        The load cells do not overlap in time, or their timestamps are not in seconds.
    """
    settings = settings or AnalysisSettings()
    signals = _load(ref, rig, cache_dir, strict)
    check_seconds(signals)
    t0 = trial_start(signals)
    frames, failures = [], []
    for lo, hi in continuous_pieces(signals):
        piece = restrict(signals, lo, hi)
        try:
            aligned = align_forces(piece.normal.t, piece.normal.value, piece.tangential.t,
                                   piece.tangential.value,
                                   max_gap_periods=settings.max_gap_periods)
        except AnalysisError as err:
            failures.append(err)
            continue
        frames.append(pd.DataFrame({
            "t_s": aligned.t - t0, "normal_force_N": aligned.normal,
            "tangential_force_N": aligned.tangential,
            **_excitation_columns(aligned.t, piece.excitation, ref.sidecar.to_dict())}))
    if not frames:
        raise AnalysisError(f"{ref.log_path}: {failures[0]}") from failures[0]
    return pd.concat(frames, ignore_index=True)
