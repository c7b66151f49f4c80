"""One trial, from decoded signals to its steady-sliding windows and its row of trials.csv.

The trial's condition, waveform, frequency and amplitude come from the amplifier's status
signals when the rig broadcasts them (what was applied), else from the sidecar (what was
intended); a disagreement between the two is reported. Every window's time is counted from
the trial's start, the first decoded frame of the rig's messages.

The steps: the two load cells on one grid (:mod:`.align`), the ON/OFF condition
(:mod:`.conditions`), mains hum notched out (:mod:`.hum`), the calibration applied and the
zero offsets removed (:mod:`.zero_offsets`), steady-sliding windows (:mod:`.windows`); the
friction loop's tangential offset is then taken out and the windows' means taken again from
the corrected forces (:mod:`.tared_windows`).
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from evtribo.analysis.forces.align import AlignedForces, align_forces
from evtribo.analysis.forces.crosstalk import ReversalSums, direction_share, reversal_sums
from evtribo.analysis.forces.excitation import excitation_of
from evtribo.analysis.forces.hum import find_hum, friction_oscillates, modulation_lines, remove_hum
from evtribo.analysis.forces.pieces import check_seconds, continuous_pieces, describe_gap, restrict
from evtribo.analysis.forces.timebase import placed_among, sample_times
from evtribo.analysis.forces.zero_offsets import HUM_FREE_S, removed_offsets
from evtribo.analysis.friction.plausible import swapped_roles
from evtribo.analysis.friction.sine import friction_modulation, trace_around_switch
from evtribo.analysis.friction.trace import TRACE_COLUMNS
from evtribo.analysis.piece_observer import PieceObserver, PieceState
from evtribo.analysis.settings import AnalysisSettings
from evtribo.analysis.tared_windows import offset_warnings, tare_and_find_windows
from evtribo.canlog.rig import Calibration
from evtribo.canlog.signals import CellSignals, TrialSignals
from evtribo.documents.sidecar import Sidecar
from evtribo.documents.tables import TRIALS, WINDOWS
from evtribo.errors import AnalysisError
from evtribo.util.docstrings import fill_doc
from evtribo.warning.collect import collecting, emitter, replay, rescoped
from evtribo.warning.record import Scope, WarningRecord

log = logging.getLogger(__name__)
emit = emitter(__name__)

#: Columns of trials.csv, windows.csv and sine_trace.csv (:mod:`evtribo.documents.tables`).
TRIAL_COLUMNS, WINDOW_CSV_COLUMNS = TRIALS.names(), WINDOWS.names()
SINE_TRACE_CSV_COLUMNS = TRACE_COLUMNS



@dataclass(frozen=True)
class TrialMeta:
    """What the study folder says about a trial (sidecar values may be None).

    The sidecar's values come from :class:`evtribo.documents.sidecar.Sidecar` through
    :meth:`from_sidecar`, the one place that reads them.
    """

    subject: str
    trial: str
    waveform: str | None = None
    frequency_Hz: float | None = None
    amplitude_V: float | None = None
    condition: str | None = None
    tare_s: float | None = None

    @classmethod
    def from_sidecar(cls, subject: str, trial: str, sidecar: Sidecar) -> TrialMeta:
        """A trial's names and what its sidecar says.

        Parameters
        ----------
        subject, trial : str
            The trial's names in the study.
        sidecar : Sidecar
            Its sidecar (``tare_s`` read from its other keys, when a number).

        Returns
        -------
        TrialMeta
        """
        tare_s = sidecar.extra.get("tare_s")
        return cls(subject=subject, trial=trial, waveform=sidecar.waveform,
                   frequency_Hz=sidecar.frequency_Hz, amplitude_V=sidecar.amplitude_V,
                   condition=sidecar.condition,
                   tare_s=float(tare_s) if isinstance(tare_s, int | float)
                   and not isinstance(tare_s, bool) else None)


@dataclass
class TrialAnalysis:
    """A trial's row of trials.csv, its windows and what went wrong on the way.

    Attributes
    ----------
    row : dict
        Values of :data:`TRIAL_COLUMNS` (None for unknown).
    windows : pandas.DataFrame
        :data:`WINDOW_CSV_COLUMNS`.
    warnings : list of WarningRecord
        What its decoding and analysis said of it, in order.
    trace : pandas.DataFrame or None
        For a sine trial with ON phases: :data:`SINE_TRACE_CSV_COLUMNS` over a stretch
        around a switch from OFF to ON (see :func:`~evtribo.analysis.friction.trace.sine_trace`).
    """

    row: dict[str, Any]
    windows: pd.DataFrame
    warnings: list[WarningRecord] = field(default_factory=list)
    trace: pd.DataFrame | None = None


def empty_windows() -> pd.DataFrame:
    """A windows table without rows.

    Returns
    -------
    pandas.DataFrame
        Columns :data:`WINDOW_CSV_COLUMNS`.
    """
    kinds = {"subject": object, "trial": object, "condition": object, "waveform": object,
             "direction": np.int64, "stroke": np.int64}
    return pd.DataFrame({c: pd.Series(dtype=kinds.get(c, float)) for c in WINDOW_CSV_COLUMNS})


def _channel(cell: CellSignals) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """A load cell's sample times (s: its frames' timestamps without the logger's jitter,
    :func:`~evtribo.analysis.forces.timebase.sample_times`) and forces (N) as float arrays."""
    return (sample_times(cell.t, cell.counter, cell.counter_period),
            np.asarray(cell.value, dtype=np.float64))


def _excitation_placed(signals: TrialSignals, tn: npt.NDArray[np.float64],
                       tt: npt.NDArray[np.float64]) -> TrialSignals:
    """*signals* with the amplifier's status on the load cells' sample times *tn*, *tt*
    (:func:`~evtribo.analysis.forces.timebase.placed_among`): where frames arrived late in bursts,
    its timestamps are as late as the cells' and the switches would move against them."""
    exc = signals.excitation
    if exc is None or not len(exc.t):
        return signals
    stamps = np.concatenate([np.asarray(signals.normal.t, dtype=np.float64),
                             np.asarray(signals.tangential.t, dtype=np.float64)])
    placed = placed_among(exc.t, stamps, np.concatenate([tn, tt]))
    return dataclasses.replace(signals, excitation=dataclasses.replace(exc, t=placed))


