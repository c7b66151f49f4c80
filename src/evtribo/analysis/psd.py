"""Welch's power spectral density, as ``scipy.signal.welch`` computes it with a Hann window
(periodic), half-overlapping segments, each segment's mean or linear trend removed, each
zero-padded to ``nfft`` points, one-sided density averaged over the segments; in numpy.

scipy 1.17 computes the segments' spectra one segment at a time in Python
(``ShortTimeFFT``, and ``scipy.signal.detrend``'s least squares for each segment's trend):
57 ms for the two minutes of a load cell at 4 kHz that the hum search (:mod:`.hum`) looks
at, twice per trial, 1.3 ms per window of a sine trial's friction (:mod:`.spectra`). Here
the segments are a strided view of the signal, detrended and transformed a batch at a
time: the same spectrum to within a few units in the last place
(``tests/analysis/test_psd.py`` holds it against scipy's), in a fraction of the time, and
without importing scipy.signal (0.5-0.6 s).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import numpy.typing as npt

__all__ = ["welch"]

#: Segments transformed at once (bounds the memory of a long signal's spectrum).
BATCH = 64


def _detrended(part: npt.NDArray[np.float64], detrend: str) -> npt.NDArray[np.float64]:
    """Each row of *part* less its mean, or less its least-squares line."""
    if detrend == "constant":
        return part - part.mean(axis=1, keepdims=True)
    n = part.shape[1]
    u = np.arange(n, dtype=np.float64)
    u -= u.mean()  # centred: the slope and the mean are fitted apart
    slope = (part @ u) / float(u @ u)
    return part - part.mean(axis=1, keepdims=True) - slope[:, None] * u


def welch(x: npt.ArrayLike, fs: float, nperseg: int, *, nfft: int | None = None,
          detrend: Literal["constant", "linear"] = "constant"
          ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """``scipy.signal.welch(x, fs=fs, nperseg=nperseg, nfft=nfft, detrend=detrend)`` of a
    1-D real signal.

    Parameters
    ----------
    x : array_like of float
        The signal, uniformly sampled, at least *nperseg* samples.
    fs : float, Hz
        Its sample rate.
    nperseg : int
        Samples per segment (at least 2); the segments overlap by half of it.
    nfft : int, optional
        Points of each segment's transform (zero-padded; default *nperseg*).
    detrend : {"constant", "linear"}
        What is removed from each segment: its mean, or its least-squares line.

    Returns
    -------
    f : ndarray of float64
        Frequencies, Hz (``nfft // 2 + 1`` of them).
    pxx : ndarray of float64
        Power spectral density, unit**2/Hz, averaged over the segments.
    """
    a = np.asarray(x, dtype=np.float64).ravel()
    if not 2 <= nperseg <= a.size:
        raise ValueError(f"nperseg must be between 2 and the signal's {a.size} samples, "
                         f"got {nperseg}")
    nfft = nperseg if nfft is None else int(nfft)
    if nfft < nperseg:
        raise ValueError(f"nfft must be at least nperseg ({nperseg}), got {nfft}")
    if detrend not in ("constant", "linear"):
        raise ValueError(f"detrend must be 'constant' or 'linear', got {detrend!r}")
    step = nperseg - nperseg // 2
    count = (a.size - nperseg) // step + 1
    window = 0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(nperseg) / nperseg)  # periodic Hann
    segments = np.lib.stride_tricks.sliding_window_view(a, nperseg)[::step][:count]
    total = np.zeros(nfft // 2 + 1)
    for k in range(0, count, BATCH):
        part = segments[k:k + BATCH]
        spectra = np.fft.rfft(_detrended(part, detrend) * window, n=nfft, axis=1)
        total += (spectra.real ** 2 + spectra.imag ** 2).sum(axis=0)
    pxx = total / count / (fs * float(np.sum(window * window)))
    pxx[1:-1 if nfft % 2 == 0 else None] *= 2.0  # one-sided: every line but DC (and Nyquist)
    return np.asarray(np.fft.rfftfreq(nfft, 1.0 / fs), dtype=np.float64), pxx
