"""Frames lost from a periodic stream, read from its upper envelope: the lead of each
frame's index over the periods elapsed since the first frame.

A frame's latency (bus arbitration, an adapter's USB polling or serial line, the operating
system) only ever delays it, so in any window of many periods the frames that arrived
earliest set the highest lead; a lost frame lowers that envelope by one for good, while a
burst, a logger's stall or a few late frames lower it only for a while. Comparing the
envelope just before and just after a place therefore says how many frames were lost
there, whatever the timestamps' bursts and jitter, and independently of small errors of the
period (a clock off by 100 ppm moves it by a hundredth of a frame over a hundred periods).
:mod:`evtribo.canlog.dropped` decides which stream is counted how.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from evtribo.util.median import median
from evtribo.warning.record import Note

__all__ = ["LARGEST_STEP_S", "MAX_CANDIDATES", "MIN_OUTAGE", "Lead", "envelope_noise",
           "lasting_gaps", "outage_count", "whole_periods"]

#: Least drop of the upper envelope taken for frames lost in a row, frames (more where the
#: envelope is noisier: four times its scatter).
MIN_OUTAGE = 1.5
#: The upper envelope's windows span at least this many periods.
_ENVELOPE_PERIODS = 32
#: Windows of the upper envelope compared either side of a change.
_ENVELOPE_K = 4
#: Frames either side of a gap whose mean lead says how many frames it lost.
_GAP_FRAMES = 32
#: Fewest frames for an envelope.
_MIN_FRAMES = 16
#: Most frames whose envelope's scatter is measured (:func:`envelope_noise`).
_NOISE_FRAMES = 50_000
#: Most steps of a stream looked at as a possible counter jump or clock step.
MAX_CANDIDATES = 400
#: A step of the clock larger than this is left as it is, s (the analysis cuts the trial
#: there: :mod:`evtribo.analysis.forces.pieces`).
LARGEST_STEP_S = 1.0

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


def _envelope(t: npt.NDArray[np.float64], index: npt.NDArray[np.float64], period: float
              ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The stream's upper envelope: in windows of many periods (and of several of the
    longest usual steps: bursts), the largest lead of a frame's index over the periods
    elapsed since the first frame; returns each window's start (s from the first frame)
    and that lead (frames), the partial first and last windows left out. Latency only
    delays frames, so the earliest frames of each window set it; a lost frame lowers it
    by one for good."""
    lead = index - (t - t[0]) / period
    width = max(_ENVELOPE_PERIODS * period, 4 * float(np.quantile(np.diff(t), 0.99)))
    w = np.floor((t - t[0]) / width).astype(np.int64)
    starts = np.flatnonzero(np.r_[True, w[1:] != w[:-1]])
    top = np.maximum.reduceat(lead, starts)
    return (w[starts] * width)[1:-1], top[1:-1]


def _noise(level: npt.NDArray[np.float64]) -> float:
    """Scatter of a level from one window to the next (robust: outages do not count), frames."""
    d = np.diff(level)
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(2)) if d.size else 0.0


def envelope_noise(t: npt.NDArray[np.float64], index: npt.NDArray[np.float64], period: float
                   ) -> float:
    """How much the stream's upper envelope scatters from one window to the next, frames:
    the least disagreement between a stream's places and its clock that can be told from
    noise is a few times this.

    Parameters
    ----------
    t : ndarray of float, s
        Reception times, non-decreasing.
    index : ndarray of float
        Each frame's place in the stream.
    period : float, s
        The stream's period.

    Returns
    -------
    float
        The robust scatter (0 for a stream too short for windows).
    """
    if t.size > _NOISE_FRAMES:  # a long stretch from the middle says it as well
        a = (t.size - _NOISE_FRAMES) // 2
        t, index = t[a:a + _NOISE_FRAMES], index[a:a + _NOISE_FRAMES]
    if t.size < _MIN_FRAMES or not period > 0 or not t[-1] > t[0]:
        return 0.0
    return _noise(_envelope(t, index, period)[1])


