"""What the simulated load cells add to the true forces.

A cell does not read the true force: it has a zero offset that drifts (linearly and with a
slow thermal settling) and picks up mains hum (:class:`CellZero`), and the two axes leak into
each other through a cross-talk matrix (:func:`measured`); strain gauges creep after a change
of load (:class:`Creep`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.signal import lfilter

__all__ = ["CellZero", "Creep", "measured"]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class CellZero:
    """What a load cell reads with no force on it: offset, drift, thermal settling, hum.

    ``zero(t) = offset + drift * t + thermal * (1 - exp(-t / thermal_time)) + hum(t)``, the
    hum a sine at the mains frequency with a third harmonic of a fifth of its amplitude.

    Attributes
    ----------
    offset_N : float, N
    drift_N_per_s : float, N/s
    thermal_N : float, N
    thermal_time_s : float, s
    hum_N : float, N
    mains_Hz : float, Hz
    hum_phase : tuple of float, rad
        Phases of the fundamental and of the third harmonic.
    """

    offset_N: float = 0.0
    drift_N_per_s: float = 0.0
    thermal_N: float = 0.0
    thermal_time_s: float = 60.0
    hum_N: float = 0.0
    mains_Hz: float = 50.0
    hum_phase: tuple[float, float] = (0.0, 0.0)

    def offset(self, t: npt.ArrayLike) -> FloatArray:
        """The zero without the hum at times *t* (s), N."""
        t = np.asarray(t, dtype=np.float64)
        return (self.offset_N + self.drift_N_per_s * t
                + self.thermal_N * -np.expm1(-t / self.thermal_time_s))

    def mean_offset(self, t0: float, t1: float) -> float:
        """Mean of :meth:`offset` over ``[t0, t1]`` (s), N."""
        if t1 <= t0:
            return float(self.offset(t0))
        tau = self.thermal_time_s
        thermal = 1.0 + tau * (math.exp(-t1 / tau) - math.exp(-t0 / tau)) / (t1 - t0)
        return (self.offset_N + self.drift_N_per_s * 0.5 * (t0 + t1)
                + self.thermal_N * thermal)

    def hum(self, t: npt.ArrayLike) -> FloatArray:
        """The mains hum at times *t* (s), N."""
        t = np.asarray(t, dtype=np.float64)
        if self.hum_N == 0:
            return np.zeros(t.shape)
        w = 2 * np.pi * self.mains_Hz * t
        return self.hum_N * (np.sin(w + self.hum_phase[0])
                             + 0.2 * np.sin(3 * w + self.hum_phase[1]))

    def __call__(self, t: npt.ArrayLike) -> FloatArray:
        return self.offset(t) + self.hum(t)


def measured(row: tuple[float, float], normal_N: npt.ArrayLike, tangential_N: npt.ArrayLike,
             zero: CellZero, t: npt.ArrayLike) -> FloatArray:
    """One cell's reading: its row of the cross-talk matrix applied to the true forces, plus
    its zero (noise is added by the caller), N.

    Parameters
    ----------
    row : (float, float)
        The cell's row of the cross-talk matrix (normal, tangential).
    normal_N, tangential_N : array_like, N
        The true forces.
    zero : CellZero
        The cell's zero offset and drift.
    t : array_like, s
        Times from the trial's start.

    Returns
    -------
    ndarray, N
    """
    return (row[0] * np.asarray(normal_N, dtype=np.float64)
            + row[1] * np.asarray(tangential_N, dtype=np.float64) + zero(t))


class Creep:
    """A strain-gauge cell's creep: after a change of load its reading first falls short of
    the change by a fraction ``creep`` and approaches it with time constant ``tau``.

    ``reading = F - creep * (F - F_slow)``, with ``F_slow`` the load through a first-order
    low-pass of time constant ``tau`` (its state carried from one call to the next, so that
    a stream of chunks gives the same readings as one call).

    Parameters
    ----------
    creep : float
        Fraction of a change of load not yet read at first (0: no creep).
    tau_s : float, s
        Time constant of the approach.
    """

    def __init__(self, creep: float, tau_s: float) -> None:
        self.creep, self.tau_s = float(creep), float(tau_s)
        self._slow: float | None = None
        self._t: float | None = None

    def __call__(self, t: npt.ArrayLike, load: npt.ArrayLike) -> FloatArray:
        """The reading of *load* (N) sampled at times *t* (s, increasing and evenly spaced,
        as a cell samples), N."""
        x = np.asarray(load, dtype=np.float64)
        if self.creep == 0 or x.size == 0:
            return x
        t = np.asarray(t, dtype=np.float64)
        if self._slow is None or self._t is None:
            self._slow, self._t = float(x[0]), float(t[0])
        step = float(np.median(np.diff(t))) if t.size > 1 else float(t[0] - self._t)
        a = math.exp(-max(step, 0.0) / self.tau_s)
        slow, _ = lfilter([1.0 - a], [1.0, -a], x, zi=[a * self._slow])
        self._slow, self._t = float(slow[-1]), float(t[-1])
        return np.asarray(x - self.creep * (x - slow), dtype=np.float64)
