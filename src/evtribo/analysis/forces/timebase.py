"""A load cell's sample times, taken back from the timestamps a logger gave its frames.

A load cell samples on its own clock, one sample every period ``P``; the logger stamps each
frame when it arrives. Between the two lie the bus, the adapter and the host: frames arrive
late by a latency that varies (0.1-1 ms and more on USB adapters and busy hosts), in
batches that get one timestamp, and the host's clock runs at its own rate. Used as they are,
such timestamps reorder samples, open false gaps where a batch was late and close real ones
(``docs/analysis.md``, "Timing as loggers deliver it").

The cure is the one data-acquisition systems use (Lab Streaming Layer's ``dejitter``
processing, pyxdf's ``dejitter_timestamps``): the sample's index in its stream is known, so
its time is a straight line in the index, ``t_k = a + P k``, fitted to all the timestamps by
least squares; the line keeps the clocks' rates and the mean latency and drops the jitter.
Here the line is piecewise (a knot every :data:`KNOT_S` seconds, continuous), so that it
follows a clock whose rate wanders, and fitted again without the frames far off it (a
stall of the logger). The index comes from

- **the cell's rolling counter** when the rig names one: ``+1`` per frame modulo the
  counter's period, so lost frames keep their places; an outage longer than the counter's
  period is added in whole periods from the timing;
- **the frames' order** otherwise;

and the frames lost in a gap of the timestamps (beyond what a counter counts) from the
persistent shift the gap leaves in them: a late batch, or a logger that stalls and then
delivers its backlog at once, shifts the timestamps only for a moment.

A stream whose timestamps do not follow such a line (a node that sends on change, not
periodically) keeps its timestamps as they are; :func:`placed_among` puts such a stream's
frames (the amplifier's status) on the load cells' sample times by where they arrived among
the cells' frames: a bus delivers frames in the order they were sent, so a status frame
logged between two cell frames late by a stall was sent between their samples, however late
all three were stamped.
"""

from __future__ import annotations

import itertools
import logging
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from evtribo.analysis.forces.pieces import MAX_PAUSE_S
from evtribo.util.median import median

log = logging.getLogger(__name__)