def _lasting_drops(level: npt.NDArray[np.float64], threshold: float) -> float:
    """Lasting drops of *level* minus its lasting rises, frames.

    Around each boundary between windows the highest of the :data:`_ENVELOPE_K` windows
    before is compared with the highest of those after; each run of boundaries where they
    differ by *threshold* or more is one change, measured between the medians of the
    windows before and after the run (a dip shorter than the windows compared, such as a
    logger's stall, is no change)."""
    k = _ENVELOPE_K
    if level.size < 2 * k:
        return 0.0
    # boundary b (between windows b and b + 1, for b from k - 1 to n - k - 1): the highest
    # of the k windows up to it and of the k after it
    top = np.lib.stride_tricks.sliding_window_view(level, k).max(axis=1)
    diff = top[:-k] - top[k:]
    total = 0.0
    for sign in (1.0, -1.0):
        edges = np.flatnonzero(np.diff(np.r_[0, (sign * diff >= threshold).astype(np.int8), 0]))
        for a, b in zip(edges[::2] + k - 1, edges[1::2] + k - 1, strict=True):
            total += sign * float(np.median(level[a - k + 1:a + 1])
                                  - np.median(level[b - k + 1:b + 1]))
    return total


def outage_count(t: npt.ArrayLike) -> tuple[int, float]:
    """Frames lost in outages of a stream whose timestamps cannot show single lost frames
    (frames received in bursts, jitter of the order of the period).

    The upper envelope (see the module's docstring) is levelled by its median slope
    (frames lost one by one all along, and a clock error, cannot be told from a slightly
    other period); its lasting drops are the frames lost in outages.

    Parameters
    ----------
    t : array_like of float, s
        Reception times, increasing.

    Returns
    -------
    count : int
        Frames lost in outages.
    threshold : float
        The fewest frames lost in a row that are seen (more where the envelope is noisier).
    """
    times = np.asarray(t, dtype=np.float64)
    if times.size < _MIN_FRAMES or not times[-1] > times[0]:
        return 0, float("nan")
    period = float(times[-1] - times[0]) / (times.size - 1)
    starts, level = _envelope(times, np.arange(times.size, dtype=np.float64), period)
    if level.size < 3:
        return 0, float("nan")
    level = level - float(np.median(np.diff(level) / np.diff(starts))) * starts
    threshold = max(MIN_OUTAGE, 4 * _noise(level))
    return max(int(np.rint(_lasting_drops(level, threshold))), 0), threshold


def whole_periods(t: npt.NDArray[np.float64], index: npt.NDArray[np.float64],
                   pauses: npt.NDArray[np.intp], modulus: int) -> tuple[int, Note | None]:
    """Whole counter periods lost in the *pauses* (steps where the counter shows frames lost
    and the stream paused for half a counter period or more), and a note where the timing
    cannot tell.

    Across such a pause the frames after it lead the periods elapsed by as much as before
    it, less any frames the counter did not see: the highest lead over ``2 * modulus``
    frames either side (up to the neighbouring pauses) is compared.

    Parameters
    ----------
    t : ndarray of float, s
        Reception times, increasing.
    index : ndarray of float
        Each frame's place in the stream by the counter (the frames it shows lost counted).
    pauses : ndarray of int
        The steps (``t[j]`` to ``t[j + 1]``) to look at.
    modulus : int
        The counter's period, frames.

    Returns
    -------
    wraps : int
        Whole counter periods lost, in all.
    note : Note or None
        The pauses where the timing cannot tell (too noisy for the counter's period):
        ``periods-unsure``, or ``periods-unsure-still`` where no time passes between them.
    """
    bounds = np.r_[0, pauses + 1, t.size]
    # the period from the stretches between the pauses (what they hide left out)
    first, last = bounds[:-1], bounds[1:] - 1
    period = float(np.sum(t[last] - t[first]) / max(np.sum(index[last] - index[first]), 1.0))
    if not (np.isfinite(period) and period > 0):  # no time passes between the pauses
        return 0, Note("periods-unsure-still")
    lead = index - (t - t[0]) / period
    tolerance = max(2.0, 4 * _noise(_envelope(t, index, period)[1]))
    reach = max(2 * modulus, 64)
    wraps, unsure = 0, []
    for i, j in enumerate(pauses):
        before = lead[max(bounds[i], j + 1 - reach):j + 1].max()
        after = lead[j + 1:min(bounds[i + 2], j + 1 + reach)].max()
        hidden = float(before - after)
        k = int(np.rint(hidden / modulus))
        if abs(hidden - k * modulus) > tolerance or (k > 0 and tolerance > modulus / 4):
            unsure.append(f"{t[j + 1] - t[j]:.3g} s at {t[j] - t[0]:.3f} s")
        elif k > 0:
            wraps += k
    note = None if not unsure else Note("periods-unsure", {
        "pauses": ", ".join(unsure[:3]) + (" ..." if len(unsure) > 3 else ""),
        "period": modulus})
    return wraps, note


