"""Mains hum on the load cells: found in the spectrum, notched out.

Strain-gauge amplifiers pick up the mains (50 or 60 Hz, and its harmonics). A window's mean
over a fraction of a period keeps part of it, and a hum as large as a few mN is as large as
the effects the analysis looks for; it also stands out in the friction's spectrum, where a
sine drive's modulation is sought. :func:`find_hum` looks for a narrow peak at 50 or 60 Hz
(and at their harmonics) standing well above the spectrum around it (Welch's density,
``scipy.signal.welch``); :func:`remove_hum` notches those lines out with zero-phase IIR
notch filters (``scipy.signal.iirnotch``, run forwards and backwards by
``scipy.signal.filtfilt``), which leave the rest of the spectrum, steps included, as it was.
scipy.signal is imported where a hum is looked for (0.5 s, once per process).

A harmonic that coincides with a frequency the friction itself oscillates at (twice the
drive's frequency and its multiples) is not notched: it cannot be told apart from the physics.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

log = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]

#: Mains frequencies looked for, Hz.
MAINS_HZ = (50.0, 60.0)
#: A line counts as hum when its spectral density stands this many times above the
#: median density of the band around it.
PEAK_RATIO = 20.0
#: Harmonics looked at (1 = the fundamental).
MAX_HARMONIC = 7
#: Quality factor of the notches (bandwidth = f / Q: under 2 Hz at 50 Hz, wide enough for
#: the mains' own wander of +/-0.2 Hz).
NOTCH_Q = 30.0
#: A hum line closer than this to a frequency of the physics is left alone, Hz.
CLEARANCE_HZ = 3.0


@dataclass(frozen=True)
class Hum:
    """Hum found on one signal.

    Attributes
    ----------
    mains_Hz : float, Hz
        50 or 60.
    lines_Hz : tuple of float, Hz
        The lines found (the fundamental and harmonics) that are notched out.
    amplitude : float
        Amplitude of the fundamental, in the signal's unit (N).
    kept_Hz : tuple of float, Hz
        Lines found but left in, because the physics has a line there.
    """

    mains_Hz: float
    lines_Hz: tuple[float, ...]
    amplitude: float
    kept_Hz: tuple[float, ...] = ()


def _filled(x: FloatArray) -> FloatArray:
    """*x* with NaNs linearly interpolated (ends held), for filtering."""
    bad = ~np.isfinite(x)
    if not bad.any():
        return x
    good = np.flatnonzero(~bad)
    out = x.copy()
    out[bad] = np.interp(np.flatnonzero(bad), good, x[good])
    return out


def find_hum(x: npt.ArrayLike, rate_Hz: float, *, avoid_Hz: Sequence[float] = ()
             ) -> Hum | None:
    """Mains hum on a uniformly sampled signal, or None.

    Parameters
    ----------
    x : array_like of float
        The signal (NaN in gaps).
    rate_Hz : float, Hz
        Its sample rate.
    avoid_Hz : sequence of float, Hz
        Frequencies of the physics (a sine drive's friction modulation and its multiples):
        hum lines near them are reported in ``kept_Hz``, not notched.

    Returns
    -------
    Hum or None
        None when there is no hum line at 50 or 60 Hz (or the signal is too short or too
        slowly sampled to tell).
    """
    x = np.asarray(x, dtype=np.float64)
    finite = np.isfinite(x)
    if finite.sum() < 4 * rate_Hz / 10 or rate_Hz < 2.5 * min(MAINS_HZ):
        return None
    from scipy import signal

    y = _filled(x)
    nper = int(min(y.size, round(2.0 * rate_Hz)))  # 0.5 Hz resolution
    f, pxx = signal.welch(y, fs=rate_Hz, nperseg=nper)
    df = f[1] - f[0]

    def line(freq: float) -> tuple[float, float]:
        """(peak ratio, power) of a line at *freq*."""
        near = np.abs(f - freq) <= 1.0
        band = (np.abs(f - freq) <= 10.0) & (np.abs(f - freq) > 2.0)
        if not near.any() or band.sum() < 4:
            return 0.0, 0.0
        base = float(np.median(pxx[band]))
        peak = float(pxx[near].max())
        power = float(np.sum(pxx[near] - base) * df)
        return (peak / base if base > 0 else np.inf), max(power, 0.0)

    best = None
    for mains in MAINS_HZ:
        ratio, power = line(mains)
        if ratio >= PEAK_RATIO and (best is None or power > best[1]):
            best = (mains, power)
    if best is None:
        return None
    mains, power = best
    lines, kept = [], []
    for k in range(1, MAX_HARMONIC + 1):
        freq = k * mains
        if freq >= 0.45 * rate_Hz:
            break
        if k > 1 and line(freq)[0] < PEAK_RATIO:
            continue
        if any(abs(freq - a) < CLEARANCE_HZ for a in avoid_Hz):
            kept.append(freq)
        else:
            lines.append(freq)
    return Hum(mains_Hz=mains, lines_Hz=tuple(lines), amplitude=float(np.sqrt(2 * power)),
               kept_Hz=tuple(kept))


def remove_hum(x: npt.ArrayLike, rate_Hz: float, hum: Hum) -> FloatArray:
    """*x* with the lines of *hum* notched out (zero phase; NaNs stay NaN).

    Parameters
    ----------
    x : array_like of float
        The signal (NaN in gaps).
    rate_Hz : float, Hz
    hum : Hum
        What :func:`find_hum` found.

    Returns
    -------
    ndarray of float64
    """
    x = np.asarray(x, dtype=np.float64)
    if not hum.lines_Hz:
        return x.copy()
    from scipy import signal

    bad = ~np.isfinite(x)
    y = _filled(x)
    for freq in hum.lines_Hz:
        b, a = signal.iirnotch(freq, NOTCH_Q, fs=rate_Hz)
        # pad by a few time constants of the notch (Q periods), odd-extended
        y = signal.filtfilt(b, a, y, padlen=min(y.size - 1,
                                                int(3 * NOTCH_Q * rate_Hz / freq)))
    y[bad] = np.nan
    return y


def friction_oscillates(waveform: str | None, frequency_Hz: float | None,
                        rate_Hz: float) -> bool:
    """Whether the friction oscillates slowly enough to be seen at *rate_Hz*: at twice the
    drive's frequency, a sine's always, a square wave's when the layers conduct (a pulse
    after each edge). Such a trial's windows span whole periods of it and its hum is
    notched out (``hum = "auto"``).

    Parameters
    ----------
    waveform : str or None
    frequency_Hz : float or None
        The drive's frequency, Hz.
    rate_Hz : float
        The forces' sample rate, Hz.

    Returns
    -------
    bool
    """
    return (waveform in ("sine", "square") and bool(frequency_Hz)
            and 2 * float(frequency_Hz or 0) < 0.4 * rate_Hz)


def modulation_lines(waveform: str | None, frequency_Hz: float | None,
                     rate_Hz: float) -> list[float]:
    """Frequencies the friction itself may oscillate at: ``2 k f`` (up to the Nyquist
    frequency), for a sine drive and for a square wave (whose force pulses after each edge
    when the layers conduct), Hz.

    Parameters
    ----------
    waveform : str or None
        The drive's waveform (``"sine"``, ``"square"``...).
    frequency_Hz : float or None
        The drive's frequency, Hz.
    rate_Hz : float
        The forces' sampling rate, Hz.

    Returns
    -------
    list of float
        Hz; empty for other waveforms or an unknown frequency.
    """
    if waveform not in ("sine", "square") or not frequency_Hz:
        return []
    f2 = 2.0 * float(frequency_Hz)
    n = int(0.5 * rate_Hz // f2) if f2 > 0 else 0
    return [k * f2 for k in range(1, min(n, 50) + 1)]


__all__ = ["Hum", "find_hum", "friction_oscillates", "modulation_lines", "remove_hum"]
