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
- **the frames' order** otherwise, with the frames lost in a gap counted from the persistent
  shift it leaves in the timestamps (a late batch shifts them only for a moment).

A stream whose timestamps do not follow such a line (a node that sends on change, not
periodically) keeps its timestamps as they are.
"""

from __future__ import annotations

import logging

import numpy as np
import numpy.typing as npt

from evtribo.median import median

log = logging.getLogger(__name__)

__all__ = ["KNOT_S", "sample_times"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: Time between the knots of the piecewise line, s.
KNOT_S = 5.0
#: Fewest samples a stream needs to be taken back to its clock.
MIN_SAMPLES = 50
#: Timestamps farther from the line than this many robust standard deviations (and than
#: one period) are left out of the second fit.
OUTLIER_SD = 4.0
#: A stream whose timestamps stray from the line by more than this many periods (robust
#: standard deviation) is not periodic: its timestamps are kept.
MAX_SPREAD_PERIODS = 20.0
#: Frames on each side of a gap over which the shift it leaves is measured (no counter).
SHIFT_FRAMES = 200


def _unwrap_counter(t: FloatArray, counter: IntArray, period: float) -> IntArray:
    """The samples' indices from a rolling counter: its steps modulo its period (a power of
    two above its largest value), whole periods added where the timing says they were lost;
    a repeated value (a frame sent twice) keeps its index."""
    modulus = 1 << max(1, int(counter.max()).bit_length())
    step = np.mod(np.diff(counter), modulus)
    gap = np.diff(t) / period
    lost_periods = np.maximum(np.round((gap - step) / modulus), 0).astype(np.int64)
    return np.concatenate(([0], np.cumsum(step + modulus * lost_periods))).astype(np.int64)


def _ordinal_index(t: FloatArray, period: float) -> IntArray:
    """The samples' indices from their order, with the frames lost in a gap counted from the
    persistent shift it leaves: the timestamps' medians over :data:`SHIFT_FRAMES` frames
    on each side, apart by more than their jitter allows (a late batch shifts a few
    timestamps, a loss all that follow)."""
    n = t.size
    index = np.arange(n, dtype=np.int64)
    resid = t - period * index
    jitter = _fit_line(index, t, period)[1]
    # what the medians of two sets of SHIFT_FRAMES timestamps differ by, at most
    noise = 4.0 * 1.25 * jitter * np.sqrt(2.0 / SHIFT_FRAMES)
    extra = np.zeros(n, dtype=np.int64)
    for j in np.flatnonzero(np.diff(t) > 3 * period + 4 * jitter):
        before = median(resid[max(0, j - SHIFT_FRAMES + 1):j + 1])
        after = median(resid[j + 1:j + 1 + SHIFT_FRAMES])
        shift = after - before
        lost = round(shift / period) if shift > max(0.5 * period, noise) else 0
        if lost > 0:
            extra[j + 1] += lost
            resid[j + 1:] -= lost * period
    return index + np.cumsum(extra)


def _hats(x: FloatArray, knots: FloatArray) -> FloatArray:
    """Piecewise-linear basis at *x* within the knots (one column per knot)."""
    eye = np.eye(knots.size)
    return np.column_stack([np.interp(x, knots, eye[k]) for k in range(knots.size)])


def _fit_line(index: IntArray, t: FloatArray, period: float) -> tuple[FloatArray, float]:
    """The piecewise line through ``(index, t)``, fitted twice (the second time without
    the timestamps far off the first), and the robust spread of the timestamps about it."""
    x = index.astype(np.float64)
    span = float(x[-1] - x[0])
    knots = np.linspace(x[0], x[-1], max(1, round(span * period / KNOT_S)) + 1)
    basis = _hats(x, knots)
    t0 = t[0]
    keep = np.ones(x.size, dtype=bool)
    for _ in range(2):
        coef, *_ = np.linalg.lstsq(basis[keep], t[keep] - t0, rcond=None)
        resid = t - t0 - basis @ coef
        spread = 1.4826 * median(np.abs(resid - median(resid)))
        keep = np.abs(resid) <= max(OUTLIER_SD * spread, period)
        if keep.sum() < basis.shape[1] + 2:
            break
    return t0 + basis @ coef, spread


def sample_times(t: npt.ArrayLike, counter: npt.ArrayLike | None = None) -> FloatArray:
    """A periodic stream's sample times, from its frames' timestamps (and counter).

    Parameters
    ----------
    t : array_like of float, s
        The frames' timestamps as logged, in the order logged.
    counter : array_like of int, optional
        The stream's rolling frame counter, one value per frame.

    Returns
    -------
    ndarray of float64, s
        One time per frame, increasing: the timestamps without their jitter; the timestamps
        themselves when the stream is too short, or not periodic.
    """
    t = np.asarray(t, dtype=np.float64)
    if t.size < MIN_SAMPLES or not np.isfinite(t).all():
        return t
    order_ok = bool(np.all(np.diff(t) >= 0))
    ts = t if order_ok else np.maximum.accumulate(t)
    steps = np.diff(ts)
    if not np.any(steps > 0):
        return t
    period = float(ts[-1] - ts[0]) / (t.size - 1)  # corrected by the index below
    if counter is not None:
        c = np.asarray(counter, dtype=np.int64)
        index = _unwrap_counter(ts, c, period) if c.size == t.size and c.max() > 0 \
            else _ordinal_index(ts, period)
    else:
        index = _ordinal_index(ts, period)
    if index[-1] <= index[0]:
        return t
    period = float(ts[-1] - ts[0]) / float(index[-1] - index[0])
    fitted, spread = _fit_line(index, ts, period)
    if not spread <= MAX_SPREAD_PERIODS * period or not np.all(np.diff(fitted) >= 0):
        log.debug("timestamps kept: they stray %.3g s from a periodic clock", spread)
        return t
    return fitted