def lasting_gaps(t: npt.ArrayLike, period: float, gap_factor: float = 1.5) -> int:
    """Frames lost in the steps longer than *gap_factor* periods of a regular stream, each
    step's count the lasting drop of the frames' lead across it (its mean over up to
    :data:`_GAP_FRAMES` frames either side, up to the neighbouring steps).

    On a clean clock this is ``round(dt / period) - 1`` per step; where the timestamps are
    the polls of an adapter at about the stream's rate, a poll that finds no frame (its
    clock and the cell's drift apart by a few ppm) makes a long step and no lasting drop,
    and counts nothing.

    Parameters
    ----------
    t : array_like of float, s
        Reception times, increasing.
    period : float, s
        The stream's period.
    gap_factor : float
        A step longer than this many periods may have lost frames.

    Returns
    -------
    int
        Frames lost.
    """
    times = np.asarray(t, dtype=np.float64)
    gaps = np.flatnonzero(np.diff(times) > gap_factor * period)
    if not gaps.size or not period > 0:
        return 0
    lead = np.arange(times.size) - (times - times[0]) / period
    total = np.concatenate([[0.0], np.cumsum(lead)])
    bounds = np.r_[0, gaps + 1, times.size]  # the stretches between the steps
    a = np.maximum(bounds[:-2], gaps + 1 - _GAP_FRAMES)  # before step k: lead[a:gaps+1]
    b = np.minimum(bounds[2:], gaps + 1 + _GAP_FRAMES)   # after it: lead[gaps+1:b]
    before = (total[gaps + 1] - total[a]) / (gaps + 1 - a)
    after = (total[b] - total[gaps + 1]) / (b - gaps - 1)
    return int(np.clip(np.rint(before - after), 0, None).sum())


@dataclass
class Lead:
    """A stream's places against its clock, where the two may disagree for good (a counter
    that jumps, a clock that steps): :mod:`evtribo.canlog.sequence` puts them right.

    Attributes
    ----------
    t : ndarray of float, s
        Timestamps, in the order sent.
    index : ndarray of int
        Each frame's place (by the counter, or the rank).
    modulus : int or None
        The counter's period (None: no counter).
    period : float, s
        The stream's period, by least squares between the steps that may hide a jump.
    width_s : float, s
        The windows of time either side of a step over which the upper envelope is taken.
    tol : float
        The least disagreement told from noise, frames.
    bounds : ndarray of int
        The stretches between steps of the clock left as they are.
    odd : ndarray of int
        The steps where the counter or the clock does something out of the ordinary (at
        most :data:`MAX_CANDIDATES`, the most out of it); when there is none, *t* and *index*
        are the arrays given (not copies) and *width_s* 0.
    poll : float
        The longest usual step (99 in 100 are shorter) of a stream whose envelope is quiet
        (*tol* 2), frames: a logger that stamps its polls shows a step of the clock up to
        this much short (0 for a stream whose latency wanders).
    """

    t: FloatArray
    index: IntArray
    modulus: int | None
    period: float
    width_s: float
    tol: float
    bounds: IntArray
    odd: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    poll: float = 0.0

    def lead(self) -> FloatArray:
        """Each frame's place less the periods elapsed since the first frame, frames."""
        return self.index - (self.t - self.t[0]) / self.period

    def monotone(self) -> FloatArray:
        """The timestamps made non-decreasing within each stretch (for windows of time), s."""
        return _monotone(self.t, self.bounds)

    def shift(self, j: int, lead: FloatArray, mono: FloatArray) -> float:
        """How many frames the places and the clock disagree by after step j than before
        it: the upper envelope over a window of time either side (within its stretch)."""
        k = int(np.searchsorted(self.bounds, j, side="right"))
        a, b = int(self.bounds[k - 1]), int(self.bounds[k])
        lo = max(a, int(np.searchsorted(mono[a:j + 1], mono[j] - self.width_s)) + a)
        hi = min(b, int(np.searchsorted(mono[j + 1:b], mono[j + 1] + self.width_s,
                                        side="right")) + j + 1)
        if hi <= j + 1 or lo > j:
            return 0.0
        return float(lead[lo:j + 1].max() - lead[j + 1:hi].max())

    @classmethod
    def of(cls, t: FloatArray, index: IntArray, modulus: int | None) -> Lead | None:
        """The stream with its period, windows and tolerance; None when it has no period."""
        return _lead(cls, t, index, modulus)


