"""Record every frame of a python-can bus into a candump ``-L`` log, without dropping any.

The receive loop (:func:`receive`) runs in the caller's thread and does nothing but
``bus.recv(timeout)`` and appending to a list; every 50 ms (or 512 frames) it hands the batch
to a :class:`LogWriter` thread, which formats the lines, counts frames per identifier, checks
the rig's rolling counters (:class:`CounterTracker`) and writes to disk, with an explicit
flush and ``os.fsync`` at least once a second. A disk that stalls on ``fsync`` therefore never
stalls the bus.

The log line format is candump's ``-L`` one, as read by ``can.CanutilsLogReader``::

    (1763700000.000123) vcan0 0C1#1122334455667788
"""

from __future__ import annotations

import logging
import os
import queue
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import IO

import can
from cantools.database.utils import start_bit

from evtribo.frames.candump import CAN_ERR_BUSERROR, CAN_ERR_FLAG, frame_field

log = logging.getLogger(__name__)

#: Seconds between two hand-overs from the receive loop to the writer thread.
HANDOFF_INTERVAL_S = 0.05
#: Frames after which the receive loop hands over a batch early.
HANDOFF_FRAMES = 512
#: Longest time, s, between two flushes (``flush`` + ``os.fsync``) of the log.
FLUSH_INTERVAL_S = 0.5


def _frame_field(msg: can.Message) -> str:
    """``ID#DATA`` of one frame, candump style (without timestamp and channel)."""
    flags = (1 if msg.bitrate_switch else 0) | (2 if msg.error_state_indicator else 0)
    return frame_field(msg.arbitration_id, msg.data, is_extended=msg.is_extended_id,
                       is_remote=msg.is_remote_frame, is_error=msg.is_error_frame,
                       is_fd=msg.is_fd, dlc=msg.dlc, fd_flags=flags)


def format_candump_line(msg: can.Message, channel: str) -> str:
    """One candump ``-L`` line (with its newline) for *msg* received on *channel*.

    Parameters
    ----------
    msg : can.Message
        The frame; its ``timestamp`` is in s (Unix epoch).
    channel : str
        Channel name written in the line (``vcan0``); no spaces.

    Returns
    -------
    str
        ``"(1763700000.000123) vcan0 0C1#1122334455667788\\n"``.
    """
    return f"({msg.timestamp:.6f}) {channel} {_frame_field(msg)}\n"


# ----------------------------------------------------------------------------------------
# Rolling counters
# ----------------------------------------------------------------------------------------
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


# ----------------------------------------------------------------------------------------
# Statistics shared with the monitor
# ----------------------------------------------------------------------------------------
@dataclass
class LogStats:
    """What the writer thread has seen so far (read by the monitor, a few times a second).

    Attributes
    ----------
    frames : int
        Frames written to the log.
    frames_by_id : dict
        Frames per identifier key (``"0C1"``, ``"18FF0001"``, ``"error"``).
    error_frames : int
        Error frames received.
    dropped : int
        Frames missing by the rig's counters.
    dropped_by_message : dict
        The same per message name.
    latest : dict
        The latest frame per :func:`frame_key` (data frames only).
    first_timestamp, last_timestamp : float or None
        Reception times, s, of the first and last frame.
    """

    frames: int = 0
    frames_by_id: dict[str, int] = field(default_factory=dict)
    error_frames: int = 0
    dropped: int = 0
    dropped_by_message: dict[str, int] = field(default_factory=dict)
    latest: dict[int, can.Message] = field(default_factory=dict)
    first_timestamp: float | None = None
    last_timestamp: float | None = None


def id_key(msg: can.Message) -> str:
    """The identifier of *msg* as the sidecar counts it: ``"0C1"``, ``"18FF0001"``, ``"error"``."""
    if msg.is_error_frame:
        return "error"
    return f"{msg.arbitration_id:08X}" if msg.is_extended_id else f"{msg.arbitration_id:03X}"


