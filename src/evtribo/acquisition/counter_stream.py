"""One counted message's frames as the recorder keeps them, and when to count them again.

:class:`~evtribo.acquisition.counters.CounterTracker` keeps a :class:`CounterStream` for each
load cell whose frames carry a counter: every frame received (its place in the log, its time
as the log holds it, its counter and payload), the count of the frames lost made of all of
them the last time, and the count of the frames since. It counts with the analysis's own
count (:mod:`evtribo.canlog.counters.streams`); this module says only *when*: frames whose
counter steps by one change nothing and are not counted again; where one may change the
count, the frames since the last count of all of them (and, before them, a window of the
analysis's) are counted, and all of them once those are a quarter as many
(:data:`WHOLE_SHARE`). A counter's jump with fewer frames after it than the analysis judges
it by counts the values it skipped until they have arrived; the last frames from one that
steps back (a late frame) wait for the frames after it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from evtribo.canlog.counters.law import CounterLaw
from evtribo.canlog.counters.streams import CellCount, CellFrames, CounterSignal, count_cell
from evtribo.canlog.sequence import REORDER_REACH

__all__ = ["CounterStream", "Tally"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: A message with fewer frames than this is counted whole whenever a frame may change its
#: count (a few milliseconds).
WHOLE_FRAMES = 4096
#: All of a trial's frames are counted again once a message's frames since the last such
#: count are this share of those it counted: counting all of them again and again costs a
#: few times counting them once.
WHOLE_SHARE = 1 / 4
#: The frames since the last count of all of them are counted again (where a frame may
#: change the count) once they have grown by this share, or are fewer than
#: :data:`WHOLE_FRAMES`.
TAIL_SHARE = 1 / 16
#: A message whose frames lost are the timestamps' count (a counter that does not count,
#: or whose period is not known yet) is counted again once this many frames (or a quarter
#: more) have arrived: that count looks for the stream's period in all of them.
TIMED_FRAMES = 1024
#: Fewest frames after a counter's jump for it to be judged while the trial is recorded
#: (twice the counter's period, if more), as the analysis's window
#: (:class:`evtribo.canlog.outages.Lead`).
JUMP_WINDOW_PERIODS = 64
#: Most frames before those since the last count of all of them counted with them (a
#: jump's window before it, the duplicates and late frames at their start).
MAX_OVERLAP = 16_384


@dataclass
class Tally:
    """A count of some of a message's frames (all of them, or those from one on)."""

    dropped: int = 0
    duplicates: int = 0
    restarts: list[tuple[int, float]] = field(default_factory=list)  # (frame, time) judged
    law: CounterLaw | None = None
    waiting: bool = False  # a jump waits for the frames after it


def _tally(found: CellCount, first: int, size: int, *, final: bool) -> Tally:
    """*found*, the count of *size* frames of a message from its *first* on, as the tracker
    keeps it: a jump of the counter with fewer frames after it than the analysis's window
    counts the values it skipped until they have arrived (or the log has closed), where the
    counter counts (a count the timing's, the counter ignored, holds no jump's values)."""
    window = max(2 * (found.modulus or 0), JUMP_WINDOW_PERIODS)
    out = Tally(found.found.count, found.seq.duplicates, law=found.law)
    for jump in found.seq.jumps:
        if not final and size - jump.after < window:
            out.dropped += jump.skipped - jump.lost if found.counted else 0
            out.waiting = True
        else:
            out.restarts.append((first + jump.after, jump.t))
    return out


