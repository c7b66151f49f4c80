"""Record every frame of a python-can bus into a candump ``-L`` log, without dropping any.

The receive loop (:func:`evtribo.acquisition.receive.receive`, which imports this module)
runs in the caller's thread and does nothing but ``bus.recv(timeout)`` and appending to a
list; every 50 ms (or 512 frames) it hands the batch to a :class:`LogWriter` thread, which
formats the lines, counts frames per identifier, checks the rig's rolling counters
(:class:`CounterTracker`) and writes to disk, with an explicit flush and ``os.fsync`` at
least once a second. A disk that stalls on ``fsync`` therefore never stalls the bus.

The log line format is candump's ``-L`` one, as read by ``can.CanutilsLogReader``::

    (1763700000.000123) vcan0 0C1#1122334455667788
"""

from __future__ import annotations

import copy
import logging
import os
import queue
import threading
import time
from dataclasses import dataclass, field
from typing import IO

import can

from evtribo.acquisition.buses.errorframes import ErrorTally
from evtribo.acquisition.counters import CounterSpec, CounterTracker, counter_spec_from_dbc
from evtribo.canlog.io.candump import CAN_ERR_BUSERROR, CAN_ERR_FLAG, frame_field
from evtribo.canlog.io.ids import frame_key, id_text

log = logging.getLogger(__name__)

#: Longest time, s, between two flushes (``flush`` + ``os.fsync``) of the log.
FLUSH_INTERVAL_S = 0.5


