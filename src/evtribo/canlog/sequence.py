"""A load cell's frames in the order it sent them, whatever the logger made of them.

Real logs hold frames the cell never sent that way: a frame received twice (an adapter's
retransmission, a bridge that forwards both ways), two frames received in each other's
place (an adapter's two receive buffers), a rolling counter that restarts at 0 (the cell
reset by a brown-out), and the logger's clock stepping back or ahead mid-trial (NTP, a PC's
clock set by hand). Read as they are, the first three make the counter step by 0, -1 or
anything: 255, 256 or up to 255 frames "lost", where none was; and a clock that steps back
makes the frames from before and after the step interleave once sorted by time. Here,
before any count:

- **a duplicate**: a frame whose counter and whole payload are those of one of the
  :data:`DUPLICATE_REACH` frames before it is the same frame again: dropped, and counted as
  a duplicate (only on a stream whose counter steps by one most of the time: a counter that
  stands still is no counter, and a constant payload no duplicate);
- **a reorder**: a frame whose counter is at most :data:`REORDER_REACH` behind the highest
  before it, and fills a place still empty there, arrived late: the frames are put back in
  the counter's order;
- **a counter that jumps, and a clock that steps**: the counter and the clock can disagree
  for good only there. Each frame's *lead*, its place in the stream (by the counter, or its
  rank) less the periods elapsed since the first frame, is steady whatever the latency; its
  upper envelope (the frames that arrived earliest, over windows of many periods, which
  bursts, stalls and jitter leave alone) says by how many frames the two disagree after a
  step, and the step itself says which one moved: the time going back is the clock stepping
  back; the counter running ahead of the time, the counter jumping (a restart); the time
  running ahead of the counter by other than whole counter periods (which are frames lost,
  :func:`evtribo.canlog.dropped.missing_frames`), the clock stepping ahead. Without a
  counter only a step back can be seen: the frames after it are taken to follow the frame
  before it by one period.

A step larger than :data:`~evtribo.canlog.dropped.CLOCK_JUMP_S` ahead, or back so far that
the frames after it fall before the trial's first frame, is left as it is (the analysis cuts
the trial there: :mod:`evtribo.analysis.forces.pieces`).
"""

from __future__ import annotations

import itertools
import logging
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from evtribo.canlog.outages import Lead
from evtribo.warning.collect import emitter
from evtribo.warning.record import WarningRecord

log = logging.getLogger(__name__)
emit = emitter(__name__)

