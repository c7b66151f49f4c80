"""What a load cell's rolling counter does, from its values and their timestamps.

A counter's signal has a bit width, but its firmware need not count to the width's top: real
cells count modulo ``2**bits``, modulo ``10**k`` (0 to 99), or modulo some other number (15,
250), some from 1 rather than 0, some by 2 per frame; and a counter may not count at all (a
field the firmware never fills: it stays at 0). Read as counting by one to its width's top,
a counter wrapping at 100 in an 8-bit field makes 156 frames "lost" at every wrap (12,324 of
24,401 frames received, F_el 37 % low through the sample times it sets), one wrapping at 250
invents 6 a wrap, and one stuck at 0 millions.

:func:`counter_law` reads the law from the data: the step (the most common step up), the
values it wraps between, and, when it never reaches its width's top, its period from the
timing. The counter's places (its count of frames, ``+1`` per frame) are a straight line in
time; each wrap adds the frames the law says it skips, so the time each wrap takes beyond
the places' line says how many frames a wrap really skips: none beyond the values seen for a
counter that starts again after its largest value, the top values for a counter of the
bit width whose top values were lost (read by least squares over every frame, the clock's
rate and each stretch's offset fitted beside it: within a small fraction of a frame per wrap
for a trial of thousands of frames, whatever the logger's jitter). Where the timing cannot
tell, the width's law is kept and a note says how to declare the period in the rig file
(``[rig] normal_force_counter_period``, docs/rig-file.md), which is then used as it is.
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from evtribo.util.median import median
from evtribo.warning.record import Note

log = logging.getLogger(__name__)

__all__ = ["MARGIN_SE", "MAX_FRAME_RATE_HZ", "MIN_COUNTING_SHARE", "MIN_FRAMES", "CounterLaw",
           "counter_law"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: Fewest frames whose counter is looked at; a shorter stream keeps its width's law.
MIN_FRAMES = 16
#: Least share of a counter's steps that are its step, or a wrap from its upper half to its
#: lower half, for it to count.
MIN_COUNTING_SHARE = 0.5
#: The timing says the period when its estimate is this many standard errors from half a
#: frame off a whole number of frames.
MARGIN_SE = 6.0
#: The timing's stretches end where the clock steps back or jumps ahead by more than this, s.
JUMP_S = 1.0
#: Widest counter whose values are looked at, bits (a wider one never wraps in a trial).
MAX_BITS = 62
#: Most places a frame received twice or late is behind its own, for the timing (as
#: :data:`evtribo.canlog.sequence.REORDER_REACH`).
BACK_REACH = 8
#: More frames a second than any CAN bus carries (a classic frame takes 47 bits at least,
#: at 1 Mbit/s; CAN FD's arbitration is as slow), Hz: a law that would have a cell send
#: faster is no cell's.
MAX_FRAME_RATE_HZ = 25_000.0


@dataclass(frozen=True)
class CounterLaw:
    """How a counter counts: from *start*, by *step* per frame, *period* values, then
    again from *start*.

    Attributes
    ----------
    start : int
        The value it starts again from.
    step : int
        Its step per frame.
    period : int
        Frames after which its value repeats.
    counts : bool
        Whether it counts at all (False: its values say nothing of the frames).
    learnt : bool
        Whether the period was taken from the data (not the bit width's, nor declared).
    note : Note or None
        What it does, where that is worth saying (``counter-idle``, ``counter-law``,
        ``counter-law-rate``, ``counter-period-unsure``): the decoder says it.
    sure : bool
        Whether the frames say it for certain: False where the counter has not wrapped
        yet (too few frames, or none of its wraps to learn its period from) and where the
        timing cannot tell its period (*note* says so); more frames may change it.
    """

    start: int
    step: int
    period: int
    counts: bool = True
    learnt: bool = False
    note: Note | None = None
    sure: bool = True

    @property
    def top(self) -> int:
        """The value before it starts again."""
        return self.start + self.step * (self.period - 1)

    def place(self, raw: npt.ArrayLike) -> IntArray:
        """Each value's place in the counter's cycle, 0 to ``period - 1`` (``+1`` a frame).

        Parameters
        ----------
        raw : array_like of int
            The counter's values as decoded.

        Returns
        -------
        ndarray of int
        """
        c = np.asarray(raw, dtype=np.int64)
        return np.mod((c - self.start) // self.step, self.period).astype(np.int64)


def _width_law(bits: int, start: int, step: int) -> CounterLaw:
    """The law of a counter that counts to its bit width's top, from *start* modulo *step*."""
    width = 1 << min(bits, MAX_BITS)
    return CounterLaw(start, step, max(1, (width - start + step - 1) // step))


def _step(d: IntArray, width: int) -> int | None:
    """The counter's step per frame: its most common step up (None: it never steps up)."""
    up = d[(d > 0) & (d <= width // 2)]
    if not up.size:
        return None
    values, counts = np.unique(up, return_counts=True)
    return int(values[np.argmax(counts)])


def counter_law(t: npt.ArrayLike, raw: npt.ArrayLike, bits: int, *,
                declared: int | None = None, name: str = "of this cell",
                key: str = "normal_force_counter_period") -> CounterLaw:
    """What a counter does, from its values and their timestamps (see the module's
    docstring).

    Parameters
    ----------
    t : array_like of float, s
        The frames' timestamps, in the order received.
    raw : array_like of int
        The counter's values, in the same order.
    bits : int
        The counter signal's width, bits.
    declared : int, optional
        The period the rig file declares (frames): used as it is.
    name : str
        The counter, for the notes (``FzCell.FzCounter``).
    key : str
        The rig file's key that declares its period, for the notes.

    Returns
    -------
    CounterLaw
    """
    c = np.asarray(raw, dtype=np.int64)
    times = np.asarray(t, dtype=np.float64)
    width = 1 << min(bits, MAX_BITS)
    d = np.diff(c)
    if c.size < MIN_FRAMES:  # too few frames to say more than its step, if that
        up = _step(d, width) or 1  # taken when it is most of the steps, three at least
        up = up if up > 1 and np.count_nonzero(d == up) >= max(3, d.size / 2) \
            and np.all((c - c[0]) % up == 0) else 1
        short = _width_law(bits, int(c.min(initial=0)) % up, up)
        return dataclasses.replace(short, period=declared or short.period, sure=False)
    vmin, vmax = int(c.min()), int(c.max())
    step = _step(d, width)
    half = 0.5 * (vmax - vmin)
    wraps = (d < 0) & (c[:-1] - vmin >= half) & (c[1:] - vmin <= half)
    if step is None or (np.count_nonzero(d == step) + np.count_nonzero(wraps)
                        < MIN_COUNTING_SHARE * d.size):
        why = (f"it stays at {vmin}" if vmin == vmax else
               "its values do not step from frame to frame")
        return CounterLaw(0, 1, width, counts=False,
                          note=Note("counter-idle", {"counter": name, "why": why}))
    if step > 1 and np.mean((c - vmin) % step == 0) < 0.99:
        step = 1  # values off its step: no counter by two
    wide = _width_law(bits, vmin % step, step)
    if declared is not None:
        start = wide.start if (vmax - wide.start) // step < declared else vmin
        return CounterLaw(start, step, declared)
    seen = (vmax - vmin) // step + 1
    if not wraps.any():
        return dataclasses.replace(wide, sure=False)  # no wrap to learn from, yet
    if vmin == wide.start and seen >= wide.period:
        return wide  # a wrap at the width's top
    return _timed(times, c, wraps, seen=CounterLaw(vmin, step, seen), wide=wide, name=name,
                  key=key, bits=bits)


def _timed(t: FloatArray, c: IntArray, wraps: npt.NDArray[np.bool_], *, seen: CounterLaw,
           wide: CounterLaw, name: str, key: str, bits: int) -> CounterLaw:
    """The law the timing supports for a counter that never reached its width's top: the
    values seen (no frame skipped at a wrap), or the width's (the frames of its top values
    lost at every wrap), whichever the frames a wrap skips by the timing are (to half a
    frame, or :data:`MARGIN_SE` standard errors) and the other's are not; or the values
    seen where the width's would have the cell send faster than a CAN bus carries; else
    the width's, with a note (a logger whose polls hold a whole cycle of the counter, in
    step with it, says nothing of the frames a wrap skips)."""
    more, se = _frames_a_wrap(t, seen.place(c), seen.period)
    skipped = wide.period - seen.period
    counts = f"from {seen.start} to {seen.top}" + (f" by {seen.step}" if seen.step > 1 else "")
    width = f"from {wide.start} to {wide.top}" + (f" by {wide.step}" if wide.step > 1 else "")
    said = {"counter": name, "counts": counts, "width": width, "bits": bits, "key": key}
    if np.isfinite(more) and abs(more) < abs(more - skipped) \
            and abs(more - skipped) > MARGIN_SE * se and abs(more) <= max(MARGIN_SE * se, 0.5):
        return CounterLaw(seen.start, seen.step, seen.period, learnt=True, note=Note(
            "counter-law", {**said, "period": seen.period}))
    if np.isfinite(more) and abs(more) > MARGIN_SE * se \
            and abs(more - skipped) <= max(MARGIN_SE * se, 0.5):
        return wide  # its top values lost at every wrap: the timing shows them
    dt = np.diff(t)
    span = float(np.sum(dt[(dt > 0) & (dt < JUMP_S)]))
    places = float(np.sum(np.mod(np.diff(seen.place(c)), seen.period)))
    sent = (places + skipped * np.count_nonzero(wraps)) / span if span > 0 else 0.0
    if sent > MAX_FRAME_RATE_HZ:  # the width's law would have the cell send too fast
        return CounterLaw(seen.start, seen.step, seen.period, learnt=True, note=Note(
            "counter-law-rate", {**said, "period": seen.period, "rate_Hz": sent}))
    return CounterLaw(wide.start, wide.step, wide.period, sure=False,
                      note=Note("counter-period-unsure", {**said, "period": seen.period}))


def _steps(place: IntArray, period: int, dt: FloatArray) -> tuple[IntArray, IntArray]:
    """The counter's steps in places, a step back by up to :data:`BACK_REACH` (a quarter of
    the period at most: a frame received twice or late) taken as such, and the wraps each
    step makes (-1 where a frame from before a wrap arrives after it). Where the period is
    long (over four such reaches) a step back is no step ahead by nearly a period; in a
    shorter one it is where the time it took (*dt*, s) says so."""
    steps = np.mod(np.diff(place), period)
    reach = min(BACK_REACH, period // 4)
    back = (steps >= period - reach) & (reach > 0)
    if back.any() and period <= 4 * BACK_REACH:
        one = (steps == 1) & (dt >= 0) & (dt < JUMP_S)
        frame_s = float(np.mean(dt[one])) if np.count_nonzero(one) >= MIN_FRAMES else 0.0
        frames = dt / frame_s if frame_s > 0 else np.full(dt.size, np.inf)
        back &= np.abs(frames - (steps - period)) < np.abs(frames - steps)
    steps = np.where(back, steps - period, steps)
    turns = (int(place[0]) + np.concatenate([[0], np.cumsum(steps)])) // period
    return steps, np.diff(turns)


def _frames_a_wrap(t: FloatArray, place: IntArray, period: int) -> tuple[float, float]:
    """Frames a wrap skips beyond *period*, by the timing, and its standard error:
    :func:`_by_line`'s, else (its wraps as regular as its frames: a counter of a short
    period) :func:`_by_steps`'s. The steps and wraps are the places' (:func:`_steps`):
    frames received twice or late, read as steps ahead by nearly a period, put off every
    frame's place after them."""
    steps, turned = _steps(place, period, np.diff(t))
    wraps = turned == 1
    dt = np.diff(t)
    one = (steps == 1) & (turned == 0) & (dt >= 0) & (dt < JUMP_S)
    at_wrap = wraps & (steps == 1) & (dt >= 0) & (dt < JUMP_S)
    if np.count_nonzero(one) < MIN_FRAMES or not at_wrap.any():
        return float("nan"), float("inf")
    frame_s = float(np.mean(dt[one]))
    if not frame_s > 0:
        return float("nan"), float("inf")
    # a timestamp holding several frames (a logger that stamps its polls) widens the errors
    at_once = max(t.size / (np.count_nonzero(dt > 0.1 * frame_s) + 1), 1.0)
    line = _by_line(t, steps, turned, period=period, frame_s=frame_s, at_once=at_once)
    return line if np.isfinite(line[0]) else _by_steps(dt, one, at_wrap, frame_s)


def _by_steps(dt: FloatArray, one: npt.NDArray[np.bool_], at_wrap: npt.NDArray[np.bool_],
              frame_s: float) -> tuple[float, float]:
    """Frames a wrap skips, by how much longer a wrap's step takes than a frame's (a
    counter of a short period: its wraps as many as its frames; where a logger stamps its
    polls in step with the cell's frames, a wrap falls at one place of a poll and the
    estimate is off by up to a poll's frames)."""
    extra = (float(np.mean(dt[at_wrap])) - frame_s) / frame_s
    var = np.var(dt[at_wrap]) / np.count_nonzero(at_wrap) + np.var(dt[one]) / np.count_nonzero(one)
    return extra, float(np.sqrt(var)) / frame_s


def _by_line(t: FloatArray, steps: IntArray, wraps: IntArray, *, period: int,
             frame_s: float, at_once: float) -> tuple[float, float]:
    """Frames a wrap skips, by the frames' times against their places (``+1`` a frame, each
    wrap ``period``) and the wraps before them, by least squares within the stretches
    between the clock's jumps and the pauses that could hide a whole cycle (each stretch its
    own offset), twice (the second time without the frames far off the first line: a
    logger's stall); the standard error widened by the frames a timestamp holds at once."""
    dt = np.diff(t)
    usual = float(np.quantile(np.abs(dt), 0.99))
    cut = (dt < 0) | (dt > JUMP_S) | (dt > max(0.5 * period * frame_s, 4 * usual))
    stretch = np.concatenate([[0], np.cumsum(cut)])
    x = np.column_stack([np.concatenate([[0], np.cumsum(steps)]),
                         np.concatenate([[0], np.cumsum(wraps)])]).astype(np.float64)
    y = t - t[0]
    keep = np.ones(t.size, dtype=bool)
    beta, sigma, xtx = np.zeros(2), 0.0, np.zeros((2, 2))
    for _ in range(2):
        xs, ys = _within(x, stretch, keep), _within(y[:, None], stretch, keep)[:, 0]
        xtx = xs[keep].T @ xs[keep]
        if abs(np.linalg.det(xtx)) <= 1e-9 * max(float(np.trace(xtx)) ** 2, 1.0):
            return float("nan"), float("inf")  # the wraps as regular as the frames
        beta = np.asarray(np.linalg.solve(xtx, xs[keep].T @ ys[keep]), dtype=np.float64)
        resid = ys - xs @ beta
        sigma = 1.4826 * median(np.abs(resid[keep] - median(resid[keep])))
        keep = np.abs(resid) <= 4 * sigma + frame_s
    if not beta[0] > 0:
        return float("nan"), float("inf")
    se = sigma * np.sqrt(at_once * np.linalg.inv(xtx)[1, 1]) / beta[0]
    return float(beta[1] / beta[0]), float(se)


def _within(x: FloatArray, group: IntArray, keep: npt.NDArray[np.bool_]) -> FloatArray:
    """*x* (columns) less each group's mean over its kept rows."""
    n = np.bincount(group, weights=keep.astype(np.float64))
    out = np.empty_like(x)
    for j in range(x.shape[1]):
        mean = np.bincount(group, weights=np.where(keep, x[:, j], 0.0)) / np.maximum(n, 1.0)
        out[:, j] = x[:, j] - mean[group]
    return out
