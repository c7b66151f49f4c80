"""Rolling frame counters: which frames of the rig's load cells were lost on the bus.

A load cell that numbers its frames (``FzCell.FzCounter``, +1 per frame, wrapping at
``2**length``) tells the logger how many of its frames never arrived.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from cantools.database.utils import start_bit

__all__ = ["CounterSpec", "CounterTracker", "counter_spec_from_dbc", "frame_key"]


@dataclass(frozen=True)
class CounterSpec:
    """Where a message's rolling frame counter sits in its payload.

    Attributes
    ----------
    message : str
        Message name in the rig's DBC (``FzCell``).
    arbitration_id : int
        Its CAN identifier.
    start : int
        Bit position of the counter's least significant bit (little endian) or most
        significant bit counted from the first byte's MSB (big endian), as
        :func:`cantools.database.utils.start_bit` gives it.
    length : int
        Width in bits; the counter wraps at ``2**length``.
    big_endian : bool
        Motorola byte order.
    is_extended : bool
        The message has a 29-bit identifier.
    """

    message: str
    arbitration_id: int
    start: int
    length: int
    big_endian: bool = False
    is_extended: bool = False

    @property
    def key(self) -> int:
        """:func:`frame_key` of the message."""
        return frame_key(self.arbitration_id, self.is_extended)

    def extract(self, data: bytes | bytearray) -> int:
        """The raw counter value in *data* (no scaling: counts)."""
        mask = (1 << self.length) - 1
        if self.big_endian:
            nbits = 8 * len(data)
            return (int.from_bytes(data, "big") >> (nbits - self.start - self.length)) & mask
        return (int.from_bytes(data, "little") >> self.start) & mask


def frame_key(arbitration_id: int, is_extended: bool) -> int:
    """One integer per identifier and kind: the ID, with bit 31 set for a 29-bit ID (as
    cantools numbers extended frames), so that standard ``0x0C1`` and extended
    ``0x000000C1`` differ."""
    return arbitration_id | (0x80000000 if is_extended else 0)


def counter_spec_from_dbc(database: object, message: str, signal: str) -> CounterSpec:
    """A :class:`CounterSpec` for ``message.signal`` of a cantools *database*.

    Raises
    ------
    KeyError
        If the message or the signal is not in the database.
    """
    msg = database.get_message_by_name(message)  # type: ignore[attr-defined]
    sig = msg.get_signal_by_name(signal)
    return CounterSpec(
        message=message,
        arbitration_id=int(msg.frame_id),
        start=int(start_bit(sig)),
        length=int(sig.length),
        big_endian=sig.byte_order == "big_endian",
        is_extended=bool(msg.is_extended_frame),
    )


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
        key = frame_key(arbitration_id, is_extended)
        spec = self.specs.get(key)
        if spec is None:
            return 0
        st = self._state[key]
        value = spec.extract(data)
        lost = 0
        if st.last is not None:
            lost = (value - st.last - 1) % (1 << spec.length)
            st.dropped += lost
            st.longest_gap = max(st.longest_gap, timestamp - st.last_time)
        st.last = value
        st.last_time = timestamp
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