def _sample_times(signals: TrialSignals) -> list[npt.NDArray[np.float64]]:
    """The sample times of the load cells and the amplifier that have any, s."""
    streams = [signals.normal.t, signals.tangential.t]
    if signals.excitation is not None:
        streams.append(signals.excitation.t)
    return [np.asarray(t, dtype=np.float64) for t in streams if len(t)]


@fill_doc
def trial_start(signals: TrialSignals) -> float:
    """The trial's start: the earliest sample time of its load cells and amplifier.

    Parameters
    ----------
    %(signals)s

    Returns
    -------
    float
        The time, s.

    Raises
    ------
    AnalysisError
        The trial has no samples.
    """
    starts = [float(np.min(t)) for t in _sample_times(signals)]
    if not starts:
        raise AnalysisError("the trial has no samples of the rig's signals")
    return min(starts)


def _trial_end(signals: TrialSignals) -> float:
    """The trial's end: the latest sample time of its load cells and amplifier, s."""
    return max(float(np.max(t)) for t in _sample_times(signals))


def _dropped(signals: TrialSignals) -> int:
    """Frames missing from both load cells, as the decoder counted them
    (:func:`evtribo.canlog.dropped.missing_frames`: counters first, else the timing), and what
    the count's method is worth saying (its notes the decoder said); never counted again
    here."""
    total = 0
    for name, cell in (("normal", signals.normal), ("tangential", signals.tangential)):
        if cell.dropped_method == "counter+timing":
            emit("frames-lost-periods", cell=name, frames=int(cell.dropped))
        total += int(cell.dropped)
    logged = int(signals.logger_dropped)
    if logged > total:
        emit("frames-dropcount", frames=logged)
    return max(total, logged)


