"""Rolling frame counters: which frames of the rig's load cells were lost on the bus.

A load cell that numbers its frames (``FzCell.FzCounter``) tells the logger how many of its
frames never arrived. The recorder counts them as the analysis counts them in the log it
writes: it keeps each counted message's frames (their times as the log holds them, to the
microsecond, their counters and payloads) and hands them to
:func:`evtribo.canlog.counters.streams.count_cells`, the analysis's own count: the counter's
law (its period, step and start, learnt from the frames or declared in the rig file, or that
it does not count), duplicates, late frames, a counter that stood still, restarts judged by
the frames' timing, the logger's clock steps, whole counter periods lost in a pause, never
more than the time holds. When the log closes (:meth:`CounterTracker.settle`) all of a
trial's frames are counted at once: the sidecar's ``dropped_frames`` is the count
``evtribo analyze`` gives for the same log.

While the trial is recorded, the count is kept up to date at a few microseconds a frame,
the frames counted again only where one may change the count
(:class:`~evtribo.acquisition.counter_stream.CounterStream` says when). A counter whose
period its frames cannot tell yet (it wrapped below its width's top, and the timing does not
say whether it starts again there) is *not known yet* (:meth:`CounterTracker.states`, said on
the live display), not a count of every wrap's values as lost.

The counter is pulled out of the payloads by
:class:`~evtribo.canlog.signal_codec.SignalCodec`, as the decoder pulls every signal;
frames are keyed by :func:`evtribo.canlog.io.ids.frame_key`.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from cantools.database.can import Database

from evtribo.acquisition.counter_stream import CounterStream
from evtribo.canlog.counters.streams import CounterSignal, count_cells
from evtribo.canlog.io.ids import frame_key
from evtribo.canlog.signal_codec import SignalCodec
from evtribo.warning.catalogue import kind

log = logging.getLogger(__name__)

__all__ = ["CounterSpec", "CounterTracker", "counter_spec_from_dbc", "frame_key"]

FloatArray = npt.NDArray[np.float64]

#: Width every payload is padded to before the counter is read (a classic frame's).
_PAYLOAD_BYTES = 8
#: What the live display says of a counter whose period its frames cannot tell yet (it
#: wrapped short of its width's top, and the timing does not say yet whether it starts
#: again there; a period declared in the rig file is known at once).
NOT_KNOWN = "period not yet learnt, its lost frames not known yet"
#: What it says of a counter that does not count.
NOT_COUNTING = "does not count, lost frames from the timestamps"


@dataclass(frozen=True)
class CounterSpec:
    """Where a message's rolling frame counter sits in its payload, and what it counts.

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
    period : int or None
        The counter's period the rig file declares (frames); None: learnt from its frames.
    period_key : str
        The rig file's key that declares it (``normal_force_counter_period``).
    """

    message: str
    arbitration_id: int
    codec: SignalCodec
    is_extended: bool = False
    period: int | None = None
    period_key: str = "normal_force_counter_period"

    @property
    def key(self) -> int:
        """:func:`~evtribo.canlog.io.ids.frame_key` of the message."""
        return frame_key(self.arbitration_id, self.is_extended)

    @property
    def length(self) -> int:
        """Width in bits (the counter counts below ``2**length``)."""
        return self.codec.length

    @property
    def signal(self) -> CounterSignal:
        """The counter as the analysis reads its law."""
        return CounterSignal(self.length, self.period, f"{self.message}.{self.codec.name}",
                             self.period_key)

    def rows(self, payloads: Sequence[bytes | bytearray]) -> npt.NDArray[np.uint8]:
        """*payloads* as rows of bytes, padded with zeros to 8 bytes at least (a short
        payload's missing bytes read as 0)."""
        width = max([_PAYLOAD_BYTES, *(len(p) for p in payloads)])
        return np.frombuffer(b"".join(bytes(p).ljust(width, b"\0") for p in payloads),
                             dtype=np.uint8).reshape(len(payloads), width)

    def values(self, payloads: Sequence[bytes | bytearray]) -> npt.NDArray[np.int64]:
        """The raw counter values in *payloads* (no scaling: counts); bytes a short payload
        lacks read as 0."""
        return self.codec.raw(self.rows(payloads)).astype(np.int64)

    def extract(self, data: bytes | bytearray) -> int:
        """The raw counter value in one payload *data*."""
        return int(self.values([data])[0])


def counter_spec_from_dbc(database: Database, message: str, signal: str, *,
                          period: int | None = None,
                          period_key: str = "normal_force_counter_period") -> CounterSpec:
    """A :class:`CounterSpec` for ``message.signal`` of a cantools *database*.

    Parameters
    ----------
    database : cantools.database.can.Database
    message, signal : str
        Names in *database*.
    period : int, optional
        The counter's period the rig file declares (frames).
    period_key : str
        The rig file's key that declares it.

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
                       is_extended=bool(msg.is_extended_frame), period=period,
                       period_key=period_key)



def _as_logged(timestamps: Sequence[float]) -> FloatArray:
    """The timestamps as the candump log holds them (to the microsecond), s."""
    return np.array([float(f"{x:.6f}") for x in timestamps], dtype=np.float64)


class CounterTracker:
    """Count frames missing from each message's rolling counter, as the analysis of the log
    counts them (see the module's docstring): a frame received twice is a duplicate
    (:attr:`duplicates`), not 255 frames lost; two frames received swapped are no loss; a
    counter that stood still is no loss; a counter that restarts (jumps: to 0, a low value
    or any other) counts the frames lost by the timing, and its time is kept
    (:meth:`restarts_by_message`); a counter of a shorter period than its width's counts
    as it counts; one that does not count is said (:meth:`states`), and the frames lost are
    the timestamps' count.

    Parameters
    ----------
    specs : iterable of CounterSpec
        The counted messages.
    """

    def __init__(self, specs: Iterable[CounterSpec]) -> None:
        #: Specs by :func:`frame_key` (identifier and kind).
        self.specs = {s.key: s for s in specs}
        self._state = {i: CounterStream(s.signal, s.message) for i, s in self.specs.items()}
        self._rows = 0  # frames numbered here when the caller gives no rows

    def update(self, arbitration_id: int, data: bytes | bytearray, timestamp: float,
               is_extended: bool = False) -> int:
        """Account for one frame (*timestamp* in s); return the change of :attr:`dropped`."""
        return self.update_many(frame_key(arbitration_id, is_extended), [data], [timestamp])

    def update_many(self, key: int, payloads: Sequence[bytes | bytearray],
                    timestamps: Sequence[float], rows: Sequence[int] | None = None) -> int:
        """Account for frames of one message, in the order received.

        Parameters
        ----------
        key : int
            The message's :func:`frame_key`.
        payloads : sequence of bytes
        timestamps : sequence of float, s
        rows : sequence of int, optional
            The frames' places in the log (default: numbered here, in the order given).

        Returns
        -------
        int
            The change of :attr:`dropped` (0 for a message without a counter; negative
            where frames counted lost arrived late, or a step counted at face value was a
            jump).
        """
        st = self._state.get(key)
        if st is None or not payloads:
            return 0
        before = self.dropped
        if rows is None:
            at = np.arange(self._rows, self._rows + len(payloads), dtype=np.int64)
        else:
            at = np.asarray(rows, dtype=np.int64)
        self._rows = max(self._rows, int(at[-1]) + 1)
        spec = self.specs[key]
        matrix = spec.rows(payloads)
        st.add(at, _as_logged(timestamps), spec.codec.raw(matrix).astype(np.int64), matrix)
        self._count(final=False)
        return self.dropped - before

    def _count(self, *, final: bool) -> None:
        """Count what the frames since the last count call for (all of them: *final*)."""
        streams = [st for st in self._state.values() if st.n]
        if not streams:
            return
        due = [st.due() for st in streams]
        if final or "whole" in due:
            self._count_whole(streams, final=final)
            return
        for st, what in zip(streams, due, strict=True):
            if what == "tail":
                st.counted_tail()

    def _count_whole(self, streams: list[CounterStream], *, final: bool) -> None:
        """Count every frame of every message at once, as the analysis counts a log (the
        logger's clock steps seen by one taken out of all)."""
        upto = [st.upto(final=final) for st in streams]
        kept = [st.frames() for st in streams]
        rows = np.concatenate([k[0][:m] for k, m in zip(kept, upto, strict=True)])
        order = np.argsort(rows, kind="stable")
        place = np.empty(order.size, dtype=np.int64)
        place[order] = np.arange(order.size)
        t = np.concatenate([k[1][:m] for k, m in zip(kept, upto, strict=True)])[order]
        edges = np.cumsum([0, *upto])
        cells = [st.cell(0, m, place[a:b], None)
                 for st, m, a, b in zip(streams, upto, edges[:-1], edges[1:], strict=True)]
        _, counts, _ = count_cells(t, cells)
        for st, found, m in zip(streams, counts, upto, strict=True):
            st.counted_whole(found, m, final=final)

    def settle(self) -> int:
        """Count every frame of the trial at once (it has ended), as the analysis counts
        the log: the sidecar's count.

        Returns
        -------
        int
            The change of the count, frames (negative where a step counted at face value
            was the counter jumping).
        """
        before = self.dropped
        self._count(final=True)
        for st in self._state.values():
            for t in st.restarts():
                log.warning("the counter of %s jumped (it restarted) at %.6f: the frames "
                            "lost there counted by the timing", st.message, t)
        return self.dropped - before

    def longest_gap_by_message(self) -> dict[str, float]:
        """Longest time, s, between two consecutive frames of each counted message."""
        return {st.message: round(st.longest_gap, 6) for st in self._state.values()}

    def dropped_by_message(self) -> dict[str, int]:
        """Frames lost so far, per message name (those :meth:`states` says are not known
        yet included)."""
        return {st.message: st.dropped for st in self._state.values()}

    def restarts_by_message(self, since: float | None = None) -> dict[str, list[float]]:
        """When the counted messages' counters restarted (jumped) (those that did):
        timestamps, s, or seconds from *since*."""
        out = {st.message: [round(t - (since or 0.0), 6) for t in st.restarts()]
               for st in self._state.values()}
        return {name: times for name, times in out.items() if times}

    def states(self) -> dict[str, str]:
        """What the counters of the messages whose count is not simply theirs say, by
        message name: :data:`NOT_KNOWN` (its period not learnt yet: its count is left out
        of :attr:`dropped`) or :data:`NOT_COUNTING`."""
        out = {}
        for st in self._state.values():
            law = st.whole.law
            if not st.known():
                out[st.message] = NOT_KNOWN
            elif law is not None and not law.counts:
                out[st.message] = NOT_COUNTING
        return out

    def notes_by_message(self) -> dict[str, str]:
        """What each counter does, in words, where that is worth saying (its period learnt
        from its frames, not told, or that it does not count), by message name."""
        return {st.message: kind(law.note.kind).text(law.note.mapping)
                for st in self._state.values()
                if (law := st.whole.law) is not None and law.note is not None}

    @property
    def dropped(self) -> int:
        """Frames lost so far, all messages together (those whose count is not known yet
        left out)."""
        return sum(st.dropped for st in self._state.values() if st.known())

    @property
    def duplicates(self) -> int:
        """Frames received twice so far, all messages together."""
        return sum(st.duplicates for st in self._state.values())
