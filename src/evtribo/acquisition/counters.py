"""Rolling frame counters: which frames of the rig's load cells were lost on the bus.

A load cell that numbers its frames (``FzCell.FzCounter``, +1 per frame, wrapping at
``2**length``) tells the logger how many of its frames never arrived. The counter is pulled
out of the payloads by :class:`~evtribo.canlog.signal_codec.SignalCodec`, as the decoder pulls every
signal, a batch of frames at a time; frames are keyed by :func:`evtribo.canlog.io.ids.frame_key`.
"""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from cantools.database.can import Database

from evtribo.canlog.io.ids import frame_key
from evtribo.canlog.signal_codec import SignalCodec

log = logging.getLogger(__name__)

__all__ = ["CounterSpec", "CounterTracker", "counter_spec_from_dbc", "frame_key"]

#: Width every payload is padded to before the counter is read (a classic frame's).
_PAYLOAD_BYTES = 8


@dataclass(frozen=True)
class CounterSpec:
    """Where a message's rolling frame counter sits in its payload.

    Attributes
    ----------
    message : str
        Message name in the rig's DBC (``FzCell``).
    arbitration_id : int
        Its CAN identifier.
    codec : SignalCodec
        The counter signal (its start bit, length and byte order).
    is_extended : bool
        The message has a 29-bit identifier.
    """

    message: str
    arbitration_id: int
    codec: SignalCodec
    is_extended: bool = False

    @property
    def key(self) -> int:
        """:func:`~evtribo.canlog.io.ids.frame_key` of the message."""
        return frame_key(self.arbitration_id, self.is_extended)

    @property
    def length(self) -> int:
        """Width in bits; the counter wraps at ``2**length``."""
        return self.codec.length

    def values(self, payloads: Sequence[bytes | bytearray]) -> npt.NDArray[np.int64]:
        """The raw counter values in *payloads* (no scaling: counts); bytes a short payload
        lacks read as 0."""
        width = max([_PAYLOAD_BYTES, *(len(p) for p in payloads)])
        rows = np.frombuffer(b"".join(bytes(p).ljust(width, b"\0") for p in payloads),
                             dtype=np.uint8).reshape(len(payloads), width)
        return self.codec.raw(rows).astype(np.int64)

    def extract(self, data: bytes | bytearray) -> int:
        """The raw counter value in one payload *data*."""
        return int(self.values([data])[0])


def counter_spec_from_dbc(database: Database, message: str, signal: str) -> CounterSpec:
    """A :class:`CounterSpec` for ``message.signal`` of a cantools *database*.

    Parameters
    ----------
    database : cantools.database.can.Database
    message, signal : str
        Names in *database*.

    Returns
    -------
    CounterSpec

    Raises
    ------
    KeyError
        If the message or the signal is not in the database.
    """
    msg = database.get_message_by_name(message)
    return CounterSpec(message=message, arbitration_id=int(msg.frame_id),
                       codec=SignalCodec.from_signal(msg.get_signal_by_name(signal)),
                       is_extended=bool(msg.is_extended_frame))


#: Frames before a frame among which a copy of it is looked for (as
#: :data:`evtribo.canlog.sequence.DUPLICATE_REACH`).
DUPLICATE_REACH = 8
#: Most steps back a frame that arrived late is put back (its loss counted back).
REORDER_REACH = 8
#: Periods either side of a step that skipped values over which the frames' lead over the
#: clock is compared (at least; twice the counter's period where that is more), as the
#: analysis compares them (:class:`evtribo.canlog.outages.Lead`).
JUMP_WINDOW_PERIODS = 64
#: Least disagreement between the counter and the clock taken for a jump of the counter,
#: frames (more where the timestamps scatter: four times their upper envelope's scatter).
JUMP_TOLERANCE = 2.0
#: Periods of the windows whose earliest frames make the upper envelope.
ENVELOPE_PERIODS = 32
#: Fewest frames of a message before a jump of its counter is looked for (as
#: :data:`evtribo.canlog.sequence.MIN_FRAMES`).
MIN_JUMP_FRAMES = 64
#: A restart puts the counter back to 0 or a low value: in the first this share of its
#: range (frames lost just after it included). A step to a higher value is frames lost,
#: whatever the timing says (a logger that stamps frames late for a while, then catches
#: up, makes a loss look like the counter running ahead).
RESTART_SHARE = 1 / 8


