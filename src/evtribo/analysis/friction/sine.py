"""What a sine trial gives besides its windows: the friction's modulation frequency
(``friction_modulation_Hz`` of trials.csv) and its forces around a switch to ON
(sine_trace.csv, :mod:`.trace`)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from evtribo.analysis.forces.align import AlignedForces
from evtribo.analysis.forces.conditions import ON
from evtribo.analysis.forces.excitation import Excitation
from evtribo.analysis.forces.spectra import dominant_frequency
from evtribo.analysis.friction.trace import sine_trace
from evtribo.analysis.settings import AnalysisSettings
from evtribo.warning.collect import emitter

__all__ = ["friction_modulation", "trace_around_switch"]

emit = emitter(__name__)


def _sine_segments(aligned: AlignedForces, windows: pd.DataFrame
                   ) -> list[npt.NDArray[np.float64]]:
    """Friction magnitude over runs of back-to-back ON windows (split windows rejoined)."""
    on = windows[windows.condition == "on"].sort_values("i_start")
    segs: list[tuple[int, int]] = []
    for a, b in zip(on.i_start.to_numpy(int), on.i_stop.to_numpy(int), strict=True):
        if segs and segs[-1][1] == a:
            segs[-1] = (segs[-1][0], b)
        else:
            segs.append((a, b))
    return [np.abs(aligned.tangential[a:b]) for a, b in segs]


def friction_modulation(aligned: AlignedForces, w: pd.DataFrame, info: Mapping[str, Any]
                        ) -> float | None:
    """The friction's dominant frequency over the ON windows of a sine trial (why none is
    found is said: ``modulation``, ``modulation-none``).

    Parameters
    ----------
    aligned : AlignedForces
        The trial's forces, tared.
    w : pandas.DataFrame
        Its steady-sliding windows (``condition``, ``i_start``, ``i_stop``).
    info : mapping
        The trial's excitation (``frequency_Hz``: the drive's).

    Returns
    -------
    float or None
        Hz; None without ON windows, beyond the sampling's reach, or when no oscillation
        stands out.
    """
    if not (w.condition == "on").any():
        return None
    drive = info.get("frequency_Hz")
    if drive and 2 * float(drive) >= 0.8 * aligned.rate_Hz / 2:
        emit("modulation", frequency_Hz=drive, rate_Hz=aligned.rate_Hz)
        return None
    f = dominant_frequency(_sine_segments(aligned, w), aligned.rate_Hz)
    if not np.isfinite(f):
        emit("modulation-none")
        return None
    return float(f)


def trace_around_switch(aligned: AlignedForces, w: pd.DataFrame, exc: Excitation, *,
                        subject: str, trial: str, settings: AnalysisSettings
                        ) -> pd.DataFrame | None:
    """A sine trial's forces around a switch to ON.

    Parameters
    ----------
    aligned : AlignedForces
        The trial's forces, tared.
    w : pandas.DataFrame
        Its steady-sliding windows (``i_start``, ``i_stop``).
    exc : Excitation
        Its excitation (when the voltage was on).
    subject, trial : str
        The trial's names.
    settings : AnalysisSettings
        ``trace_off_s``, ``trace_on_s``, ``trace_rate_Hz``.

    Returns
    -------
    pandas.DataFrame or None
        Rows of sine_trace.csv (:func:`.trace.sine_trace`); None without a switch to ON.
    """
    if exc.t is not None and exc.enabled is not None:
        idx = np.searchsorted(exc.t, aligned.t, side="right") - 1
        on_now = np.where(idx >= 0, exc.enabled[np.clip(idx, 0, None)], False)
    else:
        on_now = exc.condition == ON
    steady = np.zeros(aligned.t.size, dtype=bool)
    for a, b in zip(w.i_start.to_numpy(int), w.i_stop.to_numpy(int), strict=True):
        steady[a:b] = True
    info = exc.info
    return sine_trace(aligned.t, aligned.normal, aligned.tangential, on_now, steady,
                      amplitude_V=float(info["amplitude_V"] or np.nan),
                      frequency_Hz=float(info["frequency_Hz"] or np.nan),
                      subject=subject, trial=trial, off_s=settings.trace_off_s,
                      on_s=settings.trace_on_s, rate_Hz=settings.trace_rate_Hz)