def _stretches(t: FloatArray) -> IntArray:
    """The bounds of the stretches between steps of the clock left as they are: ahead by
    more than :data:`LARGEST_STEP_S`; back so far that no frame after it reaches the
    frames before it; or back by as much from frames stamped far ahead of those around
    them (a line or a few stamped hours ahead: the frames after them go on from those
    before them, and the stamps far ahead are a stretch of their own, not a clock that
    stepped back)."""
    dt = np.diff(t)
    big = np.flatnonzero(np.abs(dt) > LARGEST_STEP_S)
    if big.size:
        first = np.minimum.accumulate(t)
        later = np.maximum.accumulate(t[::-1])[::-1]  # the latest frame from each on
        big = big[(dt[big] > 0) | (later[big + 1] < first[big]) | _back_home(t, big)]
    return np.concatenate([[0], big + 1, [t.size]]).astype(np.int64)


def _back_home(t: FloatArray, big: IntArray) -> npt.NDArray[np.bool_]:
    """Which of the large steps *big* go back to where the clock was before the last large
    step ahead: the frames after them go on from the frames before it (by the frames in
    between, at the stream's usual step, and :data:`LARGEST_STEP_S`)."""
    dt = np.diff(t)
    ahead = big[dt[big] > 0]
    if not ahead.size:
        return np.zeros(big.size, dtype=bool)
    last = np.searchsorted(ahead, big, side="left") - 1  # the last step ahead before each
    k = ahead[np.maximum(last, 0)]
    usual = median(np.abs(dt))
    since = t[big + 1] - t[k]
    return ((last >= 0) & (dt[big] < 0) & (since >= -LARGEST_STEP_S)
            & (since <= (big + 1 - k) * usual + LARGEST_STEP_S))


def _monotone(t: FloatArray, bounds: IntArray) -> FloatArray:
    """*t* made non-decreasing within each stretch (for windows of time)."""
    if not np.any(t[1:] < t[:-1]):
        return t
    out = t.copy()
    for a, b in itertools.pairwise(bounds):
        out[a:b] = np.maximum.accumulate(t[a:b])
    return out


