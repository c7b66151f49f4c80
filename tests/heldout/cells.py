"""The load cells: each samples on its own clock and reads the force with its flaws.

Per trial and cell: a zero offset and a linear drift of it, mains hum (the fundamental and
a third harmonic of a third of its size, each cell its own phase), white noise; per rig:
cross-talk between the axes (a matrix near identity); optionally creep, the strain gauge's
slow approach after a load change (the cell calibrated statically reads the load's
steady value, and a step shows at first short of it by ``creep`` of its size, the rest
arriving with time constant ``creep_tau_s``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from .config import Cells, Logger


@dataclass
class CellStream:
    """One cell's samples: true times (s from the trial's start), readings (N), counters."""

    t: np.ndarray
    value: np.ndarray
    counter: np.ndarray     # the node's frame number (before wrapping)
    offset_N: float         # its zero offset at the trial's start
    drift_N: float          # its zero's change over the trial


def crosstalk_matrix(cells: Cells, rng: np.random.Generator) -> np.ndarray:
    """[Fn_read, Ft_read] = X @ [Fn, Ft]: ones on the diagonal, ± crosstalk off it."""
    x = rng.uniform(-cells.crosstalk, cells.crosstalk, size=2)
    return np.array([[1.0, x[0]], [x[1], 1.0]])


def _creep(force: np.ndarray, dt: float, share: float, tau: float) -> np.ndarray:
    """The reading of a creeping gauge: F - share·(F - F low-passed over tau)."""
    if share == 0.0:
        return force
    a = np.exp(-dt / tau)
    low = lfilter([1.0 - a], [1.0, -a], force, zi=[a * force[0]])[0]
    return force - share * (force - np.asarray(low))


def _sample_times(duration: float, rate: float, ppm: float,
                  rng: np.random.Generator) -> np.ndarray:
    """A node's sample instants in true time: its own period, its own clock error."""
    period = 1.0 / (rate * (1.0 + ppm * 1e-6))
    start = rng.uniform(0.0, period)
    return start + period * np.arange(int((duration - start) / period))


def sample(t: np.ndarray, forces: tuple[np.ndarray, np.ndarray], xtalk: np.ndarray, *,
           cells: Cells, logger: Logger, rng: np.random.Generator) -> list[CellStream]:
    """Both cells' streams over a trial, from the true forces on the grid."""
    dt = t[1] - t[0]
    duration = t[-1] + dt
    crept = [_creep(f, dt, cells.creep, cells.creep_tau_s) for f in forces]
    seen = xtalk @ np.vstack(crept)
    streams = []
    for i, rate in enumerate(logger.rates_Hz):
        ppm = rng.uniform(-logger.clock_ppm, logger.clock_ppm)
        ts = _sample_times(duration, rate, ppm, rng)
        offset = rng.uniform(-cells.offset_N, cells.offset_N)
        drift = rng.uniform(-cells.drift_N, cells.drift_N)
        phase = rng.uniform(0, 2 * np.pi, size=2)
        w = 2 * np.pi * cells.mains_Hz
        hum = cells.hum_N * (np.sin(w * ts + phase[0]) + np.sin(3 * w * ts + phase[1]) / 3.0)
        value = (np.interp(ts, t, seen[i]) + offset + drift * ts / duration + hum
                 + rng.standard_normal(ts.size) * cells.noise_N)
        counter = np.arange(ts.size)
        if logger.drop_rate > 0:
            keep = rng.uniform(size=ts.size) >= logger.drop_rate
            ts, value, counter = ts[keep], value[keep], counter[keep]
        streams.append(CellStream(ts, value, counter, offset, drift))
    return streams
