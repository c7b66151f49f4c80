"""Welch's power spectral density of a long signal, as ``scipy.signal.welch`` computes it
with its defaults (a periodic Hann window, half-overlapping segments, each segment's mean
removed, one-sided density), in numpy.

scipy 1.17 computes the segments' spectra one segment at a time in Python
(``ShortTimeFFT``): 57 ms for the two minutes of a load cell at 4 kHz that the hum search
(:mod:`.hum`) looks at, twice per trial. Here the segments are a strided view of the signal,
transformed a batch at a time: the same spectrum to within a few units in the last place
(``tests/analysis/test_psd.py`` holds it against scipy's), in a fraction of the time, and
without importing scipy.signal (0.6 s) for a trial that turns out to have no hum.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["welch"]

#: Segments transformed at once (bounds the memory of a long signal's spectrum).
BATCH = 64


def welch(x: npt.ArrayLike, fs: float, nperseg: int
          ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """``scipy.signal.welch(x, fs=fs, nperseg=nperseg, detrend="constant")`` of a 1-D real
    signal.

    Parameters
    ----------
    x : array_like of float
        The signal, uniformly sampled, at least *nperseg* samples.
    fs : float, Hz
        Its sample rate.
    nperseg : int
        Samples per segment (at least 2); the segments overlap by half of it.

    Returns
    -------
    f : ndarray of float64
        Frequencies, Hz (``nperseg // 2 + 1`` of them).
    pxx : ndarray of float64
        Power spectral density, unit**2/Hz, averaged over the segments.
    """
    a = np.asarray(x, dtype=np.float64).ravel()
    if not 2 <= nperseg <= a.size:
        raise ValueError(f"nperseg must be between 2 and the signal's {a.size} samples, "
                         f"got {nperseg}")
    step = nperseg - nperseg // 2
    count = (a.size - nperseg) // step + 1
    window = 0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(nperseg) / nperseg)  # periodic Hann
    segments = np.lib.stride_tricks.sliding_window_view(a, nperseg)[::step][:count]
    total = np.zeros(nperseg // 2 + 1)
    for k in range(0, count, BATCH):
        part = segments[k:k + BATCH]
        spectra = np.fft.rfft((part - part.mean(axis=1, keepdims=True)) * window, axis=1)
        total += (spectra.real ** 2 + spectra.imag ** 2).sum(axis=0)
    pxx = total / count / (fs * float(np.sum(window * window)))
    pxx[1:-1 if nperseg % 2 == 0 else None] *= 2.0  # one-sided: every line but DC (and Nyquist)
    return np.asarray(np.fft.rfftfreq(nperseg, 1.0 / fs), dtype=np.float64), pxx