__all__ = ["DUPLICATE_REACH", "REORDER_REACH", "ClockStep", "CounterJump", "Sequenced",
           "clock_corrected", "log_clock_steps", "say", "sending_order"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: Frames before a frame among which a copy of it is looked for.
DUPLICATE_REACH = 8
#: Most places a frame may arrive behind its own and be put back.
REORDER_REACH = 8
#: Most counter jumps and clock steps looked for in one stream.
MAX_EVENTS = 20
#: Fewest frames for jumps and steps to be looked for.
MIN_FRAMES = 64
#: Shortest counter period for which a counter stepping by 0 is taken to stand still (a frame
#: the firmware stamped with the value before): in a shorter one it is a whole period of
#: frames lost, as likely as not (one frame lost of a counter counting 0, 1, 0, 1).
MIN_STANDING_PERIOD = 8


@dataclass(frozen=True)
class ClockStep:
    """The logger's clock stepping between two frames of a stream.

    Attributes
    ----------
    before, after : int
        The two frames (positions in the stream as received).
    t : float, s
        Timestamp of the frame before the step.
    step_s : float, s
        The step: negative back, positive ahead.
    """

    before: int
    after: int
    t: float
    step_s: float


@dataclass(frozen=True)
class CounterJump:
    """The rolling counter jumping (a restart) between two frames.

    Attributes
    ----------
    after : int
        The first frame after the jump (position in the stream as received).
    t : float, s
        Its timestamp.
    old, new : int
        The counter before the jump and after it.
    lost : int
        Frames lost at the jump, by the timing.
    skipped : int
        Frames the counter's step skips there (what it counts lost read as no jump).
    """

    after: int
    t: float
    old: int
    new: int
    lost: int
    skipped: int = 0


@dataclass
class Sequenced:
    """A stream in the order it was sent.

    Attributes
    ----------
    rows : ndarray of int
        Positions of the frames kept (duplicates left out), in the order sent.
    t : ndarray of float, s
        Their timestamps, clock steps taken out, made increasing within each stretch
        between steps left as they are (frames put back in order take the times in order).
    counter : ndarray of int or None
        Their counter as if it had not jumped (the frames lost at a jump kept as gaps).
    by_time : ndarray of int
        The order of the stretches by time (identity unless a step left as it is went
        back): ``rows[by_time]`` are the frames in time order.
    duplicates : int
        Frames received twice, dropped.
    first_duplicate : float, s
        Timestamp of the first of them (NaN: none).
    stood : int
        Frames whose counter stood still (the value of the frame before, another payload):
        taken for the next frame, their counter put right.
    first_stood : float, s
        Timestamp of the first of them (NaN: none).
    reordered : int
        Frames that arrived out of their place, put back.
    jumps : list of CounterJump
    steps : list of ClockStep
    """

    rows: IntArray
    t: FloatArray
    counter: IntArray | None
    by_time: IntArray
    duplicates: int = 0
    first_duplicate: float = float("nan")
    stood: int = 0
    first_stood: float = float("nan")
    reordered: int = 0
    jumps: list[CounterJump] = field(default_factory=list)
    steps: list[ClockStep] = field(default_factory=list)


def _steps(c: IntArray, modulus: int) -> IntArray:
    """The counter's steps modulo its period."""
    return np.mod(np.diff(c), modulus)


def _duplicates(c: IntArray, payload: npt.NDArray[np.uint8], modulus: int
                ) -> npt.NDArray[np.bool_]:
    """Frames whose counter and payload are those of one of the few frames before them."""
    n = c.size
    dup = np.zeros(n, dtype=bool)
    rows = np.ascontiguousarray(payload)
    key = rows.view(np.dtype((np.void, rows.shape[1]))).ravel() if rows.ndim == 2 \
        else rows
    for m in range(1, min(DUPLICATE_REACH, max(modulus // 2 - 1, 1), n - 1) + 1):
        same = np.flatnonzero(c[m:] == c[:-m])  # few: the payloads of those alone compared
        dup[same[key[same + m] == key[same]] + m] = True
    return dup


def _local_order(c: IntArray, modulus: int, d: IntArray) -> tuple[IntArray, int]:
    """The order that puts frames that arrived a few places late back in their place, and
    how many did: a counter stepping back by at most :data:`REORDER_REACH`, to places not
    held by the frames around (a restart repeats them), and above where it was again within
    as many frames (*d*: the counter's steps)."""
    reach = min(REORDER_REACH, modulus // 4)
    back = (d >= modulus - reach) & (reach > 0)
    if not back.any():
        return np.arange(c.size), 0
    for j in np.flatnonzero(back):
        u = np.concatenate([[0], np.cumsum(np.where(back, d - modulus, d))])
        top = u[:j + 1].max()
        ahead = np.flatnonzero(u[j + 2:j + 2 + reach] > top)
        end = j + 2 + (int(ahead[0]) if ahead.size else reach)
        around = u[max(0, j + 1 - 2 * reach):min(u.size, end + reach)]
        if not ahead.size or np.unique(around).size < around.size:
            back[j] = False  # no late frame: a jump of the counter, counted as such
    u = np.concatenate([[0], np.cumsum(np.where(back, d - modulus, d))])
    order = np.argsort(u, kind="stable")
    if np.any(np.diff(u[order]) == 0) or np.any(np.abs(order - np.arange(u.size)) > reach):
        return np.arange(c.size), 0
    return order, int(np.count_nonzero(u[1:] < np.maximum.accumulate(u)[:-1]))


def _events(s: Lead, c: IntArray | None) -> tuple[list[tuple[int, float]],
                                                       list[tuple[int, int]]]:
    """Put *s* right where the counter and the clock disagree for good; return the clock
    steps (step j, seconds) and the counter jumps (step j, frames)."""
    steps: list[tuple[int, float]] = []
    jumps: list[tuple[int, int]] = []
    cand = s.odd
    done: set[int] = set()
    if not cand.size:
        return steps, jumps
    for _ in range(MAX_EVENTS):
        lead, mono = s.lead(), s.monotone()
        shifts = np.array([0.0 if j in done else s.shift(int(j), lead, mono) for j in cand])
        big = np.flatnonzero(np.abs(shifts) > s.tol)
        if not big.size:
            break
        top = np.abs(shifts[big]).max()
        near = big[np.abs(shifts[big]) >= top - s.tol]
        at = cand[near]
        dt = (s.t[at + 1] - s.t[at]) / s.period - (s.index[at + 1] - s.index[at])
        pick = near[int(np.argmax(np.abs(dt)))]
        j, h = int(cand[pick]), float(shifts[pick])
        done.add(j)
        # the step's own disagreement, frames; a logger that stamps its polls shows a step
        # of the clock up to a poll's frames short
        held = float(dt[near == pick][0])
        if s.t[j + 1] < s.t[j] and held <= h / 2 + s.poll:  # the clock went back, by about h
            steps.append((j, h * s.period))
            s.t[j + 1:s.bounds[np.searchsorted(s.bounds, j, side="right")]] -= h * s.period
        elif c is None or s.modulus is None:
            continue  # frames lost (an outage): counted by the timing
        elif h < 0:
            k = round(-h)
            skipped = int(s.index[j + 1] - s.index[j]) - 1
            if skipped < k - s.tol:
                continue
            # the frame after a jump is one place on at least: where the timing puts the
            # whole step down to the jump (its first frame within a period of the last, or
            # a poll's stamps making it look so), none lost there, not a period less one
            k = min(k, skipped)
            if k < 1:
                continue
            jumps.append((j, k))
            s.index[j + 1:] -= k
        else:
            whole = round(h / s.modulus)
            if (whole >= 1 and abs(h - whole * s.modulus) <= s.tol) or held + s.poll < h / 2:
                continue  # whole counter periods lost (counted by dropped.missing_frames),
                # or a shift no step of the clock holds: no step of the clock
            steps.append((j, h * s.period))
            s.t[j + 1:s.bounds[np.searchsorted(s.bounds, j, side="right")]] -= h * s.period
    return steps, jumps


def _counted(out: Sequenced, times: FloatArray, c: IntArray | None, rows: IntArray, *,
             d: IntArray | None, modulus: int | None, payload: npt.ArrayLike | None
             ) -> tuple[IntArray, IntArray | None, int | None]:
    """Duplicates dropped, late frames put back and a standing counter stepped on, as the
    counter tells them (recorded in *out*); return the rows kept, their counter steps and the
    modulus (None when there is no counter to trust)."""
    if c is not None and d is not None and modulus and 2 * np.count_nonzero(d == 1) >= d.size > 0:
        # a counter, stepping by one for most frames (a constant is none)
        if payload is not None:
            dup = _duplicates(c, np.asarray(payload), modulus)
            out.duplicates = int(dup.sum())
            if out.duplicates:
                out.first_duplicate = float(times[np.argmax(dup)])
                rows = rows[~dup]
        if out.duplicates:
            d = _steps(c[rows], modulus)
        order, out.reordered = _local_order(c[rows], modulus, d)
        if out.reordered:
            rows = rows[order]
            d = _steps(c[rows], modulus)
    elif c is not None:
        modulus = None  # no counter to trust: its values are kept as they are
    if d is not None and modulus and modulus >= MIN_STANDING_PERIOD and np.any(d == 0):
        # the counter stood still (not a duplicate: the payload differs): the frame is the
        # next one all the same, its counter put right (a counter of a short period that
        # steps by 0 lost a whole period: counted as such)
        out.stood = int(np.count_nonzero(d == 0))
        out.first_stood = float(times[rows[int(np.argmax(d == 0)) + 1]])
        d = _stepped_on(d)
    return rows, d, modulus


def _stepped_on(d: IntArray) -> IntArray:
    """The counter's steps *d* with each frame it stood still for (a step of 0) taken for
    the next frame, and the step out of the run stepping over the places they took (by one
    at least): the frames of the run are no loss there."""
    stood = d == 0
    out = np.where(stood, 1, d)
    moved = np.flatnonzero(~stood)
    run = np.diff(np.concatenate([[0], np.cumsum(stood)[moved]]))  # stood just before each
    out[moved] = np.maximum(d[moved] - run, 1)
    return out


def sending_order(t: npt.ArrayLike, counter: npt.ArrayLike | None = None,
                  modulus: int | None = None, payload: npt.ArrayLike | None = None
                  ) -> Sequenced:
    """A stream's frames in the order sent: duplicates dropped, late frames put back, the
    counter's jumps and the clock's steps found and taken out (see the module's docstring).

    Parameters
    ----------
    t : array_like of float, s
        Timestamps, in the order the frames were received.
    counter : array_like of int, optional
        The stream's rolling counter, in the same order.
    modulus : int, optional
        The counter's period (default: the next power of two above its largest value).
    payload : array_like of uint8, optional
        The frames' payloads (one row each): a duplicate is a frame with the counter *and*
        the payload of one before it.

    Returns
    -------
    Sequenced
    """
    times = np.asarray(t, dtype=np.float64)
    n = times.size
    rows = np.arange(n, dtype=np.int64)
    c = None if counter is None else np.asarray(counter, dtype=np.int64)
    if c is not None and modulus is None and c.size:
        modulus = 1 << max(int(c.max(initial=0)).bit_length(), 1)
    out = Sequenced(rows, times, c, rows)
    d = None if c is None or not modulus else _steps(c, modulus)
    rows, d, modulus = _counted(out, times, c, rows, d=d, modulus=modulus,
                                payload=payload)
    moved = rows.size < n or out.reordered
    ts = times[rows] if moved else times
    cs = None if c is None else c[rows] if moved else c
    if out.stood and cs is not None and d is not None and modulus:
        cs = (cs[0] + np.concatenate([[0], np.cumsum(d)])) % modulus
    index = (np.concatenate([[0], np.cumsum(d)]) if d is not None and modulus
             else np.arange(rows.size))
    s = Lead.of(ts, index, modulus) if rows.size >= MIN_FRAMES else None
    if s is not None:
        steps, jumps = _events(s, cs if modulus else None)
        ts = s.t
        out.steps = [ClockStep(int(rows[j]), int(rows[j + 1]), float(times[rows[j]]), dt)
                     for j, dt in steps]
        if jumps and c is not None and cs is not None and modulus:
            cs = (cs[0] + s.index) % modulus
            out.jumps = [CounterJump(int(rows[j + 1]), float(times[rows[j + 1]]),
                                     int(c[rows[j]]), int(c[rows[j + 1]]),
                                     int(max(int(index[j + 1] - index[j]) - 1 - k, 0)),
                                     int(index[j + 1] - index[j]) - 1)
                         for j, k in jumps]
        bounds = s.bounds
    else:
        bounds = np.array([0, rows.size], dtype=np.int64)
    if (cs is None or not modulus) and np.any(ts[1:] < ts[:-1]):
        # no counter to order them: time does, stretch by stretch
        order = np.concatenate([a + np.argsort(ts[a:b], kind="stable")
                                for a, b in itertools.pairwise(bounds)])
        rows, ts = rows[order], ts[order]
        cs = None if cs is None else cs[order]
    out.rows, out.counter = rows, cs
    out.t, out.by_time = _in_time(ts, bounds)
    return out


def _in_time(t: FloatArray, bounds: IntArray) -> tuple[FloatArray, IntArray]:
    """*t* made increasing within each stretch (its values sorted: frames put back in order
    take the times in order), and the order of the stretches by time."""
    if bounds.size == 2 and not np.any(t[1:] < t[:-1]):
        return t, np.arange(t.size, dtype=np.int64)
    out = t.copy()
    starts = []
    for a, b in itertools.pairwise(bounds):
        out[a:b] = np.sort(t[a:b])
        starts.append(out[a] if b > a else np.inf)
    pieces = np.argsort(np.asarray(starts), kind="stable")
    by_time = [np.arange(bounds[k], bounds[k + 1]) for k in pieces]
    return out, np.concatenate([np.zeros(0, dtype=np.int64), *by_time]).astype(np.int64)


def clock_corrected(t: npt.ArrayLike, steps: list[tuple[int, int, float]]) -> FloatArray:
    """A log's timestamps with the logger's clock steps taken out.

    Parameters
    ----------
    t : array_like of float, s
        The log's timestamps, in its order.
    steps : list of (int, int, float)
        Each step: the rows of the frames just before and just after it (of one stream),
        and the step, s (negative: back). Frames of other streams between the two rows are
        after the step when their timestamps are.

    Returns
    -------
    ndarray of float, s
        The frames after each step moved by minus the step.
    """
    out = np.asarray(t, dtype=np.float64).copy()
    for before, after, step in sorted(steps):
        moved = np.zeros(out.size, dtype=bool)
        moved[after:] = True
        between = np.arange(before + 1, after)
        if between.size:  # after the step when stamped on its far side
            edge = out[before] + step / 2
            moved[between] = out[between] < edge if step < 0 else out[between] > edge
        out[moved] -= step
    return out


def log_clock_steps(streams: list[tuple[npt.NDArray[np.int64], Sequenced]]
                    ) -> list[tuple[int, int, float, float]]:
    """The logger's clock steps, as the streams of one log saw them, each once.

    Parameters
    ----------
    streams : list of (ndarray of int, Sequenced)
        Each stream's rows in the log (in the order received) and what
        :func:`sending_order` found in it.

    Returns
    -------
    list of (int, int, float, float)
        Each step: the rows (in the log) of the frames just before and just after it, the
        step (s, negative: back) and the time of the frame before it (s); a step seen by
        several streams within 50 ms is taken from the stream with the most frames (the
        finest clock).
    """
    seen = sorted(((float(st.t), float(st.step_s), -seq.rows.size,
                    int(rows[st.before]), int(rows[st.after]))
                   for rows, seq in streams for st in seq.steps))
    out: list[tuple[int, int, float, float]] = []
    group: list[tuple[float, float, int, int, int]] = []
    for item in [*seen, None]:
        if item is not None and group and item[0] - group[0][0] < 0.05 \
                and np.sign(item[1]) == np.sign(group[0][1]):
            group.append(item)
            continue
        if group:
            t, step, _, before, after = min(group, key=lambda g: g[2])
            out.append((before, after, step, t))
        group = [] if item is None else [item]
    return out


def say(steps: list[tuple[int, int, float, float]],
        cells: list[tuple[str, str | None, Sequenced]], t0: float) -> list[WarningRecord]:
    """Say what was put right in a trial's streams, each time from the trial's start
    (``clock-step``, ``counter-restart``, ``counter-jump``, ``frames-twice``,
    ``counter-stood``).

    Parameters
    ----------
    steps : list of (int, int, float, float)
        :func:`log_clock_steps`.
    cells : list of (str, str or None, Sequenced)
        Each load cell's message, its counter's name (None: it has none) and what
        :func:`sending_order` made of it.
    t0 : float, s
        The trial's start.

    Returns
    -------
    list of WarningRecord
        One per clock step, counter jump, and cell with duplicates, in that order.
    """
    out = []
    for _, _, step, t in steps:
        out.append(emit("clock-step", direction="back" if step < 0 else "ahead",
                        step_s=abs(step), at_s=t - t0))
    for name, counter, seq in cells:
        for jump in seq.jumps:
            out.append(emit("counter-restart" if jump.new == 0 else "counter-jump",
                            counter=counter, old=jump.old, new=jump.new, at_s=jump.t - t0,
                            lost=jump.lost))
        if seq.duplicates:
            out.append(emit("frames-twice", frames=seq.duplicates, message=name,
                            at_s=seq.first_duplicate - t0))
        if seq.stood:
            out.append(emit("counter-stood", counter=counter, frames=seq.stood,
                            at_s=seq.first_stood - t0))
        if seq.reordered:
            log.info("%d frames of %s arrived out of their place: put back in the counter's "
                     "order", seq.reordered, name)
    return out