class CounterStream:
    """One counted message: its frames so far, and their counts.

    Parameters
    ----------
    signal : CounterSignal
        Its counter, as the analysis reads its law.
    message : str
        The message's name (``FzCell``).
    """

    def __init__(self, signal: CounterSignal, message: str) -> None:
        self.signal = signal
        self.message = message
        self.parts: list[tuple[IntArray, FloatArray, IntArray, npt.NDArray[np.uint8]]] = []
        self.n = 0
        self.last: int | None = None  # the counter of the last frame
        self.first_time = self.last_time = 0.0
        self.longest_gap = 0.0
        self.bounds = (0, -1)  # the counter's least and largest values
        self.whole = Tally()  # of the frames up to n_whole
        self.n_whole = 0
        self.base = 0  # the tail's first frame
        self.before: Tally | None = None  # of the frames from base to n_whole, alone
        self.tail: Tally | None = None  # of the frames from base on
        self.tail_at = 0
        self.odd = False  # frames since the last count that may change it
        self.wrapped = False  # the counter's first wrap arrived, its law not read since
        self.wrap_seen = False  # a step down such as a wrap makes arrived
        self.whole_wrapped = False  # ... among the frames of the last count of all of them
        self.final = False  # counted once the trial ended

    def add(self, rows: IntArray, t: FloatArray, raw: IntArray,
            payload: npt.NDArray[np.uint8]) -> None:
        """Keep a batch of frames; say whether they may change the count."""
        law = self.whole.law if self.n_whole else None
        seq = raw if self.last is None else np.concatenate([[self.last], raw])
        lo, hi = int(seq.min()), int(seq.max())
        if self.n:
            lo, hi = min(lo, self.bounds[0]), max(hi, self.bounds[1])
        self.bounds = (lo, hi)
        # a step down but a late frame's (back by no more than a late frame of a counter by
        # two is, within the time of as many frames): the counter's period says how many
        # frames it skipped
        half, d = 0.5 * (hi - lo), np.diff(seq)
        dt = np.diff(np.concatenate([[self.last_time], t]) if self.n else t)
        frame_s = (self.last_time - self.first_time) / (self.n - 1) if self.n > 1 else np.inf
        wrap = bool(np.any((d < 0) & (((seq[:-1] - lo >= half) & (seq[1:] - lo <= half))
                                      | (d < -2 * REORDER_REACH)
                                      | (dt > REORDER_REACH * frame_s))))
        self.wrap_seen |= wrap
        if law is None or not law.counts:
            self.odd = True  # the timestamps' count: any frame may change it
        else:
            self.odd |= bool(np.any(np.mod(np.diff(law.place(seq)), law.period) != 1))
            # the first wrap of a counter not known to wrap yet: its law read again at once
            self.wrapped |= wrap and not law.sure and law.note is None
        self.longest_gap = max(self.longest_gap, float(dt.max(initial=0.0)))
        self.first_time = self.first_time if self.n else float(t[0])
        self.parts.append((rows, t, raw, payload))
        self.n += t.size
        self.last, self.last_time = int(raw[-1]), float(t[-1])

    def frames(self) -> tuple[IntArray, FloatArray, IntArray, npt.NDArray[np.uint8]]:
        """Every frame kept, in one piece (rows, times, counters, payloads)."""
        if len(self.parts) > 1:
            width = max(p[3].shape[1] for p in self.parts)
            self.parts = [(np.concatenate([p[0] for p in self.parts]),
                           np.concatenate([p[1] for p in self.parts]),
                           np.concatenate([p[2] for p in self.parts]),
                           np.concatenate([np.pad(p[3], ((0, 0), (0, width - p[3].shape[1])))
                                           for p in self.parts]))]
        return self.parts[0]

    def cell(self, a: int, b: int, rows: IntArray, law: CounterLaw | None) -> CellFrames:
        """Frames *a* to *b* as the analysis counts them (*rows*: their places in the
        log's times handed with them)."""
        _, _, raw, payload = self.frames()
        return CellFrames(rows, raw[a:b], payload[a:b], self.signal, law)

    def known(self) -> bool:
        """Whether the count is known: the counter's law is certain, or it has not wrapped
        (nor stepped down as a wrap does) among the frames counted."""
        law = self.whole.law
        return (self.final or law is None or not law.counts or law.sure
                or not self.whole_wrapped)

    def upto(self, *, final: bool) -> int:
        """The frames to count now: all of them but, while the trial goes on, the last few
        from one that steps back (a late frame, as the frames after it will say), and the
        frames it may have been sent before (a step ahead over it is no loss yet)."""
        law = self.whole.law
        if final or not self.n:
            return self.n
        period = law.period if law is not None and law.counts else 1 << self.signal.bits
        reach = min(REORDER_REACH, period // 4)
        _, _, raw, _ = self.frames()
        a = max(0, self.n - 2 * reach - 1)
        last = raw[a:]
        place = law.place(last) if law is not None and law.counts else last
        back = np.flatnonzero(np.mod(np.diff(place), period) >= period - reach)
        back = back[back >= self.n - reach - 1 - a] if reach else back[:0]
        if not back.size:
            return self.n
        late = int(back[0]) + 1  # in *last*; the frames before it it was sent before
        first = max(0, late - reach)
        ahead = np.mod(place[first:late] - place[late], period)
        before = np.flatnonzero((ahead >= 1) & (ahead <= reach))
        return a + first + int(before[0]) if before.size else a + late

    def due(self) -> str:
        """What its frames since the last count call for: ``"whole"`` (all of the trial's
        frames counted), ``"tail"`` (its frames since), or ``""``."""
        if not self.odd:
            return ""
        law = self.whole.law
        timed = law is not None and (not law.counts or (not law.sure and law.note is not None))
        since = self.n - self.n_whole
        if self.wrapped or since >= max(TIMED_FRAMES if timed else 0,
                                        WHOLE_SHARE * self.n_whole) \
                or (self.n < WHOLE_FRAMES and not timed):
            return "whole"
        since = self.n - self.base
        if not timed and (since <= WHOLE_FRAMES or self.n - self.tail_at
                          >= TAIL_SHARE * since):
            return "tail"
        return ""

    def counted_tail(self) -> None:
        """Count the frames since the last count of all of them (with the window before)."""
        _, t, _, _ = self.frames()
        law = self.whole.law
        if self.before is None:
            a, b = self.base, self.n_whole
            self.before = _tally(count_cell(t[a:b], self.cell(a, b, np.arange(b - a), law)),
                                 a, b - a, final=False)
        a, b = self.base, self.upto(final=False)
        self.tail = _tally(count_cell(t[a:b], self.cell(a, b, np.arange(b - a), law)),
                           a, b - a, final=False)
        self.tail_at, self.odd = self.n, self.tail.waiting or b < self.n

    def counted_whole(self, found: CellCount, upto: int, *, final: bool) -> None:
        """Take the count of its first *upto* frames (all of them: *final*)."""
        self.whole = _tally(found, 0, upto, final=final)
        self.n_whole, self.tail_at = upto, self.n
        window = max(2 * (found.modulus or 0), JUMP_WINDOW_PERIODS)
        self.base = max(0, upto - min(window + 32, MAX_OVERLAP))
        self.before = self.tail = None
        self.odd, self.wrapped = self.whole.waiting or upto < self.n, False
        self.final, self.whole_wrapped = final, self.wrap_seen

    @property
    def dropped(self) -> int:
        """Frames lost, as last counted."""
        if self.tail is None or self.before is None:
            return self.whole.dropped
        return self.whole.dropped + self.tail.dropped - self.before.dropped

    @property
    def duplicates(self) -> int:
        """Frames received twice, as last counted."""
        if self.tail is None or self.before is None:
            return self.whole.duplicates
        return self.whole.duplicates + self.tail.duplicates - self.before.duplicates

    def restarts(self) -> list[float]:
        """When the counter restarted (the jumps judged), s."""
        if self.tail is None:
            return [t for _, t in self.whole.restarts]
        return [t for k, t in self.whole.restarts if k < self.base] + \
            [t for _, t in self.tail.restarts]
