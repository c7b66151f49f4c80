"""Frames missing from a load cell's periodic stream, robust to how the frames were received.

A load cell sends a frame every period P of its own clock; the logger stamps each frame
when it arrives, late by a latency that varies (bus arbitration, USB polling, the
operating system). Counting a "gap" wherever one step is longer than 1.5 median periods
overcounts as soon as the jitter is a sizeable part of the period: a late frame makes one
long step and one short one, and the long one alone is counted (a 2 kHz cell with 0.2 ms of
jitter showed 3,400 "missing" frames where 600 were lost). Here:

- **with a rolling counter**, the missing frames are the counter's (``(dcounter - 1) mod
  modulus`` per step): a counter that steps by one from frame to frame means nothing was
  lost, whatever the timestamps say (an adapter that delivers frames in bursts, a logger
  that stalls). Only where the counter itself shows frames lost, in a pause longer than
  half a counter period, can whole counter periods have been lost with them: they are added
  when the timing shows them unambiguously (the frames after the pause sit a whole number of
  counter periods later than the counter says, within the timing's noise), else a note says
  the count may miss them;
- **without a counter, on a regular clock** (timestamps coherent at the cell's period, no
  bursts), the period is estimated from the phase coherence of all timestamps (the peak of
  ``|sum exp(2 pi i t / P)|`` near the median step, refined on longer and longer spans;
  missing frames and jitter do not bias it, clock errors in ppm are part of it), and the
  missing frames are the grid positions between the first and last frame minus the frames
  received (the ends taken as medians over their first and last frames, so that frames
  stamped together when the logger starts do not count);
- **without a counter, on irregular reception** (frames delivered in bursts, jitter of the
  order of the period), single lost frames leave no trace in the timestamps: only outages
  are counted, as lasting drops of the stream's upper envelope (the frame count minus the
  elapsed time in periods, its maximum over windows of many periods, which the earliest
  frames of each burst set), with a note saying so. Short pauses, bursts, stalls and a
  clock off by 100 ppm make no lasting drop, so they invent no outage (symmetric jitter of
  two periods can move the count by a few frames, less than the outage the note names).

What no timestamp can tell: an adapter that stamps its polls, one frame a poll, at about the
cell's own rate (a 1 kHz cell read by a USB adapter polled every 1 ms) skips a poll whenever
its clock and the cell's drift a period apart, and such a skip is a lost frame to the
timing (one per ``1 / (rate * clock error)``: every 10 s at 1 kHz and 100 ppm). A rolling
counter tells them apart; without one, the count may hold these.
"""

from __future__ import annotations

import itertools
import logging
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from evtribo.canlog.outages import lasting_gaps, outage_count, whole_periods
from evtribo.util.median import median
from evtribo.warning.record import Note

log = logging.getLogger(__name__)

__all__ = ["DropCount", "coherence", "count_by_steps", "count_dropped", "estimate_period",
           "missing_frames", "missing_frames_received", "outage_count"]

#: Fewest frames for the coherent estimate; shorter streams use the step heuristic.
MIN_FRAMES = 16
#: Least coherence (see :func:`coherence`) at which the timing is trusted.
MIN_COHERENCE = 0.15
#: Coherence of a clean clock (jitter a few % of the period), where no step is stretched
#: to 1.5 periods by jitter and the per-step rule (:func:`count_by_steps`) is exact.
CLEAN_COHERENCE = 0.98
#: Most frames reported missing from one stream (a damaged timestamp can make a gap of
#: centuries; the count stays a finite integer).
MAX_COUNT = 2**40
#: Candidate periods evaluated per refinement stage.
_N_CANDIDATES = 25
#: Frames at each end whose median position gives the stream's start and end (no counter).
_EDGE_FRAMES = 32
#: Elements of the (candidates x timestamps) phase matrix computed at once.
_CHUNK = 1 << 20
#: Largest number of timestamps used per stage (evenly thinned beyond that).
_MAX_POINTS = 8_000
#: Share of a stream's frames by which a counter's count of lost frames may exceed what the
#: stream's time holds at its rate before the count is taken for one that cannot be.
SLACK_SHARE = 0.02
#: Share of a stream's steps shorter than a tenth of its period beyond which its frames are
#: taken to arrive in bursts (a USB or serial adapter's): their timestamps then say nothing
#: of single frames.
BURST_SHARE = 0.25