def _frame_field(msg: can.Message) -> str:
    """``ID#DATA`` of one frame, candump style (without timestamp and channel); an FD
    frame's flags as the kernel gave them when it did (SocketCAN), else python-can's."""
    flags = getattr(msg, "fd_flags", None)
    if flags is None:
        flags = (1 if msg.bitrate_switch else 0) | (2 if msg.error_state_indicator else 0)
    return frame_field(msg.arbitration_id, bytes(msg.data), is_extended=msg.is_extended_id,
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
        Frames missing by the rig's counters, as the analysis counts them (those of a
        counter whose period is not known yet left out: *counters* says so).
    dropped_by_message : dict
        The same per message name.
    counters : dict
        What the counters of the messages whose count is not simply theirs say, by message
        name (:meth:`CounterTracker.states`: a period not known yet, a counter that does
        not count).
    duplicates : int
        Frames of the counted messages received twice (the counter and payload of a frame
        just before), not counted as lost.
    latest : dict
        The latest frame per :func:`frame_key` (data frames only).
    first_timestamp, last_timestamp : float or None
        Reception times, s, of the first and last frame.
    damaged_lines : int
        Lines the bus's driver could not parse (counted by
        :func:`~evtribo.acquisition.receive.receive`, skipped).
    errors : ErrorTally
        The error frames by kind, and the controller's state they report.
    queue_dropped : int or None
        Frames the receiving side dropped (SocketCAN: the kernel's count of the frames the
        socket's full receive queue dropped), read by :func:`~evtribo.acquisition.receive.receive`;
        None when the bus does not count them.
    """

    frames: int = 0
    frames_by_id: dict[str, int] = field(default_factory=dict)
    error_frames: int = 0
    dropped: int = 0
    dropped_by_message: dict[str, int] = field(default_factory=dict)
    counters: dict[str, str] = field(default_factory=dict)
    duplicates: int = 0
    latest: dict[int, can.Message] = field(default_factory=dict)
    first_timestamp: float | None = None
    last_timestamp: float | None = None
    damaged_lines: int = 0
    errors: ErrorTally = field(default_factory=ErrorTally)
    queue_dropped: int | None = None


def id_key(msg: can.Message) -> str:
    """The identifier of *msg* as the sidecar counts it.

    Parameters
    ----------
    msg : can.Message

    Returns
    -------
    str
        ``"0C1"``, ``"18FF0001"`` (:func:`evtribo.canlog.io.ids.id_text`) or ``"error"``.
    """
    if msg.is_error_frame:
        return "error"
    return id_text(msg.arbitration_id, msg.is_extended_id)


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

    Attributes
    ----------
    error : BaseException or None
        Why writing stopped (a full disk...). The file then ends with the last whole line
        that was written: a line cut by the error is truncated away, and :attr:`stats`
        count the frames of the whole lines only.
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
        self._size = file.tell()  # bytes of whole lines in the file
        self._pending = 0  # bytes of the batch being written that reached the file

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
        ended = False  # the end of the queue taken
        try:
            while True:
                try:
                    batch = self._queue.get(timeout=self.flush_interval / 2)
                except queue.Empty:
                    batch = []
                if batch is None:
                    ended = True
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
            while not ended and self._queue.get() is not None:
                pass
        self._settle()

    def _settle(self) -> None:
        """The trial has ended: every frame of the rig's load cells counted at once, as the
        analysis counts the log (:meth:`CounterTracker.settle`)."""
        try:
            self.counters.settle()
        except Exception as err:  # the log is whole: a count that fails does not lose it
            log.error("counting the load cells' lost frames failed (%s): the count is the "
                      "one made while recording; evtribo analyze counts them from the log",
                      err)
        self._counted()

    def _counted(self) -> None:
        """The counters' counts into :attr:`stats`."""
        stats, tracker = self.stats, self.counters
        stats.dropped = tracker.dropped
        stats.dropped_by_message = tracker.dropped_by_message()
        stats.duplicates = tracker.duplicates
        stats.counters = tracker.states()

    def _flush(self) -> None:
        self.file.flush()
        os.fsync(self.file.fileno())
        self._last_flush = time.monotonic()

    def _write_all(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            written = self.file.write(view)
            written = len(view) if written is None else written
            self._pending += written
            view = view[written:]

    def _keep_whole_lines(self, data: bytes, batch: list[can.Message],
                          before: tuple[dict[str, int], int, ErrorTally]) -> None:
        """After a write of *batch* (as *data*) failed part way: truncate the file to its
        last whole line, and count only the frames whose lines are whole."""
        keep = data.rfind(b"\n", 0, self._pending) + 1
        try:
            os.ftruncate(self.file.fileno(), self._size + keep)
            self.file.seek(self._size + keep)
        except OSError as err:
            log.error("cannot drop the line cut by the failed write: %s", err)
            return
        self._size += keep
        stats = self.stats
        stats.frames_by_id, stats.error_frames, stats.errors = before
        kept = batch[:data.count(b"\n", 0, keep)]
        for msg in kept:
            key = id_key(msg)
            stats.frames_by_id[key] = stats.frames_by_id.get(key, 0) + 1
            stats.error_frames += msg.is_error_frame
            if msg.is_error_frame:
                stats.errors.add(msg.arbitration_id, msg.data)
        if kept:
            stats.frames += len(kept)
            stats.first_timestamp = stats.first_timestamp or kept[0].timestamp
            stats.last_timestamp = kept[-1].timestamp

    def _write(self, batch: list[can.Message]) -> None:
        stats = self.stats
        before = (dict(stats.frames_by_id), stats.error_frames, copy.deepcopy(stats.errors))
        lines = self._lines(batch)
        data = "".join(lines).encode()
        self._pending = 0
        try:
            self._write_all(data)
        except BaseException:
            self._keep_whole_lines(data, batch, before)
            raise
        self._size += len(data)
        stats.frames += len(batch)
        if stats.first_timestamp is None:
            stats.first_timestamp = batch[0].timestamp
        stats.last_timestamp = batch[-1].timestamp
        self._counted()

    def _lines(self, batch: list[can.Message]) -> list[str]:
        """The log lines of *batch*; count its frames per identifier, keep each message's
        latest frame, and check the rolling counters of the counted messages."""
        channel = self.channel
        stats = self.stats
        by_id = stats.frames_by_id
        latest = stats.latest
        tracker = self.counters
        counted: dict[int, tuple[list[bytearray], list[float], list[int]]] = {
            key: ([], [], []) for key in tracker.specs}
        lines: list[str] = []
        append = lines.append
        prefix_cache: dict[int, str] = {}
        for row, msg in enumerate(batch, stats.frames):
            if msg.is_error_frame or msg.is_remote_frame or msg.is_fd:
                append(format_candump_line(msg, channel))
                key = id_key(msg)
                if msg.is_error_frame:
                    stats.error_frames += 1
                    stats.errors.add(msg.arbitration_id, msg.data)
            else:
                fkey = frame_key(msg.arbitration_id, msg.is_extended_id)
                prefix = prefix_cache.get(fkey)
                if prefix is None:
                    prefix = prefix_cache[fkey] = f" {id_key(msg)}#"
                key = prefix[1:-1]
                append(f"({msg.timestamp:.6f}) {channel}{prefix}{msg.data.hex().upper()}\n")
                latest[fkey] = msg
                if fkey in counted:
                    counted[fkey][0].append(msg.data)
                    counted[fkey][1].append(msg.timestamp)
                    counted[fkey][2].append(row)
            by_id[key] = by_id.get(key, 0) + 1
        for fkey, (payloads, times, rows) in counted.items():
            tracker.update_many(fkey, payloads, times, rows)
        return lines


__all__ = ["CAN_ERR_BUSERROR", "CAN_ERR_FLAG", "CounterSpec", "CounterTracker", "LogStats",
           "LogWriter", "counter_spec_from_dbc", "format_candump_line", "frame_key", "id_key"]
