"""Zero-phase IIR notch filters, as ``scipy.signal.iirnotch`` designs them and
``scipy.signal.filtfilt`` runs them (odd extension at both ends, the filter started in its
steady state for the first sample, forwards then backwards), without importing
scipy.signal (0.5-0.6 s, which every process that analysed a sine trial paid).

The filter's recursion is a banded lower-triangular solve (BLAS ``dtbsv`` from
scipy.linalg, 0.03 s to import): ``a * y = b * x`` with the initial state folded into the
first right-hand sides. scipy runs the same recursion in its transposed direct form, whose
roundings come in another order: the output agrees with scipy's to within ~1e-13 of the
signal (``tests/analysis/test_iir.py``).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

__all__ = ["filtfilt", "iirnotch", "lfilter"]

FloatArray = npt.NDArray[np.float64]


def iirnotch(w0: float, Q: float, fs: float) -> tuple[FloatArray, FloatArray]:
    """``scipy.signal.iirnotch(w0, Q, fs=fs)``: a second-order notch at *w0* Hz of quality
    factor *Q* (bandwidth ``w0 / Q`` at -3 dB).

    Parameters
    ----------
    w0 : float, Hz
        The frequency removed, between 0 and ``fs / 2``.
    Q : float
    fs : float, Hz
        The sample rate.

    Returns
    -------
    b, a : ndarray of float64
        Numerator and denominator (``a[0] == 1``).
    """
    w = 2.0 * float(w0) / float(fs)
    if not 0.0 <= w <= 1.0:
        raise ValueError("w0 should be such that 0 < w0 < fs / 2")
    bw = w / float(Q) * np.pi
    w *= np.pi
    gain = 1.0 / (1.0 + math.tan(bw / 2.0))
    b = gain * np.asarray([1.0, -2.0 * math.cos(w), 1.0])
    a = np.asarray([1.0, -2.0 * gain * math.cos(w), (2.0 * gain - 1.0)])
    return b, a


def _steady_state(b: FloatArray, a: FloatArray) -> FloatArray:
    """``scipy.signal.lfilter_zi(b, a)`` (with ``a[0] == 1`` and ``len(a) == len(b)``):
    the state of a filter that has seen only ones."""
    n = a.size
    companion = np.zeros((n - 1, n - 1))
    companion[0] = -a[1:]
    companion[np.arange(1, n - 1), np.arange(n - 2)] = 1.0
    return np.asarray(np.linalg.solve(np.eye(n - 1) - companion.T, b[1:] - a[1:] * b[0]),
                      dtype=np.float64)


def lfilter(b: npt.ArrayLike, a: npt.ArrayLike, x: npt.ArrayLike,
            zi: npt.ArrayLike | None = None) -> FloatArray:
    """``scipy.signal.lfilter(b, a, x, zi=zi)[0]`` of a 1-D signal, for ``a[0] == 1`` and
    ``b`` and ``a`` of one length.

    Parameters
    ----------
    b, a : array_like of float
        Numerator and denominator.
    x : array_like of float
    zi : array_like of float, optional
        The initial state (``len(a) - 1`` values, as scipy's transposed direct form holds
        it); zeros by default.

    Returns
    -------
    ndarray of float64
    """
    from scipy.linalg import blas

    b = np.asarray(b, dtype=np.float64)
    a = np.asarray(a, dtype=np.float64)
    if a.ndim != 1 or a.shape != b.shape or a.size < 2 or a[0] != 1.0:
        raise ValueError("a and b must be 1-D of one length (2 or more), with a[0] == 1")
    order = a.size - 1
    x = np.asarray(x, dtype=np.float64)
    rhs = b[0] * x
    for k in range(1, order + 1):
        rhs[k:] += b[k] * x[:-k]
    if zi is not None:
        z = np.asarray(zi, dtype=np.float64)
        m = min(order, x.size)
        rhs[:m] += z[:m]
    if not x.size:
        return rhs
    band = np.empty((order + 1, x.size), order="F")  # a's diagonals, lower band storage
    band[:] = a[:, None]
    return np.asarray(blas.dtbsv(order, band, rhs, lower=1, overwrite_x=1), dtype=np.float64)


def filtfilt(b: npt.ArrayLike, a: npt.ArrayLike, x: npt.ArrayLike, padlen: int
             ) -> FloatArray:
    """``scipy.signal.filtfilt(b, a, x, padlen=padlen)`` of a 1-D signal: filtered forwards
    and backwards (zero phase), each end extended by *padlen* samples reflected through it.

    Parameters
    ----------
    b, a : array_like of float
        Numerator and denominator, of one length, ``a[0] == 1``.
    x : array_like of float
        The signal, longer than *padlen* samples.
    padlen : int
        Samples added at each end.

    Returns
    -------
    ndarray of float64
    """
    b = np.asarray(b, dtype=np.float64)
    a = np.asarray(a, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 1 or not 0 <= padlen < x.size:
        raise ValueError(f"x must be 1-D and longer than padlen ({padlen}), "
                         f"got {x.size} samples")
    if padlen:
        ext = np.concatenate((2.0 * x[0] - x[padlen:0:-1], x,
                              2.0 * x[-1] - x[-2:-(padlen + 2):-1]))
    else:
        ext = x
    zi = _steady_state(b, a)
    y = lfilter(b, a, ext, zi * ext[0])
    y = lfilter(b, a, y[::-1], zi * y[-1])[::-1]
    return np.ascontiguousarray(y[padlen:y.size - padlen])