@dataclass
class _Skip:
    """A step of the counter that skipped two or more values: counted as frames lost until
    the frames around it say whether the counter jumped there (a restart) instead."""

    at: float          # place of the frame before the step
    after: float       # place of the frame after it, by the counter
    t_before: float    # their timestamps, s
    t_after: float
    counted: int       # frames counted lost at it
    old: int           # the counter before and after the step
    new: int


@dataclass
class _CounterState:
    last: int | None = None
    last_time: float = 0.0
    first_time: float = 0.0
    places: int = 0  # frames since the first, lost ones counted
    frames: int = 0  # frames received (duplicates left out)
    longest_gap: float = 0.0
    dropped: int = 0
    duplicates: int = 0
    reordered: int = 0
    stood: int = 0  # frames in a row whose counter stood still
    restarts: list[float] = field(default_factory=list)
    recent: deque[tuple[int, bytes]] = field(
        default_factory=lambda: deque(maxlen=DUPLICATE_REACH))
    missing: dict[int, int] = field(default_factory=dict)  # counter value: its place
    held: tuple[int, float, int] | None = None  # a frame that may have arrived late
    skips: list[_Skip] = field(default_factory=list)  # steps not yet judged
    # the times and places of the frames received lately, a batch a piece
    seen: list[tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]] = field(
        default_factory=list)


class _Seen:
    """The times and places of the frames of one batch, as they are accounted for."""

    def __init__(self) -> None:
        self.t: list[float] = []
        self.place: list[float] = []

    def add(self, t: float, place: float) -> None:
        self.t.append(t)
        self.place.append(place)

    def keep(self, st: _CounterState) -> None:
        """Add them to *st*'s frames seen (:func:`_seen`)."""
        _seen(st, np.asarray(self.t, dtype=np.float64),
              np.asarray(self.place, dtype=np.float64))


def _window_periods(modulus: int) -> int:
    return max(2 * modulus, JUMP_WINDOW_PERIODS)


