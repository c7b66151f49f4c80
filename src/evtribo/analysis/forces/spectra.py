"""Dominant frequency of the friction's oscillation (Welch spectrum over windows).

Under a sine voltage the electrostatic force follows ``U(t)**2``, so the friction oscillates
at twice the drive frequency. Each ON window's friction magnitude, on the uniform grid, is
split into Hann-windowed, linearly detrended segments; the segments' power spectra are
averaged over all windows (weighted by segment count), zero-padded for a fine frequency grid
(``scipy.signal.welch``).
Among the highest local maxima above ``min_frequency_Hz`` the one that stands out most over
the spectrum around it (its power over a line through the log-log spectrum from a factor 1.5
below to 1.5 above it, its own peak left out) is the oscillation, if it stands out further
than noise would (twice the 99.9th percentile of an average of as many periodograms as were
averaged, and at least :data:`MIN_PROMINENCE`): the slow wander of a person's pressing force
has more power than a weak oscillation at low frequency, but no peak. Its frequency is
refined by a parabola through the peak bin and its neighbours.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
from scipy import special  # stats.chi2.isf is special.chdtri (scipy.stats: 0.5 s to import)

log = logging.getLogger(__name__)

#: The oscillation's peak stands at least this many times above the spectrum around it.
MIN_PROMINENCE = 3.0
#: Local maxima of the spectrum weighed for it.
CANDIDATES = 12


def dominant_frequency(
    segments: Sequence[npt.ArrayLike],
    rate_Hz: float,
    *,
    min_frequency_Hz: float = 2.0,
    max_frequency_Hz: float | None = None,
    segment_s: float = 1.0,
    resolution_Hz: float = 0.05,
) -> float:
    """Frequency of the highest spectral peak of a signal observed in several windows.

    Parameters
    ----------
    segments : sequence of array_like of float
        The signal in each window, uniformly sampled at *rate_Hz* (no NaN).
    rate_Hz : float, Hz
        Sample rate.
    min_frequency_Hz, max_frequency_Hz : float, Hz
        Band searched (default up to the Nyquist frequency).
    segment_s : float, s
        Longest Welch segment; windows shorter than the segment length used are skipped.
    resolution_Hz : float, Hz
        Frequency step of the zero-padded spectrum.

    Returns
    -------
    float
        Frequency in Hz; NaN when no window is long enough, the band is empty, or no peak
        stands out (:data:`MIN_PROMINENCE`).
    """
    from scipy import signal

    arrays = [np.asarray(s, dtype=np.float64) for s in segments]
    arrays = [a for a in arrays if a.size >= 16 and np.all(np.isfinite(a))]
    if not arrays:
        return float("nan")
    lengths = np.array([a.size for a in arrays])
    nperseg = int(min(round(segment_s * rate_Hz), np.median(lengths)))
    nfft = max(nperseg, int(2 ** np.ceil(np.log2(rate_Hz / resolution_Hz))))
    total = None
    weight = 0
    for a in arrays:
        if a.size < nperseg:
            continue
        freqs, pxx = signal.welch(a, fs=rate_Hz, nperseg=nperseg, nfft=nfft,
                                  detrend="linear")
        nseg = 1 + (a.size - nperseg) // (nperseg // 2)
        total = pxx * nseg if total is None else total + pxx * nseg
        weight += nseg
    if total is None:
        return float("nan")
    fmax = rate_Hz / 2 if max_frequency_Hz is None else min(max_frequency_Hz, rate_Hz / 2)
    band = (freqs >= min_frequency_Hz) & (freqs <= fmax)
    if not band.any():
        return float("nan")
    idx = np.flatnonzero(band)
    best = _most_prominent(freqs[idx], total[idx], resolution=2.0 * rate_Hz / nperseg,
                           averaged=weight)
    if best is None:
        return float("nan")
    k = int(idx[best])
    if 0 < k < total.size - 1:
        y0, y1, y2 = np.log(total[k - 1: k + 2] + 1e-300)
        denom = y0 - 2 * y1 + y2
        shift = 0.5 * (y0 - y2) / denom if denom < 0 else 0.0
        return float(freqs[k] + shift * (freqs[1] - freqs[0]))
    return float(freqs[k])


def _most_prominent(freqs: npt.NDArray[np.float64], spec: npt.NDArray[np.float64], *,
                    resolution: float, averaged: int) -> int | None:
    """Index of the local maximum of *spec* that stands out most over the spectrum around
    it, if it stands out further than noise would; else None."""
    peaks = np.flatnonzero((spec[1:-1] > spec[:-2]) & (spec[1:-1] >= spec[2:])) + 1
    peaks = peaks[np.argsort(spec[peaks])[::-1][:CANDIDATES]]
    best, best_prominence = None, 0.0
    for j in peaks:
        fj = freqs[j]
        around = (freqs >= fj / 1.5) & (freqs <= fj * 1.5) & (np.abs(freqs - fj) > resolution)
        if around.sum() < 4:
            continue
        # the background under the peak: a line through the log-log spectrum around it
        # (a wander's spectrum falls steeply with frequency)
        slope, intercept = np.polyfit(np.log(freqs[around]),
                                      np.log(spec[around] + 1e-300), 1)
        background = float(np.exp(intercept + slope * np.log(fj)))
        prominence = spec[j] / max(background, 1e-300)
        if prominence > best_prominence:
            best, best_prominence = int(j), prominence
    # an average of `averaged` periodograms: noise alone rarely stands out that far
    needed = max(MIN_PROMINENCE, 2.0 * special.chdtri(2 * averaged, 1e-3) / (2 * averaged))
    return best if best_prominence >= needed else None


__all__ = ["MIN_PROMINENCE", "dominant_frequency"]
