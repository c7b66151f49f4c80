"""One trial, from decoded signals to its steady-sliding windows and its row of trials.csv.

The trial's condition, waveform, frequency and amplitude come from the amplifier's status
signals when the rig broadcasts them (what was applied), else from the sidecar (what was
intended); a disagreement between the two is reported. Every window's time is counted from
the trial's start, the first decoded frame of the rig's messages.
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from evtribo.analysis.align import DEFAULT_MAX_GAP_PERIODS, AlignedForces, align_forces
from evtribo.analysis.conditions import (
    DEFAULT_GUARD_S,
    ON,
    condition_from_excitation,
    constant_condition,
)
from evtribo.analysis.spectra import dominant_frequency
from evtribo.analysis.trace import TRACE_COLUMNS, sine_trace
from evtribo.analysis.windows import DEFAULT_MAX_WINDOW_S, DEFAULT_MIN_WINDOW_S, find_windows
from evtribo.dropped import DropCount, missing_frames
from evtribo.errors import AnalysisError

log = logging.getLogger(__name__)

#: Columns of trials.csv (study format, section 2).
TRIAL_COLUMNS = ("subject", "trial", "waveform", "frequency_Hz", "amplitude_V", "condition",
                 "duration_s", "frames", "dropped_frames", "skipped_lines",
                 "friction_modulation_Hz")
#: Columns of windows.csv (study format, section 2).
WINDOW_CSV_COLUMNS = ("subject", "trial", "condition", "amplitude_V", "waveform", "t_start_s",
                      "t_end_s", "normal_force_N", "friction_force_N")

#: Columns of sine_trace.csv (read by :mod:`evtribo.compare.tables`).
SINE_TRACE_CSV_COLUMNS = TRACE_COLUMNS

_WAVE_CODES = {0: "sine", 1: "square", 2: "triangle", 3: "dc"}


@dataclass(frozen=True)
class AnalysisSettings:
    """Tunable constants of the per-trial analysis (all times in s).

    Attributes
    ----------
    smooth_s : float, s
        Moving-average span for finding strokes; for a sine drive at least one period of
        the drive (two of the friction's modulation) is used.
    guard_s : float, s
        Excluded on both sides of an ON/OFF switch.
    min_window_s, max_window_s : float, s
        Shortest window kept, longest window (longer steady runs are split).
    max_gap_periods : float
        A pause of a load cell longer than this many sample periods is a gap.
    n_boot : int
        Bootstrap replicates of the electrostatic force.
    seed : int
        Seed of the bootstrap.
    trace_off_s, trace_on_s : float, s
        Extent of the sine trace written for the model comparison (sine_trace.csv): this
        long before and after a switch from OFF to ON.
    trace_rate_Hz : float, Hz
        Highest sample rate of the sine trace (block means of the aligned forces).
    """

    smooth_s: float = 0.1
    guard_s: float = DEFAULT_GUARD_S
    min_window_s: float = DEFAULT_MIN_WINDOW_S
    max_window_s: float = DEFAULT_MAX_WINDOW_S
    max_gap_periods: float = DEFAULT_MAX_GAP_PERIODS
    n_boot: int = 2000
    seed: int = 0
    trace_off_s: float = 0.5
    trace_on_s: float = 1.0
    trace_rate_Hz: float = 1000.0

    def to_dict(self) -> dict[str, Any]:
        """The settings as a JSON-ready mapping."""
        return dict(self.__dict__)


@dataclass(frozen=True)
class TrialMeta:
    """What the study folder says about a trial (sidecar values may be None)."""

    subject: str
    trial: str
    waveform: str | None = None
    frequency_Hz: float | None = None
    amplitude_V: float | None = None
    condition: str | None = None


@dataclass
class TrialResult:
    """A trial's row of trials.csv, its windows and what went wrong on the way.

    Attributes
    ----------
    row : dict
        Values of :data:`TRIAL_COLUMNS` (None for unknown).
    windows : pandas.DataFrame
        :data:`WINDOW_CSV_COLUMNS`.
    warnings : list of str
    trace : pandas.DataFrame or None
        For a sine trial with ON phases: :data:`SINE_TRACE_CSV_COLUMNS` over a stretch
        around a switch from OFF to ON (see :func:`sine_trace`).
    """

    row: dict[str, Any]
    windows: pd.DataFrame
    warnings: list[str] = field(default_factory=list)
    trace: pd.DataFrame | None = None


def empty_windows() -> pd.DataFrame:
    """A windows table without rows."""
    return pd.DataFrame({c: pd.Series(dtype=object if c in {"subject", "trial", "condition",
                                                            "waveform"} else float)
                         for c in WINDOW_CSV_COLUMNS})


def _get(obj: Any, name: str, default: Any = None) -> Any:
    return getattr(obj, name, default) if obj is not None else default


def _waveform_names(values: npt.ArrayLike) -> list[str]:
    out = []
    for v in np.asarray(values, dtype=object).ravel():
        if isinstance(v, bytes | str):
            out.append(v.decode() if isinstance(v, bytes) else str(v))
        elif v is not None and np.isfinite(float(v)):
            out.append(_WAVE_CODES.get(int(v), str(int(v))))
    return out


def _excitation_summary(exc: Any, on_mask: npt.NDArray[np.bool_]) -> dict[str, Any]:
    """Waveform (most common), frequency and amplitude (medians) while the voltage is on."""
    out: dict[str, Any] = {}
    if not on_mask.any():
        return out
    for key, name in (("amplitude_V", "amplitude"), ("frequency_Hz", "frequency")):
        values = _get(exc, name)
        if values is not None:
            arr = np.asarray(values, dtype=np.float64)[on_mask]
            arr = arr[np.isfinite(arr)]
            if arr.size:
                out[key] = float(np.median(arr))
    waves = _get(exc, "waveform")
    if waves is not None:
        names = _waveform_names(np.asarray(waves, dtype=object)[on_mask])
        if names:
            out["waveform"] = Counter(names).most_common(1)[0][0]
    return out


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, float) or isinstance(b, float):
        return bool(np.isclose(float(a), float(b), rtol=1e-3, atol=1e-6))
    return bool(a == b)


def _channel(signals: Any, name: str) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    ch = _get(signals, name)
    if ch is None:
        raise AnalysisError(f"the trial has no {name} force signal")
    return np.asarray(ch.t, dtype=np.float64), np.asarray(ch.value, dtype=np.float64)


def trial_start(signals: Any) -> float:
    """The trial's start: the earliest sample time of its load cells and amplifier, s."""
    starts = []
    for name in ("normal", "tangential", "excitation"):
        t = _get(_get(signals, name), "t")
        if t is not None and len(t):
            starts.append(float(np.min(t)))
    if not starts:
        raise AnalysisError("the trial has no samples of the rig's signals")
    return min(starts)


def _trial_end(signals: Any) -> float:
    ends = [float(np.max(t)) for name in ("normal", "tangential", "excitation")
            if (t := _get(_get(signals, name), "t")) is not None and len(t)]
    return max(ends)


def _sine_segments(aligned: AlignedForces, windows: pd.DataFrame) -> list[npt.NDArray[np.float64]]:
    """Friction magnitude over runs of back-to-back ON windows (split windows rejoined)."""
    on = windows[windows.condition == "on"].sort_values("i_start")
    segs: list[tuple[int, int]] = []
    for a, b in zip(on.i_start.to_numpy(int), on.i_stop.to_numpy(int), strict=True):
        if segs and segs[-1][1] == a:
            segs[-1] = (segs[-1][0], b)
        else:
            segs.append((a, b))
    return [np.abs(aligned.tangential[a:b]) for a, b in segs]


def _dropped(signals: Any, counter_moduli: Mapping[str, int] | None,
             warn: Callable[[str], None]) -> int:
    """Frames missing from both load cells, as the decoder counted them
    (:func:`evtribo.dropped.missing_frames`: counters first, else the timing); counted here
    only for signals that come without a count."""
    total = 0
    for name in ("normal", "tangential"):
        ch = _get(signals, name)
        t = _get(ch, "t")
        if t is None:
            continue
        if _get(ch, "dropped") is not None:
            count = DropCount(int(_get(ch, "dropped")), _get(ch, "dropped_method", "counter"),
                              note=_get(ch, "dropped_note"))
        else:
            counter = _get(ch, "counter")
            modulus = (counter_moduli or {}).get(name) if counter is not None else None
            count = missing_frames(np.asarray(t, dtype=np.float64), counter, modulus)
        if count.note:
            warn(f"{name} force: {count.note}")
        if count.method == "counter+timing":
            warn(f"{name} force: {count.count} frames missing, including whole counter "
                 "periods lost at once (found from the timing)")
        total += count.count
    return total


def analyze_signals(signals: Any, meta: TrialMeta, *,
                    settings: AnalysisSettings | None = None,
                    counter_moduli: Mapping[str, int] | None = None) -> TrialResult:
    """Analyse one decoded trial.

    Parameters
    ----------
    signals : TrialSignals
        Decoded trial: ``normal`` and ``tangential`` channels (``t`` in s, ``value`` in N,
        ``dropped``), and ``excitation`` (None, or ``t``, ``enabled``, ``amplitude`` in V,
        ``frequency`` in Hz, ``waveform``).
    meta : TrialMeta
        Names and the sidecar's values.
    settings : AnalysisSettings, optional
    counter_moduli : mapping, optional
        For signals without a dropped-frame count of their own (the decoder's carry one):
        period of each load cell's rolling counter (``{"normal": 256, ...}``); inferred
        from the values when absent.

    Returns
    -------
    TrialResult

    Raises
    ------
    AnalysisError
        The trial cannot be analysed (no overlap of the load cells, an alternating trial
        without excitation signals, no condition known).
    """
    settings = settings or AnalysisSettings()
    warnings: list[str] = []
    where = f"{meta.subject}/{meta.trial}"

    def warn(msg: str) -> None:
        log.warning("%s: %s", where, msg)
        warnings.append(f"{where}: {msg}")

    t0 = trial_start(signals)
    duration = _trial_end(signals) - t0
    tn, fn = _channel(signals, "normal")
    tt, ft = _channel(signals, "tangential")
    aligned = align_forces(tn, fn, tt, ft, max_gap_periods=settings.max_gap_periods)
    if np.nanmedian(aligned.normal) < 0:
        warn("the normal force is negative: its sign is flipped (compression counted "
             "positive)")
        aligned = AlignedForces(aligned.t, -aligned.normal, aligned.tangential, aligned.rate_Hz)

    info: dict[str, Any] = {"waveform": meta.waveform, "frequency_Hz": meta.frequency_Hz,
                            "amplitude_V": meta.amplitude_V, "condition": meta.condition}
    exc = _get(signals, "excitation")
    exc_t = _get(exc, "t")
    amp_at: npt.NDArray[np.float64] | None = None
    if exc is not None and exc_t is not None and len(exc_t) and exc.enabled is not None:
        exc_t = np.asarray(exc_t, dtype=np.float64)
        enabled = np.asarray(exc.enabled).astype(bool)
        cond = condition_from_excitation(aligned.t, exc_t, enabled, guard_s=settings.guard_s)
        observed = {"condition": "alternating" if enabled.any() and not enabled.all()
                    else "on" if enabled.all() else "off"}
        observed.update(_excitation_summary(exc, enabled))
        for key, value in observed.items():
            given = info.get(key)
            if given is not None and not _same(given, value):
                warn(f"the sidecar says {key} = {given!r} but the excitation signals say "
                     f"{value!r}; using the signals")
            info[key] = value
        amp = _get(exc, "amplitude")
        if amp is not None:
            amp_at = np.asarray(amp, dtype=np.float64)
    else:
        exc_t = None
        if info["condition"] in ("on", "off"):
            cond = constant_condition(aligned.t.size, info["condition"])
        elif info["condition"] == "alternating":
            raise AnalysisError("the sidecar says the trial alternates, but the rig has no "
                                "excitation signals to tell ON from OFF")
        else:
            raise AnalysisError("the trial's condition is unknown: the rig has no excitation "
                                "signals and the sidecar gives no 'condition'")

    smooth = settings.smooth_s
    if info["waveform"] == "sine" and info.get("frequency_Hz"):
        smooth = max(smooth, 1.0 / float(info["frequency_Hz"]))
    w = find_windows(aligned.t, aligned.normal, aligned.tangential, cond, smooth_s=smooth,
                     min_window_s=settings.min_window_s, max_window_s=settings.max_window_s)
    if w.empty:
        warn("no steady-sliding window found")

    amplitude = np.zeros(len(w))
    is_on = (w.condition == "on").to_numpy()
    if is_on.any():
        amplitude[is_on] = np.nan if info["amplitude_V"] is None else float(info["amplitude_V"])
        if amp_at is not None and exc_t is not None:
            # the amplitude reported during each ON window (amplitude sweeps inside a trial)
            enabled_t = exc_t[np.asarray(exc.enabled).astype(bool)]
            enabled_a = amp_at[np.asarray(exc.enabled).astype(bool)]
            for k in np.flatnonzero(is_on):
                sel = (enabled_t >= w.t_start.iat[k]) & (enabled_t <= w.t_end.iat[k])
                if sel.any():
                    amplitude[k] = float(np.median(enabled_a[sel]))
        if np.isnan(amplitude).any():
            warn("the amplitude of the ON windows is unknown (no excitation amplitude "
                 "signal, no 'amplitude_V' in the sidecar)")
    windows = pd.DataFrame({
        "subject": meta.subject, "trial": meta.trial, "condition": w.condition,
        "amplitude_V": np.round(amplitude, 3), "waveform": info["waveform"],
        "t_start_s": np.round(w.t_start.to_numpy() - t0, 6),
        "t_end_s": np.round(w.t_end.to_numpy() - t0, 6),
        "normal_force_N": w.normal_force_N, "friction_force_N": w.friction_force_N,
    }, columns=list(WINDOW_CSV_COLUMNS)) if len(w) else empty_windows()

    modulation = None
    if info["waveform"] == "sine" and is_on.any():
        drive = info.get("frequency_Hz")
        if drive and 2 * float(drive) >= 0.8 * aligned.rate_Hz / 2:
            warn(f"friction modulation at 2 x {drive:g} Hz is beyond what the load cells' "
                 f"{aligned.rate_Hz:.0f} Hz sampling can resolve")
        else:
            f = dominant_frequency(_sine_segments(aligned, w), aligned.rate_Hz)
            if np.isfinite(f):
                modulation = f
            else:
                warn("ON windows too short for a spectrum of the friction force")

    trace = None
    if info["waveform"] == "sine":
        if exc_t is not None and exc is not None and exc.enabled is not None:
            enabled = np.asarray(exc.enabled).astype(bool)
            idx = np.searchsorted(exc_t, aligned.t, side="right") - 1
            on_now = np.where(idx >= 0, enabled[np.clip(idx, 0, None)], False)
        else:
            on_now = cond == ON
        steady = np.zeros(aligned.t.size, dtype=bool)
        for a, b in zip(w.i_start.to_numpy(int), w.i_stop.to_numpy(int), strict=True):
            steady[a:b] = True
        trace = sine_trace(aligned.t, aligned.normal, aligned.tangential, on_now, steady,
                           amplitude_V=float(info["amplitude_V"] or np.nan),
                           frequency_Hz=float(info["frequency_Hz"] or np.nan),
                           subject=meta.subject, trial=meta.trial,
                           off_s=settings.trace_off_s, on_s=settings.trace_on_s,
                           rate_Hz=settings.trace_rate_Hz)

    dropped = _dropped(signals, counter_moduli, warn)
    row = {
        "subject": meta.subject, "trial": meta.trial, "waveform": info["waveform"],
        "frequency_Hz": info["frequency_Hz"], "amplitude_V": info["amplitude_V"],
        "condition": info["condition"], "duration_s": round(duration, 6),
        "frames": _get(signals, "frames"), "dropped_frames": dropped,
        "skipped_lines": _get(signals, "skipped_lines"),
        "friction_modulation_Hz": modulation,
    }
    return TrialResult(row=row, windows=windows, warnings=warnings, trace=trace)


def failed_row(meta: TrialMeta) -> dict[str, Any]:
    """trials.csv row of a trial that could not be analysed: names and sidecar values only."""
    row = dict.fromkeys(TRIAL_COLUMNS)
    row.update(subject=meta.subject, trial=meta.trial, waveform=meta.waveform,
               frequency_Hz=meta.frequency_Hz, amplitude_V=meta.amplitude_V,
               condition=meta.condition)
    return row


__all__ = ["SINE_TRACE_CSV_COLUMNS", "TRIAL_COLUMNS", "WINDOW_CSV_COLUMNS", "AnalysisSettings",
           "TrialMeta", "TrialResult", "analyze_signals", "empty_windows", "failed_row",
           "trial_start"]