def _dehum(aligned: AlignedForces, info: Mapping[str, Any]) -> AlignedForces:
    """The forces with mains hum notched out (each cell on its own)."""
    avoid = modulation_lines(info.get("waveform"), info.get("frequency_Hz"), aligned.rate_Hz)
    out = {}
    for name in ("normal", "tangential"):
        x = getattr(aligned, name)
        hum = find_hum(x, aligned.rate_Hz, avoid_Hz=avoid)
        if hum is not None:
            log.info("%s force: %g Hz hum of %.2g N removed (lines %s%s)", name, hum.mains_Hz,
                     hum.amplitude, ", ".join(f"{f:g}" for f in hum.lines_Hz),
                     f"; left in at {hum.kept_Hz} Hz, where the friction oscillates"
                     if hum.kept_Hz else "")
            x = remove_hum(x, aligned.rate_Hz, hum)
        out[name] = x
    return AlignedForces(aligned.t, out["normal"], out["tangential"], aligned.rate_Hz)


@dataclass
class _PieceResult:
    """What one continuous piece of a trial gives."""

    windows: pd.DataFrame
    info: dict[str, Any]
    offsets: tuple[float | None, float | None]
    methods: list[str]
    span_s: float
    modulation: float | None = None
    trace: pd.DataFrame | None = None
    reversals: ReversalSums = field(default_factory=ReversalSums)


def _analyze_piece(signals: TrialSignals, meta: TrialMeta, t0: float, *, settings: AnalysisSettings,
                   calibration: Calibration | None,
                   observe: PieceObserver | None = None) -> _PieceResult:
    """Align, read the excitation, remove hum and offsets, find the windows of a stretch of
    a trial with no long pause; window times from *t0*, the trial's start."""
    tn, fn = _channel(signals.normal)
    tt, ft = _channel(signals.tangential)
    aligned = align_forces(tn, fn, tt, ft, max_gap_periods=settings.max_gap_periods)
    swapped_roles(aligned.normal, aligned.tangential, aligned.rate_Hz)  # said, if so
    given = {"waveform": meta.waveform, "frequency_Hz": meta.frequency_Hz,
             "amplitude_V": meta.amplitude_V, "condition": meta.condition}
    exc = excitation_of(_excitation_placed(signals, tn, tt), given, aligned.t,
                        settings.guard_s)
    info = exc.info
    smooth, quantum = settings.smooth_s, HUM_FREE_S
    oscillates = friction_oscillates(info["waveform"], info.get("frequency_Hz"),
                                     aligned.rate_Hz)
    if oscillates:  # windows span whole periods of it
        smooth = max(smooth, 1.0 / float(info["frequency_Hz"]))
        quantum = 0.5 / float(info["frequency_Hz"])
    if settings.hum == "remove" or (settings.hum == "auto" and oscillates):
        aligned = _dehum(aligned, info)
    tared, w, amplitude = tare_and_find_windows(
        aligned, exc, smooth=smooth, quantum=quantum, tare_s=meta.tare_s, settings=settings,
        calibration=calibration)
    aligned = tared.forces
    if observe is not None:
        observe(PieceState(aligned, exc.condition, tared.lifted, w, info))
    offsets = removed_offsets(tared, calibration if settings.tare != "none" else None)
    offset_warnings(tared, w, offsets)
    if np.isnan(amplitude).any():
        emit("amplitude-unknown")
    windows = pd.DataFrame({
        "subject": meta.subject, "trial": meta.trial, "condition": w.condition,
        "amplitude_V": np.round(amplitude, 3), "waveform": info["waveform"],
        "t_start_s": np.round(w.t_start.to_numpy() - t0, 6),
        "t_end_s": np.round(w.t_end.to_numpy() - t0, 6),
        "normal_force_N": w.normal_force_N, "friction_force_N": w.friction_force_N,
        "direction": w.direction.astype(np.int64), "stroke": w.stroke.astype(np.int64),
        "stroke_s": np.round(w.stroke_s.to_numpy(float), 6),
    }, columns=list(WINDOW_CSV_COLUMNS)) if len(w) else empty_windows()
    result = _PieceResult(windows, info, offsets, tared.methods,
                          span_s=float(aligned.t[-1] - aligned.t[0]),
                          reversals=reversal_sums(aligned.t, aligned.normal,
                                                  aligned.tangential, w))
    if info["waveform"] == "sine":
        result.modulation = friction_modulation(aligned, w, info)
        result.trace = trace_around_switch(aligned, w, exc, subject=meta.subject,
                                           trial=meta.trial, settings=settings)
    return result


