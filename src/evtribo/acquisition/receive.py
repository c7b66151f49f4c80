"""The receive loop: every frame of a python-can bus, handed in batches to a log writer.

:func:`receive` runs in the caller's thread and does nothing but ``bus.recv(timeout)`` and
appending to a list; every 50 ms (or 512 frames) it hands the batch to a
:class:`~evtribo.acquisition.logger.LogWriter` thread, which formats and writes it. A line
the adapter's driver cannot parse is counted and skipped (:func:`is_damaged_line`).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import can

from evtribo.acquisition.logger import LogStats, LogWriter
from evtribo.canlog.io.ids import frame_key

log = logging.getLogger(__name__)

#: Seconds between two hand-overs from the receive loop to the writer thread.
HANDOFF_INTERVAL_S = 0.05
#: Frames after which the receive loop hands over a batch early.
HANDOFF_FRAMES = 512
#: Seconds between two readings of the receiving side's count of dropped frames.
DROPS_INTERVAL_S = 0.5
#: Damaged lines kept (as text) for the sidecar's ``bus_exceptions``.
DAMAGED_EXAMPLES = 10
#: Damaged lines in a row, without a frame between them, after which the adapter is taken
#: for dead (a wrong serial speed, a driver that fails on every read).
MAX_DAMAGED_IN_A_ROW = 1000


@dataclass
class ReceiveResult:
    """How :func:`receive` ended.

    Attributes
    ----------
    reason : str
        ``"completed"`` (duration reached), ``"interrupted"`` (stop requested),
        ``"bus-error"`` (``recv`` raised: the adapter is gone), ``"disk-error"`` (the writer
        failed) or ``"no-rig-data"`` (none of the expected frames within the time allowed).
    error : BaseException or None
        The exception behind ``bus-error`` / ``disk-error``.
    frames : int
        Frames received.
    damaged_lines : int
        Lines the driver could not parse (skipped; the recording went on).
    damaged_examples : list of str
        The first :data:`DAMAGED_EXAMPLES` of them, as ``"ValueError: ..."``.
    stale : int or None
        Frames queued before the trial's start, discarded (None: the bus cannot tell them).
    """

    reason: str
    error: BaseException | None = None
    frames: int = 0
    damaged_lines: int = 0
    damaged_examples: list[str] = field(default_factory=list)
    stale: int | None = 0


def is_damaged_line(err: BaseException) -> bool:
    """Whether *err*, raised by a bus's ``recv``, is one line the driver could not parse
    (the adapter still works) rather than a failed adapter.

    A parser raises ``ValueError`` or ``IndexError`` on a malformed line (python-can's
    ``slcan``: ``int('0CZ', 16)``, ``string[9]`` of a line cut short; evtribo's
    ``slcan_bulk``: ``ValueError``); bytes that are no text surface as a
    :class:`can.CanOperationError` caused by a ``UnicodeDecodeError``. An adapter that is
    gone raises :class:`can.CanOperationError` caused by an ``OSError``
    (``serial.SerialException``), or an ``OSError``.

    Parameters
    ----------
    err : BaseException
        What ``recv`` raised.

    Returns
    -------
    bool
        True for a damaged line, False for a failed adapter.
    """
    if isinstance(err, (ValueError, IndexError, KeyError)):
        return True
    return isinstance(err, can.CanError) and isinstance(err.__cause__, UnicodeError)


def drop_stuck_line(bus: can.BusABC) -> None:
    """Forget a complete line the driver failed to decode and still holds.

    python-can's ``slcan`` driver decodes its line buffer before clearing it: a line that is
    no text would fail again with every later byte. Its buffer then ends with the line's
    terminator; a buffer that holds part of a line (``slcan_bulk``'s) never does.

    Parameters
    ----------
    bus : can.BusABC
        The bus whose ``recv`` raised a damaged line (:func:`is_damaged_line`).
    """
    buffer = getattr(bus, "_buffer", None)
    if isinstance(buffer, bytearray) and buffer.endswith((b"\r", b"\a")):
        buffer.clear()


class _Damaged:
    """Counts damaged lines; says when there were too many in a row."""

    def __init__(self, stats: LogStats) -> None:
        self.stats = stats
        self.count = 0
        self.in_a_row = 0
        self.examples: list[str] = []

    def add(self, err: BaseException, bus: can.BusABC) -> None:
        self.count += 1
        self.in_a_row += 1
        self.stats.damaged_lines += 1
        text = f"{type(err).__name__}: {err}"
        if err.__cause__ is not None:
            text += f" ({type(err.__cause__).__name__}: {err.__cause__})"
        if len(self.examples) < DAMAGED_EXAMPLES:
            self.examples.append(text)
        if self.count <= DAMAGED_EXAMPLES:
            log.warning("damaged line from the bus, skipped: %s", text)
        drop_stuck_line(bus)
        if self.in_a_row >= MAX_DAMAGED_IN_A_ROW:
            raise can.CanOperationError(
                f"{self.in_a_row} damaged lines in a row and no frame: the adapter sends "
                "nothing readable (a wrong serial speed?)") from err


def receive(bus: can.BusABC, writer: LogWriter, *, duration: float | None,
            should_stop: Callable[[], bool], timeout: float = 0.1,
            until: Callable[[], bool] | None = None,
            expect: frozenset[int] | None = None,
            expect_within: float | None = None, not_before: float | None = None,
            dropped: Callable[[], int] | None = None) -> ReceiveResult:
    """Receive frames from *bus* into *writer* until *duration* s or *should_stop*.

    A line the driver cannot parse (:func:`is_damaged_line`) is counted and skipped; any
    other exception from ``recv`` ends the trial as ``"bus-error"``.

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
    expect : frozenset of int, optional
        :func:`frame_key` of the frames the rig must send (its load cells).
    expect_within : float, s, optional
        With *expect*: when none of those frames arrived within this time, or by the end
        of a shorter trial, the trial ends as ``"no-rig-data"``.
    not_before : float, optional, s since the epoch
        The trial's start, for a bus that stamps each frame with this machine's clock as it
        receives it (SocketCAN's kernel timestamps): a frame stamped earlier was queued
        before the trial, and is discarded and counted (:attr:`ReceiveResult.stale`). When
        the trial ends by its duration or a stop, the frames received until then and still
        queued (a receiver that fell behind) are read into the log.
    dropped : callable, optional
        The receiving side's count of the frames it dropped (a full receive queue), read
        into ``writer.stats.queue_dropped`` at most every :data:`DROPS_INTERVAL_S` s and at
        the end.

    Returns
    -------
    ReceiveResult
    """
    loop = _Loop(bus, writer, duration,
                 expect=expect if expect_within is not None else None,
                 expect_within=expect_within, dropped=dropped)
    stop: tuple[str, BaseException | None] | None = None
    try:
        if not_before is not None:
            loop.skip_stale(not_before, timeout, should_stop)
        stop = loop.run(should_stop, until, timeout)
        if not_before is not None and stop[0] in ("completed", "interrupted"):
            loop.read_queued(time.time())
    except Exception as err:
        # CanOperationError, serial.SerialException (an OSError), a pty closed under the
        # driver (OSError), or anything else a driver raises: the adapter is gone.
        log.error("the bus failed: %s: %s", type(err).__name__, err)
        stop = ("bus-error", err)
    finally:
        loop.hand_over(final=True)
    assert stop is not None
    reason, error = stop
    return ReceiveResult(reason=reason, error=error, frames=loop.frames,
                         damaged_lines=loop.damaged.count,
                         damaged_examples=loop.damaged.examples, stale=loop.stale)


class _Loop:
    """The state of :func:`receive`: the batch on its way to the writer, and the counts."""

    def __init__(self, bus: can.BusABC, writer: LogWriter, duration: float | None, *,
                 expect: frozenset[int] | None, expect_within: float | None,
                 dropped: Callable[[], int] | None) -> None:
        self.bus, self.writer, self.dropped = bus, writer, dropped
        self.recv = bus.recv
        self.start = time.monotonic()
        self.end = float("inf") if duration is None else self.start + duration
        self.expect = expect
        self.deadline = self.start + (expect_within or 0.0)
        self.batch: list[can.Message] = []
        self.frames = 0
        self.stale = 0
        self.damaged = _Damaged(writer.stats)
        self.next_drops = self.start

    def skip_stale(self, not_before: float, timeout: float,
                   should_stop: Callable[[], bool]) -> None:
        """Discard the frames stamped before *not_before*, until the first one after it
        (kept), an idle bus or a stop."""
        while True:
            msg = _recv(self.bus, self.recv, min(timeout, max(self.end - time.monotonic(),
                                                              0.0)), self.damaged)
            if msg is None:
                return
            if msg.timestamp >= not_before:
                self.batch.append(msg)
                return
            self.stale += 1
            if self.stale % HANDOFF_FRAMES == 0 and should_stop():
                return

    def run(self, should_stop: Callable[[], bool], until: Callable[[], bool] | None,
            timeout: float) -> tuple[str, BaseException | None]:
        """Receive until the trial ends; say why it ended."""
        recv, monotonic, batch = self.recv, time.monotonic, self.batch
        next_handoff = self.start + HANDOFF_INTERVAL_S
        now, end = self.start, self.end
        while True:
            msg = _recv(self.bus, recv, min(timeout, max(end - now, 0.0)), self.damaged)
            now = monotonic()
            if msg is not None:
                batch.append(msg)
                self.damaged.in_a_row = 0
                if len(batch) < HANDOFF_FRAMES and now < next_handoff and now < end:
                    continue
            self.hand_over()
            batch = self.batch  # a new list: the writer has the last one
            next_handoff = now + HANDOFF_INTERVAL_S
            stop = _stop_reason(self.writer, now=now, end=end, idle=msg is None,
                                should_stop=should_stop, until=until,
                                no_rig_data=self.expect is not None and now >= self.deadline)
            if stop is not None:
                if stop[0] == "completed" and self.expect is not None:
                    return "no-rig-data", None  # never "completed" without the rig's frames
                return stop

    def read_queued(self, until: float) -> None:
        """Read the frames stamped up to *until* that are still queued."""
        while (msg := _recv(self.bus, self.recv, 0.0, self.damaged)) is not None:
            if msg.timestamp > until:
                return
            self.batch.append(msg)
            if len(self.batch) >= HANDOFF_FRAMES:
                self.hand_over()

    def hand_over(self, final: bool = False) -> None:
        """Hand the batch to the writer; note whether the rig was heard from; read the
        receiving side's drop count when it is time."""
        batch = self.batch
        if batch:
            if self.expect is not None and _any_expected(batch, self.expect):
                self.expect = None
            self.frames += len(batch)
            self.writer.put(batch)
            self.batch = batch = []
        if self.dropped is not None and (final or time.monotonic() >= self.next_drops):
            self.next_drops = time.monotonic() + DROPS_INTERVAL_S
            try:
                self.writer.stats.queue_dropped = self.dropped()
            except Exception as err:  # a count the driver cannot give ends nothing
                log.warning("cannot read the frames the receiving side dropped: %s", err)
                self.dropped = None


def _recv(bus: can.BusABC, recv: Callable[[float], can.Message | None], wait: float,
          damaged: _Damaged) -> can.Message | None:
    """One frame from the bus within *wait* s, or None: the bus was idle, or the driver
    could not parse a line (counted in *damaged* and skipped)."""
    try:
        return recv(wait)
    except Exception as err:
        if not is_damaged_line(err):
            raise
        damaged.add(err, bus)
        return None


def _stop_reason(writer: LogWriter, *, now: float, end: float, idle: bool,
                 should_stop: Callable[[], bool], until: Callable[[], bool] | None,
                 no_rig_data: bool) -> tuple[str, BaseException | None] | None:
    """Why the trial ends now (checked at each hand-over to the writer), or None to go on:
    the writer failed, the duration elapsed, a stop was asked for, the rig stayed silent,
    or the source (*until*, polled when the bus is *idle*) is done."""
    if writer.error is not None:
        return "disk-error", writer.error
    if now >= end:
        return "completed", None
    if should_stop():
        return "interrupted", None
    if no_rig_data:
        return "no-rig-data", None
    if until is not None and idle and until():
        return "completed", None
    return None


def _any_expected(batch: list[can.Message], keys: frozenset[int]) -> bool:
    return any(frame_key(m.arbitration_id, m.is_extended_id) in keys
               for m in batch if not m.is_error_frame)


__all__ = ["DAMAGED_EXAMPLES", "DROPS_INTERVAL_S", "HANDOFF_FRAMES", "HANDOFF_INTERVAL_S",
           "MAX_DAMAGED_IN_A_ROW", "ReceiveResult", "drop_stuck_line", "is_damaged_line",
           "receive"]