class CounterTracker:
    """Count frames missing from each message's rolling counter (+1 per frame).

    A step of ``k`` between two consecutive counter values (modulo ``2**length``) means
    ``k - 1`` frames lost. What a counter does that is no loss is told apart as frames
    arrive, as :mod:`evtribo.canlog.sequence` tells it apart on the whole log:

    - a frame whose counter and payload are those of one of the :data:`DUPLICATE_REACH`
      frames before it is the same frame received again: a duplicate (:attr:`duplicates`),
      not 255 frames lost;
    - a frame whose counter was counted missing among the last :data:`REORDER_REACH` steps
      arrived late: its loss is counted back (two frames received swapped are no 256 lost);
    - a frame whose counter stood still (the value of the frame before, another payload) is
      the next frame, no 255 frames lost, and holds a place the counter steps over later;
    - a counter that restarts (the cell's firmware rebooted: back to 0 or to a low value,
      in the first :data:`RESTART_SHARE` of its range, then on by one) runs ahead of the
      clock: a step to such a value that skips two or more is counted as frames lost at
      once, and judged once the frames of
      :data:`JUMP_WINDOW_PERIODS` periods (twice the counter's period, if more) after it
      have arrived (or the trial has ended: :meth:`settle`). Where the frames after it lead
      the periods elapsed by more than those before it (their upper envelopes: the frames
      that arrived earliest), by more than the timing's noise, the counter jumped: the
      frames lost there are the timing's count, and the time is kept
      (:meth:`restarts_by_message`). The analysis counts a restart the same way (it
      takes a jump to any value for one); a restart that skips fewer values than the
      timing's noise is counted as frames lost.

    A run of ``2**length`` or more consecutive lost frames of one message is counted modulo
    ``2**length``; the longest silence between two frames of each message
    (:meth:`longest_gap_by_message`) shows such holes.
    """

    def __init__(self, specs: Iterable[CounterSpec]) -> None:
        #: Specs by :func:`frame_key` (identifier and kind).
        self.specs = {s.key: s for s in specs}
        self._state = {i: _CounterState() for i in self.specs}

    def update(self, arbitration_id: int, data: bytes | bytearray, timestamp: float,
               is_extended: bool = False) -> int:
        """Account for one frame (*timestamp* in s); return the frames missing just before it."""
        return self.update_many(frame_key(arbitration_id, is_extended), [data], [timestamp])

    def update_many(self, key: int, payloads: Sequence[bytes | bytearray],
                    timestamps: Sequence[float]) -> int:
        """Account for frames of one message, in the order received; return the frames
        missing among them (0 for a message without a counter; negative when frames
        counted missing arrived late, or a step counted as frames lost was a jump)."""
        spec = self.specs.get(key)
        if spec is None or not payloads:
            return 0
        st = self._state[key]
        values = spec.values(payloads)
        times = np.asarray(timestamps, dtype=np.float64)
        modulus = 1 << spec.length
        steps = np.diff(np.concatenate(([st.last], values)) if st.last is not None
                        else values) % modulus
        before = st.dropped
        if st.last is not None and st.held is None and np.all(steps == 1):  # nothing lost
            gaps = np.diff(np.concatenate(([st.last_time], times)))
            st.longest_gap = max(st.longest_gap, float(gaps.max()))
            _seen(st, times, st.places + np.arange(1, values.size + 1, dtype=np.float64))
            st.places += values.size
            st.frames += values.size
            st.recent.extend(zip(values[-DUPLICATE_REACH:].tolist(),
                                 [bytes(p) for p in payloads[-DUPLICATE_REACH:]], strict=True))
            st.missing = {v: p for v, p in st.missing.items()
                          if st.places - p <= REORDER_REACH}
            st.last, st.last_time = int(values[-1]), float(times[-1])
        else:
            seen = _Seen()
            for value, data, t in zip(values.tolist(), payloads, times.tolist(), strict=True):
                self._one(spec, st, value, bytes(data), t=t, seen=seen)
            seen.keep(st)
        self._judge(spec, st, final=False)
        return st.dropped - before

    def _one(self, spec: CounterSpec, st: _CounterState, value: int, data: bytes, *,
             t: float, seen: _Seen) -> None:
        """Account for one frame of *spec*'s message; its time and place go to *seen*."""
        modulus = 1 << spec.length
        if st.last is None:
            st.last, st.last_time, st.first_time = value, t, t
            st.recent.append((value, data))
            st.frames += 1
            seen.add(t, 0.0)
            return
        reach = min(DUPLICATE_REACH, max(modulus // 2 - 1, 1))  # within one counter period
        if (value, data) in list(st.recent)[-reach:]:
            st.duplicates += 1
            return
        if st.held is not None:
            self._resolve(spec, st, value, seen)
        st.recent.append((value, data))
        st.frames += 1
        place = st.missing.get(value)
        if place is not None and st.places - place <= min(REORDER_REACH, modulus // 4):
            # counted missing a few steps ago: it arrived late, if the frames after it go on
            # from the highest before it (a counter that jumped back would repeat places)
            del st.missing[value]
            st.held = (value, t, place)
            return
        self._step(spec, st, value, t, seen)

    def _resolve(self, spec: CounterSpec, st: _CounterState, value: int | None,
                 seen: _Seen) -> None:
        """Say what the frame held back was, now that the frame after it (*value*; None: the
        trial ended) is here: late, when the counter goes on from the highest before it
        without repeating a place; else the counter jumped back there."""
        assert st.held is not None
        held, t, place = st.held
        st.held = None
        modulus = 1 << spec.length
        ahead = None if value is None else (value - (st.last or 0)) % modulus
        if ahead is not None and 1 <= ahead <= REORDER_REACH \
                and value not in {v for v, _ in st.recent}:
            st.dropped -= 1
            st.reordered += 1
            seen.add(t, float(place))
        else:
            self._step(spec, st, held, t, seen)

    def _step(self, spec: CounterSpec, st: _CounterState, value: int, t: float,
              seen: _Seen) -> None:
        """The counter's step to *value*: frames lost, or standing still."""
        modulus = 1 << spec.length
        step = (value - (st.last or 0)) % modulus
        if step == 0:  # standing still (another payload): the next frame, its place kept
            st.stood += 1
            st.places += 1
        else:  # the frames it stood still for held the places it steps over
            lost = max(step - 1 - st.stood, 0)
            st.dropped += lost
            st.missing.update({(value - step + k) % modulus: st.places + k
                               for k in range(max(1, step - REORDER_REACH), step)})
            if lost >= 2 and value < max(modulus * RESTART_SHARE, 2):
                # a loss, or the counter restarting: the frames after it will say
                st.skips.append(_Skip(at=st.places, after=st.places + max(step - st.stood, 1),
                                      t_before=st.last_time, t_after=t, counted=lost,
                                      old=(value - step) % modulus, new=value))
            st.places += max(step - st.stood, 1)
            st.stood = 0
            st.missing = {v: p for v, p in st.missing.items()
                          if st.places - p <= REORDER_REACH}
            st.last = value
        st.longest_gap = max(st.longest_gap, t - st.last_time)
        st.last_time = t
        seen.add(t, float(st.places))

    def _judge(self, spec: CounterSpec, st: _CounterState, *, final: bool) -> None:
        """Judge the steps that skipped values whose frames after have arrived (all of them
        when *final*): a jump of the counter, or frames lost."""
        modulus = 1 << spec.length
        while st.skips:
            skip = st.skips[0]
            period = _rough_period(st, skip)
            if not final and not (period > 0 and st.last_time >= skip.t_after
                                  + _window_periods(modulus) * period):
                break
            st.skips.pop(0)
            ahead = _ahead(st, skip, modulus) if st.frames >= MIN_JUMP_FRAMES else 0
            if ahead:
                lost = max(skip.counted - ahead, 0)
                st.dropped -= skip.counted - lost
                st.restarts.append(skip.t_after)
                log.warning("the counter of %s jumped from %d to %d (it restarted): %d "
                            "frame(s) lost there by the timing, not %d", spec.message,
                            skip.old, skip.new, lost, skip.counted)
                _shift(st, skip.at, ahead)
        _forget(st, modulus)

    def settle(self) -> int:
        """Judge the steps still waiting for frames after them (the trial has ended).

        Returns
        -------
        int
            The change of the count, frames (negative where a step counted as frames lost
            was the counter jumping).
        """
        before = self.dropped
        for key, st in self._state.items():
            if st.held is not None:  # no frame after it: it did not arrive late
                seen = _Seen()
                self._resolve(self.specs[key], st, None, seen)
                seen.keep(st)
            self._judge(self.specs[key], st, final=True)
        return self.dropped - before

    def longest_gap_by_message(self) -> dict[str, float]:
        """Longest time, s, between two consecutive frames of each counted message."""
        return {self.specs[i].message: round(st.longest_gap, 6) for i, st in self._state.items()}

    def dropped_by_message(self) -> dict[str, int]:
        """Frames lost so far, per message name."""
        return {self.specs[i].message: st.dropped for i, st in self._state.items()}

    def restarts_by_message(self, since: float | None = None) -> dict[str, list[float]]:
        """When the counted messages' counters restarted (jumped: to 0 or a low value)
        (those that did): timestamps, s, or seconds from *since*."""
        return {self.specs[i].message: [round(t - (since or 0.0), 6) for t in st.restarts]
                for i, st in self._state.items() if st.restarts}

    @property
    def dropped(self) -> int:
        """Frames lost so far, all messages together."""
        return sum(st.dropped for st in self._state.values())

    @property
    def duplicates(self) -> int:
        """Frames received twice so far, all messages together."""
        return sum(st.duplicates for st in self._state.values())


def _seen(st: _CounterState, t: npt.NDArray[np.float64],
          place: npt.NDArray[np.float64]) -> None:
    """Keep the times and places of frames received, for judging the steps that skipped."""
    if t.size:
        st.seen.append((t, place))


def _all_seen(st: _CounterState) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The times and places kept, in one piece."""
    if len(st.seen) != 1:
        st.seen = [(np.concatenate([np.zeros(0), *(t for t, _ in st.seen)]),
                    np.concatenate([np.zeros(0), *(p for _, p in st.seen)]))]
    return st.seen[0]


def _forget(st: _CounterState, modulus: int) -> None:
    """Drop the pieces of frames no step left to judge will look at (a window's worth
    kept)."""
    keep = 4 * _window_periods(modulus)
    edge = st.skips[0].at - keep if st.skips else st.places - keep
    while len(st.seen) > 1 and st.seen[0][1].max() < edge \
            and sum(t.size for t, _ in st.seen[1:]) >= keep:
        st.seen.pop(0)


def _shift(st: _CounterState, at: float, by: int) -> None:
    """The places after *at* less *by*: the counter jumped ahead by that much there."""
    st.places -= by
    st.seen = [(t, np.where(p > at, p - by, p)) for t, p in st.seen]
    st.missing = {v: p - by if p > at else p for v, p in st.missing.items()}
    for later in st.skips:
        later.at -= by
        later.after -= by


def _rough_period(st: _CounterState, skip: _Skip) -> float:
    """The message's period from the frames before the step and after it, s (NaN when
    neither spans any time)."""
    span = (skip.t_before - st.first_time) + (st.last_time - skip.t_after)
    places = skip.at + (st.places - skip.after)
    return span / places if places > 0 and span > 0 else float("nan")


def _ahead(st: _CounterState, skip: _Skip, modulus: int) -> int:
    """By how many frames the counter ran ahead of the clock at *skip* (a jump), or 0: the
    upper envelope of the frames' lead over the periods elapsed, over a window either side
    (:class:`evtribo.canlog.outages.Lead`'s comparison)."""
    t, place = _all_seen(st)
    rough = _rough_period(st, skip)
    if not rough > 0:
        return 0
    steps = np.diff(t)
    q99 = 4 * float(np.quantile(np.abs(steps), 0.99)) if steps.size else 0.0
    width = max(_window_periods(modulus) * rough, q99)
    before = (place <= skip.at) & (t >= skip.t_before - width)
    after = (place >= skip.after) & (t <= skip.t_after + width)
    if not before.any() or not after.any():
        return 0
    period = _pooled_period(t, place, before, after) or rough
    lead = place - (t - skip.t_before) / period
    shift = float(lead[before].max() - lead[after].max())
    noise = _scatter([(t[m], lead[m]) for m in (before, after)],
                     max(ENVELOPE_PERIODS * period, q99))
    tol = max(JUMP_TOLERANCE, 4 * noise)
    if shift >= -tol:
        return 0
    ahead = round(-shift)
    return ahead if skip.counted >= ahead - tol else 0


def _pooled_period(t: npt.NDArray[np.float64], place: npt.NDArray[np.float64],
                   *pieces: npt.NDArray[np.bool_]) -> float:
    """The least-squares slope of time against place, each piece with its own intercept,
    s (0 when there is none)."""
    sxx = sxt = 0.0
    for m in pieces:
        x, y = place[m] - place[m].mean(), t[m] - t[m].mean()
        sxx += float(x @ x)
        sxt += float(x @ y)
    return sxt / sxx if sxx > 0 else 0.0


def _scatter(pieces: list[tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]],
             width: float) -> float:
    """How much the upper envelope of a lead scatters from one window of *width* s to the
    next (robust), frames, within each piece."""
    steps: list[npt.NDArray[np.float64]] = []
    for t, lead in pieces:
        if t.size < 2 or not width > 0:
            continue
        w = np.floor((t - t.min()) / width).astype(np.int64)
        order = np.argsort(w, kind="stable")
        w = w[order]
        starts = np.flatnonzero(np.r_[True, w[1:] != w[:-1]])
        top = np.maximum.reduceat(lead[order], starts)[1:-1]
        steps.append(np.diff(top))
    d = np.concatenate([np.zeros(0), *steps])
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(2)) if d.size else 0.0
