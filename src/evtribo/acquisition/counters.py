"""Rolling frame counters: which frames of the rig's load cells were lost on the bus.

A load cell that numbers its frames (``FzCell.FzCounter``, +1 per frame, wrapping at
``2**length``) tells the logger how many of its frames never arrived. The counter is pulled
out of the payloads by :class:`~evtribo.canlog.signal_codec.SignalCodec`, as the decoder pulls every
signal, a batch of frames at a time; frames are keyed by :func:`evtribo.canlog.io.ids.frame_key`.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from cantools.database.can import Database

from evtribo.canlog.io.ids import frame_key
from evtribo.canlog.signal_codec import SignalCodec

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


@dataclass
class _CounterState:
    last: int | None = None
    last_time: float = 0.0
    longest_gap: float = 0.0
    dropped: int = 0


class CounterTracker:
    """Count frames missing from each message's rolling counter (+1 per frame).

    A step of ``k`` between two consecutive counter values (modulo ``2**length``) means
    ``k - 1`` frames lost. A run of ``2**length`` or more consecutive lost frames of one
    message is therefore counted modulo ``2**length``; the longest silence between two frames
    of each message (:meth:`longest_gap_by_message`) shows such holes. (Time cannot correct
    the count: adapters such as slcan stamp frames on the host, in bursts.)
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
        missing among them (0 for a message without a counter)."""
        spec = self.specs.get(key)
        if spec is None or not payloads:
            return 0
        st = self._state[key]
        values = spec.values(payloads)
        times = np.asarray(timestamps, dtype=np.float64)
        if st.last is not None:
            values = np.concatenate(([st.last], values))
            times = np.concatenate(([st.last_time], times))
        lost = 0
        if len(values) > 1:
            lost = int(((np.diff(values) - 1) % (1 << spec.length)).sum())
            st.longest_gap = max(st.longest_gap, float(np.diff(times).max()))
        st.dropped += lost
        st.last = int(values[-1])
        st.last_time = float(times[-1])
        return lost

    def longest_gap_by_message(self) -> dict[str, float]:
        """Longest time, s, between two consecutive frames of each counted message."""
        return {self.specs[i].message: round(st.longest_gap, 6) for i, st in self._state.items()}

    def dropped_by_message(self) -> dict[str, int]:
        """Frames lost so far, per message name."""
        return {self.specs[i].message: st.dropped for i, st in self._state.items()}

    @property
    def dropped(self) -> int:
        """Frames lost so far, all messages together."""
        return sum(st.dropped for st in self._state.values())