def _period(t: FloatArray, index: IntArray) -> float:
    """The stream's period, from spans of many frames (a few disturbed ones left out by
    the median), s."""
    w = max(1, min(200, t.size // 4))
    every = max(1, (t.size - w) // 20_000)  # a median's worth of spans
    spans = (t[w::every] - t[:-w:every]) / np.maximum(index[w::every] - index[:-w:every], 1)
    return median(spans[np.isfinite(spans) & (spans > 0)]) if np.any(spans > 0) else 0.0


def _pooled_slope(t: FloatArray, x: FloatArray, cut: IntArray) -> float:
    """The least-squares slope of *t* against *x*, pooled over the pieces between *cut*
    (each piece with its own intercept); 0 when there is none."""
    cut = cut[np.r_[np.diff(cut) > 0, False]]  # the starts of pieces with frames
    if not cut.size:
        return 0.0
    x = x - x[0]
    t = t - t[0]
    n = np.diff(np.r_[cut, x.size]).astype(np.float64)
    sx, st = np.add.reduceat(x, cut), np.add.reduceat(t, cut)
    sxx, sxt = np.add.reduceat(x * x, cut), np.add.reduceat(x * t, cut)
    den = float(np.sum(sxx - sx * sx / n))
    return float(np.sum(sxt - sx * st / n)) / den if den > 0 else 0.0


def _quantile(x: FloatArray, q: float) -> float:
    """*x*'s *q* quantile, from at most 20,000 of its values evenly spread (a threshold's
    worth of precision, at a fraction of the cost)."""
    if x.size > 20_000:
        x = x[np.linspace(0, x.size - 1, 20_000).astype(np.int64)]
    return float(np.quantile(x, q)) if x.size else 0.0


def _candidates(t: FloatArray, index: IntArray, period: float, bounds: IntArray,
                counted: bool) -> IntArray:
    """The steps where the counter or the clock does something out of the ordinary: the
    clock going back, the counter standing or skipping two or more, the clock going on far
    longer than the counter (beyond three times the most that 999 steps in 1000 show), or
    the longest step where the upper envelope drops for good (:func:`_lasting_drops_at`)."""
    dt = np.diff(t)
    d = np.diff(index)
    odd = dt < -period
    if counted:
        odd |= (d >= 3) | (d == 0)
        if dt.size and dt.max() > 4 * period:  # else no step goes on long enough
            off = dt - d * period
            odd |= off > max(3 * _quantile(np.abs(off), 0.999), 4 * period)
        odd[_lasting_drops_at(t, index, period, bounds)] = True
    odd[bounds[1:-1] - 1] = False
    found = np.flatnonzero(odd)
    if found.size > MAX_CANDIDATES:
        score = np.abs(dt[found] / period - d[found])
        found = np.sort(found[np.argsort(score)[::-1][:MAX_CANDIDATES]])
    return found


def _lasting_drops_at(t: FloatArray, index: IntArray, period: float, bounds: IntArray
                      ) -> IntArray:
    """The step, in each stretch of a quiet upper envelope (levelled by its median slope:
    a period a little off) that drops for good and at once by two frames or more, where
    the clock goes on longest beyond the counter: a clock stepping ahead by less than a few
    of a logger's polls shows in no single step, but in the envelope it does (frames whose
    counter says they follow one another, a few polls later than their places say). An
    envelope that scatters by half a frame or more from window to window (a latency that
    wanders: a replay, a starved machine) is left alone: there a lag a sender never made
    up looks the same, and only a step standing out of the jitter is taken for the
    clock's."""
    found = []
    for a, b in itertools.pairwise(bounds):
        if b - a < 8 * _GAP_FRAMES or not t[b - 1] > t[a]:
            continue
        ts = np.maximum.accumulate(t[a:b])
        x = index[a:b].astype(np.float64)
        starts, level = _envelope(ts, x, period)
        k = _ENVELOPE_K
        if level.size < 2 * k + 2:
            continue
        level = level - float(np.median(np.diff(level) / np.diff(starts))) * starts
        top = np.lib.stride_tricks.sliding_window_view(level, k).max(axis=1)
        threshold = 4 * _noise(level)
        if threshold > 2.0:
            continue  # a latency that wanders: a lag never made up is no step of the clock
        threshold = 2.0
        # for good across the windows compared, and at once between two of them (a clock
        # steps; a latency that grows over seconds does not)
        sudden = np.r_[level[:-1] - level[1:] >= threshold, False]
        at_once = np.lib.stride_tricks.sliding_window_view(sudden[:-1], 2 * k - 1).any(axis=1)
        dropped = (top[:-k] - top[k:] >= threshold) & at_once
        edges = np.flatnonzero(np.diff(np.r_[0, dropped.astype(np.int8), 0]))
        width = max(_ENVELOPE_PERIODS * period, 4 * float(np.quantile(np.diff(ts), 0.99)))
        off = np.diff(ts) - np.diff(x) * period
        for lo, hi in zip(edges[::2], edges[1::2], strict=True):
            t_lo = ts[0] + starts[lo]  # the windows either side of the change
            t_hi = ts[0] + starts[min(hi + 2 * k - 1, starts.size - 1)] + width
            j0, j1 = np.searchsorted(ts, [t_lo, t_hi])
            if j1 - 1 > j0:
                found.append(a + j0 + int(np.argmax(off[j0:j1 - 1])))
    return np.asarray(found, dtype=np.int64)


def _lead(cls: type[Lead], t: FloatArray, index: IntArray, modulus: int | None
          ) -> Lead | None:
    bounds = _stretches(t)
    period = _period(t, index)
    if not period > 0:
        return None
    found = _candidates(t, index, period, bounds, modulus is not None)
    if not found.size:  # nothing out of the ordinary: nothing more to know
        return cls(t, index, modulus, period, 0.0, 2.0, bounds, found)
    mono = _monotone(t, bounds)
    usual = _quantile(np.diff(mono), 0.99)
    width = max(max(2 * (modulus or 32), 64) * period, 4 * usual)
    # the period again by least squares between the steps that may hide a jump or a step (a
    # median of spans of a stream stamped in bursts is off by up to a burst per span)
    cut = np.unique(np.concatenate([[0], found + 1, bounds[1:-1], [t.size]]))
    period = _pooled_slope(t, index.astype(np.float64), cut) or period
    tol = max(2.0, 4 * envelope_noise(mono, index.astype(np.float64), period))
    # a quiet envelope (frames stamped in regular polls, not a wandering latency) may show
    # a step of the clock up to a poll short in its own step
    return cls(t.copy(), index.copy(), modulus, period, width, tol, bounds, found,
               usual / period if tol <= 2.0 else 0.0)