class LogWriter:
    """Writer thread: formats batches of frames into an open file, fsyncing often.

    Parameters
    ----------
    file : binary file object
        Opened for writing, unbuffered (``open(path, "wb", buffering=0)``): each batch is
        written with whole lines, so a killed process leaves no line cut in two.
    channel : str
        Channel name written in every line.
    counters : CounterTracker, optional
        The rig's rolling counters to check.
    flush_interval : float, s
        Longest time between two ``flush`` + ``os.fsync`` of the file.
    """

    def __init__(self, file: IO[bytes], channel: str, counters: CounterTracker | None = None,
                 flush_interval: float = FLUSH_INTERVAL_S) -> None:
        self.file = file
        self.channel = channel
        self.counters = counters or CounterTracker(())
        self.flush_interval = flush_interval
        self.stats = LogStats()
        self.error: BaseException | None = None
        self._queue: queue.SimpleQueue[list[can.Message] | None] = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._run, name="evtribo-log-writer",
                                        daemon=True)
        self._last_flush = time.monotonic()

    def start(self) -> LogWriter:
        """Start the thread; return self."""
        self._thread.start()
        return self

    def put(self, batch: list[can.Message]) -> None:
        """Queue a batch of frames for writing (never blocks)."""
        self._queue.put(batch)

    def close(self, timeout: float | None = None) -> None:
        """Write what is queued, flush, fsync and stop the thread (the file stays open)."""
        self._queue.put(None)
        self._thread.join(timeout)

    def _run(self) -> None:
        try:
            while True:
                try:
                    batch = self._queue.get(timeout=self.flush_interval / 2)
                except queue.Empty:
                    batch = []
                if batch is None:
                    break
                if batch and self.error is None:
                    self._write(batch)
                if self.error is None and time.monotonic() - self._last_flush >= \
                        self.flush_interval:
                    self._flush()
            if self.error is None:
                self._flush()
        except BaseException as err:  # disk full, closed file...: kept for the caller
            log.error("writing the log failed: %s", err)
            self.error = err
            # keep draining so the receive side never blocks on a dead writer
            while self._queue.get() is not None:
                pass

    def _flush(self) -> None:
        self.file.flush()
        os.fsync(self.file.fileno())
        self._last_flush = time.monotonic()

    def _write_all(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            written = self.file.write(view)
            view = view[written if written is not None else len(view):]

    def _write(self, batch: list[can.Message]) -> None:
        channel = self.channel
        stats = self.stats
        by_id = stats.frames_by_id
        latest = stats.latest
        tracker = self.counters
        counted = tracker.specs
        lines = []
        append = lines.append
        prefix_cache: dict[tuple[int, bool], str] = {}
        for msg in batch:
            if msg.is_error_frame or msg.is_remote_frame or msg.is_fd:
                append(format_candump_line(msg, channel))
                key = id_key(msg)
                if msg.is_error_frame:
                    stats.error_frames += 1
            else:
                ckey = (msg.arbitration_id, msg.is_extended_id)
                prefix = prefix_cache.get(ckey)
                if prefix is None:
                    key = id_key(msg)
                    prefix = prefix_cache[ckey] = f" {key}#"
                key = prefix[1:-1]
                append(f"({msg.timestamp:.6f}) {channel}{prefix}{msg.data.hex().upper()}\n")
                fkey = msg.arbitration_id | (0x80000000 if msg.is_extended_id else 0)
                latest[fkey] = msg
                if fkey in counted:
                    stats.dropped += tracker.update(msg.arbitration_id, msg.data,
                                                    msg.timestamp, msg.is_extended_id)
            by_id[key] = by_id.get(key, 0) + 1
        self._write_all("".join(lines).encode())
        stats.frames += len(batch)
        if stats.first_timestamp is None:
            stats.first_timestamp = batch[0].timestamp
        stats.last_timestamp = batch[-1].timestamp
        stats.dropped_by_message = tracker.dropped_by_message()


# ----------------------------------------------------------------------------------------
# The receive loop
# ----------------------------------------------------------------------------------------
@dataclass
class ReceiveResult:
    """How :func:`receive` ended.

    Attributes
    ----------
    reason : str
        ``"completed"`` (duration reached), ``"interrupted"`` (stop requested),
        ``"bus-error"`` (``recv`` raised) or ``"disk-error"`` (the writer failed).
    error : BaseException or None
        The exception behind ``bus-error`` / ``disk-error``.
    frames : int
        Frames received.
    """

    reason: str
    error: BaseException | None = None
    frames: int = 0


def receive(bus: can.BusABC, writer: LogWriter, *, duration: float | None,
            should_stop: Callable[[], bool], timeout: float = 0.1,
            until: Callable[[], bool] | None = None) -> ReceiveResult:
    """Receive frames from *bus* into *writer* until *duration* s or *should_stop*.

    Parameters
    ----------
    bus : can.BusABC
        Any python-can bus, already open.
    writer : LogWriter
        A started writer.
    duration : float or None, s
        Recording time from the call; ``None`` records until stopped.
    should_stop : callable
        Polled at least every *timeout* s; returning True ends with ``"interrupted"``.
    timeout : float, s
        ``recv`` timeout, the stop latency.
    until : callable, optional
        Polled like *should_stop* when the bus is idle; returning True ends the trial as
        ``"completed"`` (the source is done and every frame it sent was received).

    Returns
    -------
    ReceiveResult
    """
    recv = bus.recv
    monotonic = time.monotonic
    start = monotonic()
    end = float("inf") if duration is None else start + duration
    batch: list[can.Message] = []
    append = batch.append
    next_handoff = start + HANDOFF_INTERVAL_S
    frames = 0
    reason = "completed"
    error: BaseException | None = None
    now = start
    try:
        while True:
            msg = recv(min(timeout, max(end - now, 0.0)))
            now = monotonic()
            if msg is not None:
                append(msg)
                if len(batch) < HANDOFF_FRAMES and now < next_handoff:
                    if now < end:
                        continue
            if batch:
                frames += len(batch)
                writer.put(batch)
                batch = []
                append = batch.append
            next_handoff = now + HANDOFF_INTERVAL_S
            if writer.error is not None:
                reason, error = "disk-error", writer.error
                break
            if now >= end:
                break
            if should_stop():
                reason = "interrupted"
                break
            if until is not None and msg is None and until():
                break
    except (can.CanError, OSError, ValueError) as err:
        # CanOperationError, serial.SerialException (an OSError), a pty closed under the
        # driver (OSError), a garbled adapter answer (ValueError): the adapter is gone.
        log.error("the bus failed: %s: %s", type(err).__name__, err)
        reason, error = "bus-error", err
    finally:
        if batch:
            frames += len(batch)
            writer.put(batch)
    return ReceiveResult(reason=reason, error=error, frames=frames)


__all__ = [
    "CAN_ERR_BUSERROR",
    "CAN_ERR_FLAG",
    "CounterSpec",
    "CounterTracker",
    "LogStats",
    "LogWriter",
    "ReceiveResult",
    "counter_spec_from_dbc",
    "format_candump_line",
    "frame_key",
    "id_key",
    "receive",
]