def _pieces(signals: TrialSignals, meta: TrialMeta, t0: float, *, settings: AnalysisSettings,
            calibration: Calibration | None,
            observe: PieceObserver | None = None) -> tuple[list[_PieceResult], bool]:
    """Each continuous piece of the trial analysed (one for a trial without long pauses),
    and whether the trial was cut in pieces."""
    check_seconds(signals)
    pieces = continuous_pieces(signals)
    if len(pieces) <= 1:
        return [_analyze_piece(signals, meta, t0, settings=settings, calibration=calibration,
                               observe=observe)], False
    for before, after in itertools.pairwise(pieces):
        describe_gap(before, after, t0)
    emit("pieces", pieces=len(pieces))
    out, failures = [], []
    for k, (lo, hi) in enumerate(pieces):
        # the tare stretch the sidecar tells of is at the trial's start, in the first piece
        piece_meta = meta if k == 0 else dataclasses.replace(meta, tare_s=None)
        try:
            out.append(_analyze_piece(restrict(signals, lo, hi), piece_meta, t0,
                                      settings=settings, calibration=calibration,
                                      observe=observe))
        except AnalysisError as err:
            failures.append(err)
            emit("piece-left", start_s=lo - t0, end_s=hi - t0, error=str(err))
    if not out:
        raise failures[0]
    return out, True


@fill_doc
def analyze_signals(signals: TrialSignals, meta: TrialMeta, *,
                    settings: AnalysisSettings | None = None,
                    calibration: Calibration | None = None,
                    observe: PieceObserver | None = None) -> TrialAnalysis:
    """Analyse one decoded trial.

    A trial whose load cells both fall silent for more than a second (a jump of the log's
    clock, a pause of the recording) is analysed in its continuous pieces
    (:mod:`evtribo.analysis.forces.pieces`), so that memory follows its frames, not its time span;
    ``duration_s`` is then the pieces' total.

    Parameters
    ----------
    %(signals)s
    meta : TrialMeta
        Names and the sidecar's values.
    settings : AnalysisSettings, optional
        The analysis settings (default: the package's defaults).
    calibration : Calibration, optional
        The rig's ``[rig.calibration]``: known offsets and cross-talk matrix.
    observe : callable, optional
        Called with each analysed piece's :class:`PieceState` (what a check of the trial
        draws); the results do not depend on it.

    Returns
    -------
    TrialAnalysis

    Raises
    ------
    AnalysisError
        The trial cannot be analysed (no overlap of the load cells, timestamps not in
        seconds, an alternating trial without excitation signals, no condition known).
    """
    scope = Scope(meta.subject, meta.trial)
    with collecting(scope) as warnings:
        replay(rescoped(r, scope) for r in signals.warnings)  # its decoding's, of this trial
        result = _analyze(signals, meta, settings or AnalysisSettings(), calibration, observe)
    result.warnings = warnings
    return result


