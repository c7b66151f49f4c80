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
#: Fewest frames a counter's step to 0 must skip to be taken for a restart.
RESTART_SKIP = 8


@dataclass
class _CounterState:
    last: int | None = None
    last_time: float = 0.0
    first_time: float = 0.0
    places: int = 0  # frames since the first, lost ones counted
    longest_gap: float = 0.0
    dropped: int = 0
    duplicates: int = 0
    reordered: int = 0
    stood: int = 0  # frames in a row whose counter stood still
    restarts: list[float] = field(default_factory=list)
    recent: deque[tuple[int, bytes]] = field(
        default_factory=lambda: deque(maxlen=DUPLICATE_REACH))
    missing: dict[int, int] = field(default_factory=dict)  # counter value: its place


class CounterTracker:
    """Count frames missing from each message's rolling counter (+1 per frame).

    A step of ``k`` between two consecutive counter values (modulo ``2**length``) means
    ``k - 1`` frames lost. Three things a counter does are no loss, and are told apart as
    frames arrive (:mod:`evtribo.canlog.sequence` does the same on the whole log):

    - a frame whose counter and payload are those of one of the :data:`DUPLICATE_REACH`
      frames before it is the same frame received again: a duplicate (:attr:`duplicates`),
      not 255 frames lost;
    - a frame whose counter was counted missing among the last :data:`REORDER_REACH` steps
      arrived late: its loss is counted back (two frames received swapped are no 256 lost);
    - a frame whose counter stood still (the value of the frame before, another payload) is
      the next frame, no 255 frames lost, and holds a place the counter steps over later;
    - a counter that steps to 0 skipping :data:`RESTART_SKIP` or more values, sooner than
      half the time those frames would take, restarted (the cell was reset): no frame is
      counted lost there, and the time is kept (:meth:`restarts_by_message`). A real loss
      that ends exactly at 0 is taken for one, and a restart that skips fewer values is
      counted as frames lost (the analysis tells both from the timing).

    A run of ``2**length`` or more consecutive lost frames of one message is counted modulo
    ``2**length``; the longest silence between two frames of each message
    (:meth:`longest_gap_by_message`) shows such holes. (Time cannot correct the count:
    adapters such as slcan stamp frames on the host, in bursts.)
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
        counted missing arrived late)."""
        spec = self.specs.get(key)
        if spec is None or not payloads:
            return 0
        st = self._state[key]
        values = spec.values(payloads)
        times = np.asarray(timestamps, dtype=np.float64)
        modulus = 1 << spec.length
        steps = np.diff(np.concatenate(([st.last], values)) if st.last is not None
                        else values) % modulus
        if st.last is not None and np.all(steps == 1):  # the usual batch: nothing lost
            gaps = np.diff(np.concatenate(([st.last_time], times)))
            st.longest_gap = max(st.longest_gap, float(gaps.max()))
            st.places += values.size
            st.recent.extend(zip(values[-DUPLICATE_REACH:].tolist(),
                                 [bytes(p) for p in payloads[-DUPLICATE_REACH:]], strict=True))
            st.missing = {v: p for v, p in st.missing.items()
                          if st.places - p <= REORDER_REACH}
            st.last, st.last_time = int(values[-1]), float(times[-1])
            return 0
        before = st.dropped
        for value, data, t in zip(values.tolist(), payloads, times.tolist(), strict=True):
            self._one(spec, st, value, bytes(data), t)
        return st.dropped - before

    def _one(self, spec: CounterSpec, st: _CounterState, value: int, data: bytes,
             t: float) -> None:
        """Account for one frame of *spec*'s message."""
        modulus = 1 << spec.length
        if st.last is None:
            st.last, st.last_time, st.first_time = value, t, t
            st.recent.append((value, data))
            return
        reach = min(DUPLICATE_REACH, max(modulus // 2 - 1, 1))  # within one counter period
        if (value, data) in list(st.recent)[-reach:]:
            st.duplicates += 1
            return
        st.recent.append((value, data))
        place = st.missing.pop(value, None)
        if place is not None and st.places - place <= min(REORDER_REACH, modulus // 4):
            st.dropped -= 1  # counted missing a few steps ago: it arrived late
            st.reordered += 1
            return
        step = (value - st.last) % modulus
        if step == 0:  # standing still (another payload): the next frame, its place kept
            st.stood += 1
            st.places += 1
            st.longest_gap = max(st.longest_gap, t - st.last_time)
            st.last_time = t
            return
        period = (st.last_time - st.first_time) / st.places if st.places else 0.0
        if value == 0 and step - 1 >= RESTART_SKIP and t - st.last_time < 0.5 * step * period:
            st.restarts.append(t)
            log.warning("the counter of %s restarted at 0 (it read %d): no frame counted "
                        "lost there", spec.message, st.last)
            step = 1
        else:  # the frames it stood still for held the places it steps over
            st.dropped += max(step - 1 - st.stood, 0)
            st.missing.update({(st.last + k) % modulus: st.places + k
                               for k in range(max(1, step - REORDER_REACH), step)})
        st.places += max(step - st.stood, 1)
        st.stood = 0
        st.missing = {v: p for v, p in st.missing.items() if st.places - p <= REORDER_REACH}
        st.longest_gap = max(st.longest_gap, t - st.last_time)
        st.last, st.last_time = value, t

    def longest_gap_by_message(self) -> dict[str, float]:
        """Longest time, s, between two consecutive frames of each counted message."""
        return {self.specs[i].message: round(st.longest_gap, 6) for i, st in self._state.items()}

    def dropped_by_message(self) -> dict[str, int]:
        """Frames lost so far, per message name."""
        return {self.specs[i].message: st.dropped for i, st in self._state.items()}

    def restarts_by_message(self, since: float | None = None) -> dict[str, list[float]]:
        """When the counted messages' counters restarted at 0 (those that did): timestamps,
        s, or seconds from *since*."""
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
