"""How the frames reach the log: what a logger's clock and a USB adapter do to timestamps.

A frame is stamped by the logging host when it arrives, not when the cell sampled it
(``docs/simulator.md``): besides the latency and jitter of each frame (in
:mod:`~evtribo.acquisition.simulator.core`), a USB adapter delivers the frames in batches,
polled every millisecond or so, and stamps a whole batch at once; the host's clock runs at
its own rate (tens to hundreds of ppm from the cells' clocks); and an adapter that resets
loses every frame for a moment. :class:`Delivery` applies these to the frames' reception
times, chunk after chunk, in order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from evtribo.acquisition.simulator.config import TrialConfig

__all__ = ["Delivery"]

FloatArray = npt.NDArray[np.float64]

#: Frames of one batch are stamped this far apart, in arrival order, s.
BATCH_STEP_S = 1e-6
#: Shortest time between two outages, s.
MIN_BETWEEN_S = 1.0


@dataclass
class Delivery:
    """The logger's view of the frames' reception times.

    Attributes
    ----------
    burst_s : float, s
        Batch period (0: each frame stamped as it arrives).
    phase_s : float, s
        When the first batch arrives, within a batch period.
    clock : float
        The logger's seconds per true second, ``1 + ppm * 1e-6``.
    outages : ndarray, shape (n, 2), s
        Periods in which every frame is lost.
    """

    burst_s: float
    phase_s: float
    clock: float
    outages: FloatArray
    _last: tuple[float, int] = (-np.inf, -1)  # the last batch stamped, and its last rank

    @classmethod
    def draw(cls, config: TrialConfig, rng: np.random.Generator) -> Delivery:
        """The trial's delivery: its batch phase and its outages (Poisson, at least
        :data:`MIN_BETWEEN_S` apart), drawn with *rng*."""
        outages = []
        rate = config.outages_per_min / 60.0
        t = 0.0
        while rate > 0:
            t += float(rng.exponential(1.0 / rate))
            if t >= config.duration_s:
                break
            length = config.outage_s * float(rng.uniform(0.5, 1.5))
            outages.append((t, t + length))
            t += length + MIN_BETWEEN_S
        phase = float(rng.uniform(0, config.burst_s)) if config.burst_s > 0 else 0.0
        return cls(config.burst_s, phase, 1.0 + config.logger_ppm * 1e-6,
                   np.asarray(outages, dtype=np.float64).reshape(-1, 2))

    @property
    def ideal(self) -> bool:
        """Whether the log sees the reception times as they are."""
        return self.burst_s == 0 and self.clock == 1.0 and not len(self.outages)

    def lost(self, rx: npt.ArrayLike) -> npt.NDArray[np.bool_]:
        """Whether frames received at *rx* (s from the trial's start) fell in an outage."""
        rx = np.asarray(rx, dtype=np.float64)
        out = np.zeros(rx.shape, dtype=bool)
        for a, b in self.outages:
            out |= (rx >= a) & (rx < b)
        return out

    def stamps(self, rx: npt.ArrayLike) -> FloatArray:
        """The logger's timestamps of frames received at *rx* (s from the trial's start,
        sorted, each call after the last): batched, then on the logger's clock; still in
        arrival order."""
        rx = np.asarray(rx, dtype=np.float64)
        if self.burst_s > 0 and rx.size:
            batch = np.ceil((rx - self.phase_s) / self.burst_s)
            stamped = self.phase_s + batch * self.burst_s
            first = np.flatnonzero(np.concatenate(([True], np.diff(batch) != 0)))
            rank = np.arange(rx.size) - np.repeat(first, np.diff(np.append(first, rx.size)))
            if batch[0] == self._last[0]:  # the batch the last call ended in goes on
                rank[:first[1] if first.size > 1 else rx.size] += self._last[1] + 1
            self._last = (float(batch[-1]), int(rank[-1]))
            rx = stamped + BATCH_STEP_S * rank
        return np.asarray(rx * self.clock, dtype=np.float64)

    def periods(self) -> list[tuple[float, float]]:
        """The outages as ``(start_s, end_s)``."""
        return [(float(a), float(b)) for a, b in self.outages]