def _coherence(t: npt.NDArray[np.float64], periods: npt.NDArray[np.float64]
               ) -> npt.NDArray[np.float64]:
    """``|mean(exp(2 pi i t / P))|`` for each candidate period."""
    out = np.empty(periods.size)
    rows = max(1, _CHUNK // max(t.size, 1))
    for a in range(0, periods.size, rows):
        phase = np.outer(2 * np.pi / periods[a:a + rows], t)
        out[a:a + rows] = np.hypot(np.cos(phase).mean(axis=1), np.sin(phase).mean(axis=1))
    return out


def estimate_period(t: npt.ArrayLike, *, max_missing: float = 0.4) -> float:
    """The period of a periodic stream with jitter and missing frames, s.

    The period is at most ``span / (n - 1)`` (no two frames share a period) and, with at
    most *max_missing* of the frames lost, at least ``(1 - max_missing)`` times that: the
    search covers this range (which excludes the half period, as coherent as the period
    itself) on the first ~512 periods, then narrows around the peak on spans four times
    longer each time, up to the whole stream.

    Parameters
    ----------
    t : array_like of float, s
        Reception times, increasing.
    max_missing : float
        Largest fraction of frames that may be missing (0 to 0.5).

    Returns
    -------
    float, s
        The period that makes the timestamps most coherent. NaN for fewer than two
        distinct timestamps.
    """
    times = np.asarray(t, dtype=np.float64)
    if times.size < 2 or times[-1] <= times[0]:
        return float("nan")
    rel = times - times[0]
    span = float(rel[-1])
    upper = span / (rel.size - 1)
    lower = upper * (1 - min(max(max_missing, 0.0), 0.5))
    horizon = min(span, 512 * upper)
    # ~4 candidates per peak width (period / horizon, relative)
    n_cand = int(np.clip(4 * (upper - lower) / upper * horizon / lower, 41, 4001))
    cand = np.linspace(lower, upper * (1 + 1 / rel.size), n_cand)
    while True:
        sel = rel[: int(np.searchsorted(rel, horizon, side="right"))]
        if sel.size > _MAX_POINTS:
            sel = sel[np.linspace(0, sel.size - 1, _MAX_POINTS).astype(np.int64)]
        power = _coherence(sel, cand)
        j = int(np.argmax(power))
        if 0 < j < cand.size - 1:  # parabolic refinement of the peak
            y0, y1, y2 = power[j - 1], power[j], power[j + 1]
            denom = y0 - 2 * y1 + y2
            shift = 0.5 * (y0 - y2) / denom if denom < 0 else 0.0
            period = float(cand[j] + shift * (cand[1] - cand[0]))
        else:
            period = float(cand[j])
        if horizon >= span:
            return period
        horizon = min(span, horizon * 4)
        # the peak's width at the new horizon is about period / horizon (relative)
        half_width = 2.0 * period / horizon
        cand = period * (1 + np.linspace(-half_width, half_width, _N_CANDIDATES))


def coherence(t: npt.ArrayLike, period: float) -> float:
    """How regular a stream is at *period*: ``|mean(exp(2 pi i t / period))|``, 0 to 1.

    1 for frames exactly on a grid; about ``1/sqrt(n)`` for frames at random times.

    Parameters
    ----------
    t : array_like of float, s
        Reception times.
    period : float, s
        The period tried.

    Returns
    -------
    float
        The coherence (0 for no frames).
    """
    times = np.asarray(t, dtype=np.float64)
    return float(_coherence(times - times[0], np.array([period]))[0]) if times.size else 0.0


def _steps(t: npt.NDArray[np.float64], period: float) -> npt.NDArray[np.int64]:
    """Grid positions of each frame, relative to the stream's mean phase."""
    phase = np.angle(np.exp(2j * np.pi * (t - t[0]) / period).mean()) / (2 * np.pi)
    return np.rint((t - t[0]) / period - phase).astype(np.int64)


def count_by_steps(t: npt.ArrayLike, gap_factor: float = 1.5) -> int:
    """The per-step rule: ``round(dt / median) - 1`` summed over steps longer than
    *gap_factor* median periods. Exact on a clean clock and for short streams; overcounts
    as soon as the jitter stretches steps (see the module's docstring).

    Parameters
    ----------
    t : array_like of float, s
        Reception times, increasing.
    gap_factor : float
        A step longer than this many median steps is a gap.

    Returns
    -------
    int
        Frames missing.
    """
    dt = np.diff(np.asarray(t, dtype=np.float64))
    period = median(dt) if dt.size else 0.0
    if not period > 0:
        return 0
    gap = dt > gap_factor * period
    return int(np.clip(np.rint(dt[gap] / period) - 1, 0, MAX_COUNT).sum())


@dataclass
class DropCount:
    """Frames missing from one stream, and how they were counted.

    Attributes
    ----------
    count : int
        Frames missing.
    method : str
        ``"counter"``, ``"counter+timing"`` (whole counter periods added from the timing),
        ``"timing"``, ``"outages"`` (irregular timestamps without a counter: outages only)
        or ``"steps"`` (short streams).
    period_s : float, s
        The stream's estimated period (NaN when not estimated).
    coherence : float
        Regularity of the timestamps at that period (0 to 1, see :func:`coherence`).
    notes : tuple of Note
        Why the count may be unreliable (``frames-lost-outages``, ``frames-lost-clock``,
        ``counter-overcounts``, ``periods-unsure``...), each said of its load cell by the
        decoder.
    counter_ignored : bool
        The counter counted more frames lost than the stream's time holds: the count is the
        timing's, and the counter says nothing of the frames.
    """

    count: int
    method: str
    period_s: float = float("nan")
    coherence: float = float("nan")
    notes: tuple[Note, ...] = ()
    counter_ignored: bool = False


def _regular(coh: float, n: int) -> bool:
    return coh >= max(MIN_COHERENCE, 8 / np.sqrt(n))


def _bursty(t: npt.NDArray[np.float64], period: float) -> bool:
    """Whether the frames arrive in bursts: many steps far shorter than the period."""
    dt = np.diff(t)
    return int(np.count_nonzero(dt < 0.1 * period)) > BURST_SHARE * dt.size


def _with_counter(t: npt.NDArray[np.float64], c: npt.NDArray[np.int64],
                  modulus: int | None) -> DropCount:
    """The counter's count (a counter that steps by one: nothing lost), plus whole counter
    periods lost in pauses where the counter shows a loss, when the timing shows them."""
    n = t.size
    if n < 2:
        return DropCount(0, "counter")
    if modulus is None:
        modulus = 1 << max(int(c.max(initial=0)).bit_length(), 1)
    missing = (np.diff(c) - 1) % modulus
    by_counter = int(missing.sum())
    if n < MIN_FRAMES or not by_counter or not t[-1] > t[0]:
        return DropCount(by_counter, "counter")
    index = np.concatenate([[0], np.cumsum(missing + 1)]).astype(np.float64)
    period = float(t[-1] - t[0]) / float(index[-1])
    pauses = np.flatnonzero((missing > 0) & (np.diff(t) >= 0.5 * modulus * period))
    if not pauses.size:
        return DropCount(by_counter, "counter", period)
    wraps, note = whole_periods(t, index, pauses, modulus)
    if wraps > 0:
        log.info("the timing shows %d whole counter period(s) of %d frames lost at once",
                 wraps, modulus)
        return DropCount(by_counter + wraps * modulus, "counter+timing", period,
                         notes=_notes(note))
    return DropCount(by_counter, "counter", period, notes=_notes(note))


def _notes(note: Note | None) -> tuple[Note, ...]:
    return () if note is None else (note,)


def missing_frames(t: npt.ArrayLike, counter: npt.ArrayLike | None = None,
                   modulus: int | None = None) -> DropCount:
    """Frames missing from a periodic stream (one load cell), with the method used.

    Parameters
    ----------
    t : array_like of float, s
        Reception times, increasing.
    counter : array_like of int, optional
        The cell's rolling frame counter (+1 per frame), in the same order.
    modulus : int, optional
        The counter's period (``2**bits``). Default: the next power of two above the
        largest counter value seen.

    Returns
    -------
    DropCount
        With a counter: the counter's count, plus whole counter periods that the timing
        shows lost at once where the counter shows a loss. Without: the timing's count
        (outages only, with a note, where the timestamps cannot show single frames).
    """
    times = np.asarray(t, dtype=np.float64)
    c = None if counter is None else np.asarray(counter, dtype=np.int64)
    finite = np.isfinite(times)
    if not finite.all():  # a damaged log's times: count on the frames that have one
        times = times[finite]
        c = None if c is None else c[finite]
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        found = _by_timing(times) if c is None else _within_time(
            times, c, _with_counter(times, c, modulus), modulus)
    found.count = int(min(max(found.count, 0), MAX_COUNT))
    return found


def _within_time(t: npt.NDArray[np.float64], c: npt.NDArray[np.int64], found: DropCount,
                 modulus: int | None) -> DropCount:
    """*found* (the counter's count), or the timing's where the counter counts more frames
    lost than the stream's time holds at its rate (its frames one step of the counter apart
    give the rate, else its timestamps' period): a counter that does not count as its law
    says (:data:`SLACK_SHARE` of the frames, and the frames a timestamp may be late by,
    allowed)."""
    if t.size < MIN_FRAMES or not found.count or not t[-1] > t[0]:
        return found
    modulus = modulus or 1 << max(int(c.max(initial=0)).bit_length(), 1)
    dt = np.diff(t)
    one = (np.mod(np.diff(c), modulus) == 1) & (dt >= 0) & (dt < CLOCK_JUMP_S)
    frame_s = (float(np.mean(dt[one])) if np.count_nonzero(one) >= MIN_FRAMES
               else estimate_period(t))
    if not frame_s > 0:
        return found
    late = float(np.quantile(dt, 0.99)) / frame_s  # frames a timestamp may be late by
    held = (t[-1] - t[0]) / frame_s - (t.size - 1)
    if found.count <= held + SLACK_SHARE * t.size + 2 * late + 4:
        return found
    timed = _by_timing(t)
    said = Note("counter-overcounts", {"counted": found.count, "span_s": float(t[-1] - t[0]),
                                       "held": max(round(held), 0), "rate_Hz": 1 / frame_s})
    return DropCount(timed.count, timed.method, timed.period_s, timed.coherence,
                     (said, *timed.notes), counter_ignored=True)


def _by_timing(t: npt.NDArray[np.float64]) -> DropCount:
    """Frames missing from a stream without a counter, by its timestamps alone."""
    n = t.size
    if n < 2:
        return DropCount(0, "timing")
    if n < MIN_FRAMES:
        return DropCount(count_by_steps(t), "steps")
    period = estimate_period(t)
    if not np.isfinite(period):
        return DropCount(0, "timing")
    coh = coherence(t, period)
    if _bursty(t, period) or not _regular(coh, n):
        return _outages_only(t, period, coh)
    if coh >= CLEAN_COHERENCE:
        return DropCount(lasting_gaps(t, period), "timing", period, coh)
    # grid position minus rank grows by one at each missing frame; its medians over the
    # first and last frames are not fooled by a burst of late frames at either end
    lag = _steps(t, period) - np.arange(n)
    edge = min(_EDGE_FRAMES, max(n // 4, 1))
    inner = float(np.median(lag[-edge:]) - np.median(lag[:edge]))
    # the medians sit (edge - 1) / 2 frames inside each end: scale to the whole stream
    count = max(int(np.rint(inner * (n - 1) / max(n - edge, 1))), 0)
    return DropCount(count, "timing", period, coh)


def _outages_only(t: npt.NDArray[np.float64], period: float, coh: float) -> DropCount:
    """The outages of a stream whose timestamps cannot show single lost frames, with a note
    saying so."""
    count, seen = outage_count(t)
    bursts = "frames received in bursts, " if _bursty(t, period) else ""
    if not np.isfinite(seen):  # too few frames for the envelope's windows
        return DropCount(count, "outages", period, coh, (Note("frames-lost-unseen", {
            "bursts": bursts, "coherence": coh, "frames": int(t.size)}),))
    return DropCount(count, "outages", period, coh, (Note("frames-lost-outages", {
        "bursts": bursts, "coherence": coh, "frames": max(int(np.ceil(seen)), 2)}),))


def count_dropped(t: npt.ArrayLike, counter: npt.ArrayLike | None = None,
                  modulus: int | None = None) -> int:
    """Frames missing from a periodic stream: :func:`missing_frames`' count.

    Parameters
    ----------
    t : array_like of float, s
    counter : array_like of int, optional
    modulus : int, optional

    Returns
    -------
    int
    """
    return missing_frames(t, counter, modulus).count


#: A step in time larger than this between frames of one stream received one after the
#: other is the logger's clock jumping (NTP, a PC's clock set by hand) or the recording
#: pausing: the timing cannot say how many frames such a step hides, s.
CLOCK_JUMP_S = 1.0


def missing_frames_received(t: npt.ArrayLike, counter: npt.ArrayLike | None = None,
                            modulus: int | None = None) -> DropCount:
    """:func:`missing_frames` for a stream in the order it was received, whose clock may
    have jumped.

    Sorting such a stream by time interleaves the frames from before and after a jump back
    and makes every counter step look like a loss; a jump forward of hours, read as an
    outage, would make millions of frames "lost". The stream is cut where its clock steps
    by more than :data:`CLOCK_JUMP_S` either way; each piece is counted on its own (sorted,
    for frames merely reordered), and across each cut only the counter, when there is one,
    says how many frames are missing (whole counter periods lost there cannot be seen).

    Parameters
    ----------
    t : array_like of float, s
        Reception times, in the order the frames were received.
    counter : array_like of int, optional
        The cell's rolling frame counter, in the same order.
    modulus : int, optional
        The counter's period (default: as :func:`missing_frames`).

    Returns
    -------
    DropCount
        As :func:`missing_frames`, with a note where the clock jumped.
    """
    times = np.asarray(t, dtype=np.float64)
    c = None if counter is None else np.asarray(counter, dtype=np.int64)
    with np.errstate(invalid="ignore"):
        cuts = np.flatnonzero(np.abs(np.diff(times)) > CLOCK_JUMP_S) + 1
    if not cuts.size:
        if not np.any(times[1:] < times[:-1]):
            return missing_frames(times, c, modulus)
        order = np.argsort(times, kind="stable")
        return missing_frames(times[order], None if c is None else c[order], modulus)
    if c is not None and modulus is None and c.size:
        modulus = 1 << max(int(c.max(initial=0)).bit_length(), 1)
    bounds = np.concatenate([[0], cuts, [times.size]])
    found = []
    for a, b in itertools.pairwise(bounds):
        order = np.argsort(times[a:b], kind="stable")
        found.append(missing_frames(times[a:b][order], None if c is None else c[a:b][order],
                                    modulus))
    count = sum(f.count for f in found)
    if c is not None and modulus:
        count += int(((c[cuts] - c[cuts - 1] - 1) % modulus).sum())
    methods = list(dict.fromkeys(f.method for f in found))
    notes = [n for f in found for n in f.notes]
    steps = np.diff(times)[cuts - 1]
    what = " and ".join(w for w, n in (("jumped back", int((steps < 0).sum())),
                                       ("jumped ahead or paused", int((steps > 0).sum())))
                        if n)
    notes.append(Note("frames-lost-clock", {
        "jumped": what, "jump_s": CLOCK_JUMP_S,
        "counted": "counted by the counter alone (whole counter periods lost there cannot be "
                   "seen)" if c is not None else "cannot be counted"}))
    return DropCount(int(min(count, MAX_COUNT)), "+".join(methods),
                     notes=tuple(dict.fromkeys(notes)),
                     counter_ignored=any(f.counter_ignored for f in found))