__all__ = ["KNOT_S", "placed_among", "sample_times"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: Time between the knots of the piecewise line, s.
KNOT_S = 5.0
#: Fewest samples a stream needs to be taken back to its clock.
MIN_SAMPLES = 50
#: Timestamps farther from the line than this many robust standard deviations (and than
#: one period) are left out of the second fit.
OUTLIER_SD = 4.0
#: A stream without a counter whose timestamps stray from the line by more than this many
#: periods (robust standard deviation) is not periodic: its timestamps are kept.
MAX_SPREAD_PERIODS = 20.0
#: Fewest frames on each side of a gap over which the shift it leaves is measured (no
#: counter).
SHIFT_FRAMES = 200
#: A stream without a counter whose gaps would hide more frames than this share of those
#: received is not taken for a periodic one.
MAX_LOST_SHARE = 0.25
#: Most outages longer than a counter's period looked for in one stream.
MAX_OUTAGES = 20
#: A stream is taken back to its clock stretch by stretch where it pauses for longer than
#: this many of its usual (median) steps (and than the analysis's pieces allow).
PAUSE_STEPS = 1000


def _counter_index(counter: IntArray, period: int | None = None) -> tuple[IntArray, int]:
    """The samples' indices from a rolling counter: its steps modulo its period (*period*,
    else a power of two above its largest value; a repeated value, a frame sent twice,
    keeps its index), and that period."""
    modulus = period or 1 << max(1, int(counter.max()).bit_length())
    step = np.mod(np.diff(counter), modulus)
    return np.concatenate(([0], np.cumsum(step))).astype(np.int64), modulus


def _line_spread(index: IntArray, t: FloatArray) -> float:
    """Median absolute deviation of the timestamps from one straight line in the index."""
    x = index.astype(np.float64)
    slope, icpt = np.polyfit(x - x[0], t - t[0], 1)
    resid = t - t[0] - (icpt + slope * (x - x[0]))
    return median(np.abs(resid - median(resid)))


def _counter_periods_lost(t: FloatArray, index: IntArray, period: float, modulus: int
                          ) -> IntArray:
    """*index* with whole counter periods added where an outage was longer than the
    counter's period: at each step of the timestamps longer than half a counter period, the
    number of periods whose adding makes the timestamps straightest in the index (a stalled
    logger that delivers its backlog late is no outage: adding periods there bends them).
    The numbers tried are those next to the step's own length in counter periods, so that a
    counter of a short period costs no more than one of a long period."""
    steps = np.diff(t) - period * np.diff(index)
    out = index.copy()
    for j in np.argsort(steps)[::-1][:MAX_OUTAGES]:
        if steps[j] <= 0.5 * modulus * period:
            break
        best, spread = 0, _line_spread(out, t)
        whole = round(steps[j] / (modulus * period))
        for k in range(max(1, whole - 1), whole + 2):
            trial = out.copy()
            trial[j + 1:] += k * modulus
            value = _line_spread(trial, t)
            if value < 0.8 * spread:
                best, spread = k, value
        out[j + 1:] += best * modulus
    return out


def _ordinal_lost(t: FloatArray, index: IntArray, period: float) -> IntArray:
    """*index* (the frames' order) with the frames lost in each gap of the timestamps added.

    A gap (a step over three periods beyond the jitter) is a loss only when it leaves a
    persistent shift: the timestamps' medians over a second (at least
    :data:`SHIFT_FRAMES` frames) on each side, less the index's own advance, apart by more
    than their jitter allows. A late batch shifts a few timestamps, and a stalled logger
    delivers its backlog at once and catches up; a loss shifts all that follow.
    """
    n = t.size
    w = max(1, min(SHIFT_FRAMES, n // 4))
    period = median((t[w:] - t[:-w]) / w)  # unmoved by the few spans across a loss
    resid = t - period * index
    steps = np.diff(t)
    # the timestamps' jitter from their steps alone (a loss is one step among thousands)
    jitter = max(1.4826 * median(np.abs(steps - median(steps))) / np.sqrt(2.0), 0.1 * period)
    width = max(SHIFT_FRAMES, round(1.0 / period))
    noise = 4.0 * 1.25 * jitter * np.sqrt(2.0 / width)
    extra = np.zeros(n, dtype=np.int64)
    for j in np.flatnonzero(steps > 3 * period + 4 * jitter):
        before = median(resid[max(0, j - width + 1):j + 1])
        after = median(resid[j + 1:j + 1 + width])
        shift = after - before
        lost = round(shift / period) if shift > max(0.5 * period, noise) else 0
        if lost > 0:
            extra[j + 1] += lost
            resid[j + 1:] -= lost * period
    return index + np.cumsum(extra)


@dataclass(frozen=True)
class _Hats:
    """The piecewise-linear basis at sorted *x*, one column per knot: between two knots, a
    point's place ``u`` (0 at the left knot, 1 at the right). The points of a segment are
    contiguous, so every sum is a dot product over a slice."""

    bounds: IntArray  # the points of segment s are [bounds[s], bounds[s + 1])
    u: FloatArray
    k: int

    @classmethod
    def at(cls, x: FloatArray, knots: FloatArray) -> _Hats:
        bounds = np.searchsorted(x, knots, side="left")
        bounds[0], bounds[-1] = 0, x.size
        u = np.empty(x.size)
        for s in range(knots.size - 1):
            a, b = bounds[s], bounds[s + 1]
            u[a:b] = (x[a:b] - knots[s]) / (knots[s + 1] - knots[s])
        return cls(bounds.astype(np.int64), u, int(knots.size))

    def __call__(self, coef: FloatArray) -> FloatArray:
        out = np.empty(self.u.size)
        for s in range(self.k - 1):
            a, b = self.bounds[s], self.bounds[s + 1]
            out[a:b] = coef[s] + (coef[s + 1] - coef[s]) * self.u[a:b]
        return out

    def solve(self, y: FloatArray, weight: FloatArray) -> FloatArray:
        """Least-squares coefficients of *y*, each point weighted by *weight* (0 or 1: left
        out or in), from the normal equations (tridiagonal, summed segment by segment)."""
        k = self.k
        ata = np.zeros((k, k))
        aty = np.zeros(k)
        for s in range(k - 1):
            a, b = self.bounds[s], self.bounds[s + 1]
            u, w, ys = self.u[a:b], weight[a:b], y[a:b]
            wu, wv = w * u, w - w * u
            v = 1.0 - u
            ata[s, s] += wv @ v
            ata[s + 1, s + 1] += wu @ u
            ata[s, s + 1] += wu @ v
            ata[s + 1, s] = ata[s, s + 1]
            aty[s] += wv @ ys
            aty[s + 1] += wu @ ys
        if k > 2:  # a whisper of smoothness: a knot with no point near it follows its
            d2 = np.diff(np.eye(k), 2, axis=0)  # neighbours instead of making it singular
            ata += 1e-9 * max(float(np.mean(np.diag(ata))), 1.0) * (d2.T @ d2)
        return np.asarray(np.linalg.solve(ata, aty), dtype=np.float64)


def _fit_line(index: IntArray, t: FloatArray, period: float) -> tuple[FloatArray, float]:
    """The piecewise line through ``(index, t)``, fitted twice (the second time without
    the timestamps far off the first), and the robust spread of the timestamps about it."""
    x = index.astype(np.float64)
    span = float(x[-1] - x[0])
    knots = np.linspace(x[0], x[-1], max(1, round(span * period / KNOT_S)) + 1)
    basis = _Hats.at(x, knots)
    y = t - t[0]
    coef = basis.solve(y, np.ones(x.size))
    resid = y - basis(coef)
    spread = 1.4826 * median(np.abs(resid - median(resid)))
    keep = np.abs(resid) <= max(OUTLIER_SD * spread, period)
    if keep.sum() >= 2 * basis.k + 2:
        coef = basis.solve(y, keep.astype(np.float64))
        resid = y - basis(coef)
        spread = 1.4826 * median(np.abs(resid - median(resid)))
    return t[0] + basis(coef), spread


def sample_times(t: npt.ArrayLike, counter: npt.ArrayLike | None = None,
                 period: int | None = None) -> FloatArray:
    """A periodic stream's sample times, from its frames' timestamps (and counter).

    A stream whose clock jumps ahead by more than
    :data:`~evtribo.analysis.forces.pieces.MAX_PAUSE_S` and :data:`PAUSE_STEPS` of its
    usual steps (or pauses that long) is taken back to its clock stretch by stretch, as the
    analysis takes its pieces: what it costs grows with the frames, not with the time the
    clock's jump spans.

    Parameters
    ----------
    t : array_like of float, s
        The frames' timestamps as logged, in the order logged.
    counter : array_like of int, optional
        The stream's rolling frame counter, one value per frame.
    period : int, optional
        Frames after which the counter repeats (default: the next power of two above its
        largest value; :attr:`evtribo.canlog.signals.CellSignals.counter_period`).

    Returns
    -------
    ndarray of float64, s
        One time per frame, increasing: the timestamps without their jitter; the timestamps
        themselves when the stream is too short, or not periodic.
    """
    t = np.asarray(t, dtype=np.float64)
    if t.size < MIN_SAMPLES or not np.isfinite(t).all():
        return t
    c = None if counter is None else np.asarray(counter, dtype=np.int64)
    if c is not None and c.size != t.size:
        c = None
    steps = np.diff(np.maximum.accumulate(t))
    cuts = np.flatnonzero(steps > max(MAX_PAUSE_S, PAUSE_STEPS * median(steps))) + 1
    if not cuts.size:
        return _stretch_times(t, c, period)
    bounds = np.concatenate([[0], cuts, [t.size]])
    return np.concatenate([_stretch_times(t[a:b], None if c is None else c[a:b], period)
                           for a, b in itertools.pairwise(bounds)])


def _stretch_times(t: FloatArray, c: IntArray | None, counter_period: int | None
                   ) -> FloatArray:
    """:func:`sample_times` of a stretch of a stream without a long pause."""
    if t.size < MIN_SAMPLES:
        return t
    order_ok = bool(np.all(np.diff(t) >= 0))
    ts = t if order_ok else np.maximum.accumulate(t)
    steps = np.diff(ts)
    if not np.any(steps > 0):
        return t
    counted = c is not None and (c.max() > 0 or bool(counter_period))
    if counted:
        assert c is not None
        index, modulus = _counter_index(c, counter_period)
    else:
        index = np.arange(t.size, dtype=np.int64)
    if index[-1] <= index[0]:
        return t
    period = float(ts[-1] - ts[0]) / float(index[-1] - index[0])  # losses still left out
    index = (_counter_periods_lost(ts, index, period, modulus) if counted
             else _ordinal_lost(ts, index, period))
    if not counted and index[-1] - index[0] > MAX_LOST_SHARE * t.size + t.size - 1:
        return t  # gaps everywhere: not a periodic stream (or one too lossy to time)
    period = float(ts[-1] - ts[0]) / float(index[-1] - index[0])
    fitted, spread = _fit_line(index, ts, period)
    # the counter says which sample each frame holds, however late the logger stamped it;
    # without one, timestamps far off any line are no periodic stream's
    if not (counted or spread <= MAX_SPREAD_PERIODS * period) \
            or not np.all(np.diff(fitted) >= 0):
        log.debug("timestamps kept: they stray %.3g s from a periodic clock", spread)
        return t
    return fitted


def placed_among(t: npt.ArrayLike, stamps: npt.ArrayLike, times: npt.ArrayLike) -> FloatArray:
    """Another stream's frames put on a periodic stream's sample times, by where they arrived
    among its frames.

    The frames of one bus arrive in the order they were sent, and a logger stamps them in
    that order; a frame stamped between two of the periodic stream's frames was sent between
    their samples. Its time is read off the line from the periodic stream's timestamps to
    its sample times (:func:`sample_times`), through the two frames around it; before the
    first and after the last, the nearest frame's shift is kept. Frames stamped alike (a
    batch) take their sample times' mean.

    Parameters
    ----------
    t : array_like of float, s
        The other stream's timestamps as logged.
    stamps : array_like of float, s
        The periodic stream's timestamps as logged (several streams' together, in any
        order).
    times : array_like of float, s
        Their sample times, one per timestamp.

    Returns
    -------
    ndarray of float64, s
        One time per frame of *t* (non-finite ones kept); *t* itself when there is no
        finite pair of *stamps* and *times*.
    """
    t = np.asarray(t, dtype=np.float64)
    x = np.asarray(stamps, dtype=np.float64).ravel()
    y = np.asarray(times, dtype=np.float64).ravel()
    ok = np.isfinite(x) & np.isfinite(y)
    if not ok.any() or t.size == 0:
        return t
    order = np.argsort(x[ok], kind="stable")
    x, shift = x[ok][order], (y[ok] - x[ok])[order]
    unique, group = np.unique(x, return_inverse=True)
    mean_shift = np.bincount(group, shift) / np.bincount(group)
    out = t.copy()
    finite = np.isfinite(t)
    out[finite] = t[finite] + np.interp(t[finite], unique, mean_shift)
    return out
