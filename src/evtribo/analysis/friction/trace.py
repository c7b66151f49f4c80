"""A stretch of a sine trial's forces, for the model-versus-measurement figure (Figure 5).

``evtribo analyze`` writes ``sine_trace.csv`` (its columns are documented in
:mod:`evtribo.fit.tables`): for each sine trial with ON phases, a few seconds of the
aligned normal and friction forces around a switch from OFF to ON, averaged in blocks down
to at most ``rate_Hz``, with the drive's amplitude (0 while OFF) and frequency. The stretch
around each switch is cut at the finger's nearest reversals (where the friction swings
through zero, which the model does not describe), back to the last steady-sliding sample;
the switch chosen is the one whose stretch is longest in steady sliding.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
import pandas as pd

from evtribo.documents.tables import SINE_TRACE

__all__ = ["TRACE_COLUMNS", "sine_trace"]

#: Columns of sine_trace.csv (:data:`evtribo.documents.tables.SINE_TRACE`).
TRACE_COLUMNS = SINE_TRACE.names()


def _block_mean(x: npt.NDArray[np.float64], k: int) -> npt.NDArray[np.float64]:
    n = (x.size // k) * k
    if n == 0:
        return x[:0]
    blocks = x[:n].reshape(-1, k)
    valid = np.isfinite(blocks)
    count = valid.sum(axis=1)
    total = np.where(valid, blocks, 0.0).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def _between_reversals(a: int, i: int, b: int, flips: npt.NDArray[np.int64],
                       steady: npt.NDArray[np.bool_]) -> tuple[int, int]:
    """Narrow ``[a, b)`` around the switch *i* to the steady sliding between the nearest
    reversals (sign changes of the friction at *flips*) on either side."""
    after = flips[(flips > i) & (flips < b)]
    if after.size:
        st = np.flatnonzero(steady[i:after[0]])
        b = i + int(st[-1]) + 1 if st.size else int(after[0])
    before = flips[(flips >= a) & (flips <= i)]
    if before.size:
        st = np.flatnonzero(steady[before[-1]:i])
        a = int(before[-1]) + (int(st[0]) if st.size else 0)
    return a, b


def sine_trace(t: npt.NDArray[np.float64], normal: npt.NDArray[np.float64],
               tangential: npt.NDArray[np.float64], on: npt.NDArray[np.bool_],
               steady: npt.NDArray[np.bool_], *, amplitude_V: float, frequency_Hz: float,
               subject: str, trial: str, off_s: float = 0.5, on_s: float = 1.0,
               rate_Hz: float = 1000.0) -> pd.DataFrame | None:
    """The trace of one sine trial around its best switch from OFF to ON.

    Parameters
    ----------
    t : ndarray, s
        Uniform grid of the aligned forces.
    normal, tangential : ndarray, N
        Aligned forces (NaN in gaps); the tangential force's sign is dropped.
    on : ndarray of bool
        Whether the voltage is applied at each grid point (no guard time).
    steady : ndarray of bool
        Whether each grid point lies in a steady-sliding window (either condition).
    amplitude_V, frequency_Hz : float
        The drive's amplitude (V) and frequency (Hz).
    subject, trial : str
    off_s, on_s : float, s
        Extent before and after the switch. A trial that is ON from its start gives its
        first ``off_s + on_s`` seconds of ON.
    rate_Hz : float, Hz
        Highest sample rate of the trace.

    Returns
    -------
    pandas.DataFrame or None
        :data:`TRACE_COLUMNS`; None when the trial has no ON sample.
    """
    if t.size < 2 or not on.any():
        return None
    step = float(t[1] - t[0])
    n_off = round(off_s / step)
    n_on = round(on_s / step)
    switches = np.flatnonzero(on[1:] & ~on[:-1]) + 1
    sign = np.sign(np.nan_to_num(np.asarray(tangential, dtype=np.float64)))
    flips = np.flatnonzero(sign[:-1] * sign[1:] < 0) + 1  # the finger reverses
    best: tuple[float, int, int] | None = None
    for i in switches.tolist():
        a, b = max(0, i - n_off), min(t.size, i + n_on)
        a, b = _between_reversals(a, i, b, flips, steady)
        score = float(np.mean(steady[a:b])) * (b - a) / (n_off + n_on) if b > a else 0.0
        if best is None or score > best[0]:
            best = (score, a, b)
    if best is None:  # ON from the start (or the switch is not in the data)
        first = int(np.argmax(on))
        best = (0.0, first, min(t.size, first + n_off + n_on))
    _, a, b = best
    k = max(1, math.ceil((1.0 / step) / rate_Hz - 1e-3))  # 1 kHz * (1 + ppm) -> 1
    tt = _block_mean(t[a:b], k)
    out = pd.DataFrame({
        "subject": subject, "trial": trial,
        "time_s": np.round(tt - t[a], 6),
        "normal_force_N": _block_mean(normal[a:b], k),
        "friction_force_N": _block_mean(np.abs(tangential[a:b]), k),
        # a block that straddles the switch counts as ON from its first ON sample
        "amplitude_V": np.where(_block_mean(on[a:b].astype(np.float64), k) > 0,
                                float(amplitude_V), 0.0),
        "frequency_Hz": float(frequency_Hz),
    }, columns=list(TRACE_COLUMNS))
    return out