def _analyze(signals: TrialSignals, meta: TrialMeta, settings: AnalysisSettings,
             calibration: Calibration | None, observe: PieceObserver | None) -> TrialAnalysis:
    """:func:`analyze_signals` within its trial's collector of warnings."""
    t0 = trial_start(signals)
    parts, cut = _pieces(signals, meta, t0, settings=settings, calibration=calibration,
                         observe=observe)
    longest = max(parts, key=lambda p: p.span_s)
    info = longest.info
    frames, strokes = [], 0  # stroke numbers run on from one piece to the next
    for p in parts:
        if not p.windows.empty:
            frames.append(p.windows.assign(stroke=p.windows.stroke + strokes))
            strokes += int(p.windows.stroke.max()) + 1
    windows = pd.concat(frames, ignore_index=True) if frames else empty_windows()
    if windows.empty:
        emit("no-window")
    # a trial cut in pieces lasted the pieces analysed: a jump of its log's clock is no time
    duration = sum(p.span_s for p in parts) if cut else _trial_end(signals) - t0
    offsets = tuple(_span_mean([(p.offsets[k], p.span_s) for p in parts]) for k in (0, 1))
    methods = list(dict.fromkeys(m for p in parts for m in p.methods))
    modulation = next((p.modulation for p in sorted(parts, key=lambda p: -p.span_s)
                       if p.modulation is not None), None)
    trace = next((p.trace for p in parts if p.trace is not None), None)
    row = {
        "subject": meta.subject, "trial": meta.trial, "waveform": info["waveform"],
        "frequency_Hz": info["frequency_Hz"], "amplitude_V": info["amplitude_V"],
        "condition": info["condition"], "duration_s": round(duration, 6),
        "frames": signals.frames,
        "dropped_frames": _dropped(signals),
        "duplicate_frames": signals.duplicate_frames,
        "skipped_lines": signals.skipped_lines,
        "friction_modulation_Hz": modulation,
        "normal_offset_N": None if offsets[0] is None else round(offsets[0], 6),
        "tangential_offset_N": None if offsets[1] is None else round(offsets[1], 6),
        "tare": "+".join(methods) or "none",
        **_crosstalk(parts, windows, methods),
    }
    return TrialAnalysis(row=row, windows=windows, trace=trace)


def _crosstalk(parts: list[_PieceResult], windows: pd.DataFrame, methods: list[str]
               ) -> dict[str, float | None]:
    """trials.csv's cross-talk columns (:mod:`.crosstalk`): the normal cell's share of the
    tangential force from the reversals, and, where the tangential zero was measured (not
    taken from the friction loop, which removes it), the tangential reading's part that
    follows the normal force in both directions."""
    sums = sum((p.reversals for p in parts), ReversalSums())
    share = None
    if {"lifted", "calibration"} & set(methods) and "friction-loop" not in methods \
            and not windows.empty:
        value = direction_share(windows.assign(
            tangential_N=windows.direction * windows.friction_force_N))
        share = None if np.isnan(value) else round(value, 6)

    def rounded(x: float) -> float | None:
        return None if np.isnan(x) else round(x, 6)

    return {"crosstalk_normal": rounded(sums.slope),
            "crosstalk_normal_se": rounded(sums.slope_se), "tangential_direction_share": share}


def _span_mean(values: list[tuple[float | None, float]]) -> float | None:
    """Mean of the values given (None left out), weighted by their spans; None if none."""
    known = [(v, w) for v, w in values if v is not None]
    if not known:
        return None
    total = sum(w for _, w in known)
    if total <= 0:
        return float(np.mean([v for v, _ in known]))
    return float(sum(v * w for v, w in known) / total)


def failed_row(meta: TrialMeta) -> dict[str, Any]:
    """trials.csv row of a trial that could not be analysed: names and sidecar values only.

    Parameters
    ----------
    meta : TrialMeta
        The trial's names and sidecar values.

    Returns
    -------
    dict
        Values of :data:`TRIAL_COLUMNS` (None for the unknown).
    """
    row = dict.fromkeys(TRIAL_COLUMNS)
    row.update(subject=meta.subject, trial=meta.trial, waveform=meta.waveform,
               frequency_Hz=meta.frequency_Hz, amplitude_V=meta.amplitude_V,
               condition=meta.condition)
    return row


__all__ = ["SINE_TRACE_CSV_COLUMNS", "TRIAL_COLUMNS", "WINDOW_CSV_COLUMNS", "AnalysisSettings",
           "TrialAnalysis", "TrialMeta", "analyze_signals", "empty_windows", "failed_row",
           "trial_start"]
