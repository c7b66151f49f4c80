"""slcan (Lawicel) both ways: a bulk-reading python-can bus, and an emulated adapter on a pty.

:class:`BulkSlcanBus` is python-can's :class:`can.interfaces.slcan.slcanBus` with two changes:
it reads the serial port in bulk (every byte waiting, in one call) and splits the stream into
lines itself, where python-can reads one byte per system call; and it checks every line
(:func:`check_slcan_line`) before python-can's own parser makes a frame of it, so that a
damaged line (``t0CZ8...``, ``t0C1``, bytes that are no text, ``T1``) raises one
``ValueError`` naming the line, and the next line is read as if nothing happened. The
frames of good lines are python-can's. It is registered as the python-can interface
``slcan_bulk``::

    bus = can.Bus(interface="slcan_bulk", channel="/dev/ttyACM0", bitrate=1_000_000)

:class:`SlcanPtyAdapter` is the other end: a pseudo-terminal that answers the Lawicel
commands the way a USB-CAN adapter does and writes frames as ``tIIILDD..\\r`` lines, for
``evtribo simulate --pty``.

When the adapter vanishes (the pty closes: ``evtribo simulate`` ended or was killed, or a USB
adapter was unplugged), ``recv()`` of both ``slcan`` and ``slcan_bulk`` raises
:class:`can.CanOperationError` ("Could not read from serial device", caused by the pty's
:class:`OSError`: a :class:`serial.SerialException` from a read, a bare ``EIO`` from python-can's
``in_waiting``) once every byte received before has been returned; the bus's
``shutdown()`` then raises :class:`can.CanOperationError` too (it cannot send ``C``).
"""

from __future__ import annotations

import errno
import fcntl
import logging
import os
import re
import select
import struct
import termios
import time
import tty
from collections import deque
from collections.abc import Callable
from typing import Any

import serial
from can.exceptions import error_check
from can.interfaces.slcan import slcanBus

from evtribo.acquisition.receive import drop_stuck_line, is_damaged_line
from evtribo.canlog.io.table import FrameTable

__all__ = ["DISCARD_LIMIT_S", "QUIET_S", "BulkSlcanBus", "SlcanPtyAdapter", "check_slcan_line",
           "discard_queued", "encode_slcan"]

log = logging.getLogger(__name__)

_TERMINATOR = re.compile(rb"[\r\a]")
#: A frame line: kind, identifier, length code, payload (and an adapter's 4-digit timestamp);
#: ``H`` stands for a hex digit.
_FRAME = re.compile(rb"([tdb])(H{3})(H)(H*)|([TxDB])(H{8})(H)(H*)|(r)(H{3})([0-8])(H*)"
                    rb"|(R)(H{8})([0-8])(H*)".replace(b"H", b"[0-9A-Fa-f]"))
#: A classic data frame with an 11-bit identifier: length code, payload.
_CLASSIC = re.compile(rb"t[0-7][0-9A-Fa-f]{2}([0-8])([0-9A-Fa-f]*)")
#: Hex digits of a classic payload (and the adapter's timestamp) by length code (a byte).
_CLASSIC_DIGITS = {ord(str(n)): (2 * n, 2 * n + 4) for n in range(9)}
#: Answers of the adapter to commands (ignored when receiving, as python-can does).
_ANSWER = re.compile(rb"|[zZ]|[Vv]H{4}|N[0-9A-Za-z]{4}|FH{2}".replace(b"H", b"[0-9A-Fa-f]"))
_FD_LENGTHS = (0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64)


def check_slcan_line(line: bytes) -> None:
    """Raise ``ValueError`` naming *line* unless it is a well-formed slcan line.

    *line* ends with its terminator (``\\r``, or the error bell ``\\a``). Well formed: an
    answer (empty, ``z``/``Z``, ``Vxxxx``, ``vxxxx``, ``Nxxxx``, ``Fxx``) or a frame
    (``t``/``T``/``x``/``r``/``R`` and CAN FD's ``d``/``D``/``b``/``B``) whose identifier fits
    its kind (11 or 29 bits) and whose payload has as many hex digits as its length code says,
    optionally followed by the adapter's 4-digit timestamp.

    Parameters
    ----------
    line : bytes
        One line with its terminator.
    """
    body = line[:-1] if line[-1:] in (b"\r", b"\a") else line
    m = _CLASSIC.fullmatch(body)  # the common case, quickly
    if m is not None and len(m.group(2)) in _CLASSIC_DIGITS[m.group(1)[0]]:
        return
    if _ANSWER.fullmatch(body):
        return
    m = _FRAME.fullmatch(body)
    why = "not a frame or an answer"
    if m is not None:
        kind, ident, code, payload = (g for g in m.groups() if g is not None)
        if kind in b"dDbB":
            size = _FD_LENGTHS[int(code, 16)]
        elif kind in b"rR":
            size = 0
        else:
            size = int(code, 16) if code.isdigit() and int(code) <= 8 else -1
        if int(ident, 16) > (0x7FF if len(ident) == 3 else 0x1FFFFFFF):
            why = f"identifier {ident.decode()} out of range"
        elif size < 0:
            why = f"length {code.decode()} out of range"
        elif len(payload) in (2 * size, 2 * size + 4):
            return
        else:
            why = f"payload of {len(payload)} hex digits for a length of {size} bytes"
    raise ValueError(f"damaged slcan line {line[:40]!r}: {why}")


class BulkSlcanBus(slcanBus):
    """python-can's slcan interface, reading the serial port in bulk.

    Takes the same arguments as :class:`can.interfaces.slcan.slcanBus` (``channel``,
    ``bitrate``, ``tty_baudrate``, ``sleep_after_open``, ``timeout``...). Each read takes
    every byte the port holds (at least one, waiting up to the port's ``timeout``), keeps a
    partial line for the next read, and hands complete lines (ending in ``\\r`` or the error
    bell ``\\a``) one by one to python-can's parser.
    """

    def __init__(self, channel: Any, *args: Any, **kwargs: Any) -> None:
        self._lines: deque[bytes] = deque()
        super().__init__(channel, *args, **kwargs)

    def _split(self, chunk: bytes) -> None:
        buf = self._buffer
        buf += chunk
        start = 0
        for m in _TERMINATOR.finditer(buf):
            self._lines.append(bytes(buf[start:m.end()]))
            start = m.end()
        if start:
            del buf[:start]

    def _read_line(self, timeout: float | None) -> bytes | None:
        with error_check("Could not read from serial device"):
            if self._lines:
                return self._lines.popleft()
            deadline = serial.Timeout(timeout)
            port = self.serialPortOrig
            while True:
                waiting = port.in_waiting
                chunk = port.read(waiting if waiting else 1)
                if chunk:
                    self._split(chunk)
                    if self._lines:
                        return self._lines.popleft()
                if deadline.expired():
                    return None

    def _read(self, timeout: float | None) -> str | None:
        """The next line, checked (``ValueError`` for a damaged one; it is gone then)."""
        line = self._read_line(timeout)
        if line is None:
            return None
        check_slcan_line(line)
        return line.decode("ascii")

    def flush(self) -> None:
        """Discard what was received and not yet parsed."""
        self._lines.clear()
        super().flush()


#: An adapter that sent nothing for this long after ``C`` has no more old frames, s.
QUIET_S = 0.2
#: Longest time spent reading away an adapter's old frames, s.
DISCARD_LIMIT_S = 5.0


def discard_queued(bus: slcanBus, limit: float = DISCARD_LIMIT_S) -> int:
    """Read away the frames an slcan adapter holds (sent before a trial); return how many.

    Frames sent by the adapter before now wait in the serial port's buffers, and in the
    adapter's own (after a recording was killed, an adapter goes on sending into the port):
    read now, they would be stamped as if just received. The channel is closed (``C``: the
    adapter sends no more frames), what still comes is read until the port stays quiet for
    :data:`QUIET_S` (at most *limit* s), and the channel is opened again (``O``, or ``L``
    listen-only as the bus was opened).

    Parameters
    ----------
    bus : can.interfaces.slcan.slcanBus
        python-can's slcan bus or :class:`BulkSlcanBus`, open.
    limit : float, s

    Returns
    -------
    int
        Frames read away (damaged lines are skipped, not counted).
    """
    bus.close()
    count = 0
    now = time.monotonic()
    deadline, quiet_until = now + limit, now + QUIET_S
    while (now := time.monotonic()) < min(deadline, quiet_until):
        try:
            msg = bus.recv(QUIET_S / 4)
        except Exception as err:
            if not is_damaged_line(err):  # the adapter is gone: the trial will say so
                log.debug("reading the frames queued before the trial: %s", err)
                return count
            log.debug("a damaged line queued before the trial, discarded: %s", err)
            drop_stuck_line(bus)
            msg, quiet_until = None, now + QUIET_S
        if msg is not None:
            count += 1
            quiet_until = time.monotonic() + QUIET_S
    if now >= deadline:
        log.warning("the adapter was still sending old frames after %g s; the trial starts "
                    "anyway", limit)
    bus.open()
    return count


def encode_slcan(table: FrameTable, start: int = 0, stop: int | None = None) -> bytes:
    """Frames ``start:stop`` of *table* as slcan lines (``t``/``T``/``r``/``R``), bytes.

    Parameters
    ----------
    table : FrameTable
    start, stop : int
        The rows to encode (``stop`` None: to the end).

    Returns
    -------
    bytes
        The slcan lines, each ending in ``\\r``.
    """
    stop = len(table) if stop is None else stop
    blob = table.data[start:stop, :8].tobytes().hex().upper().encode("ascii")
    ids = table.arbitration_id[start:stop].tolist()
    ext = table.is_extended[start:stop].tolist()
    remote = table.is_remote[start:stop].tolist()
    dlc = table.dlc[start:stop].tolist()
    parts = []
    for i, aid in enumerate(ids):
        n = min(dlc[i], 8)
        if remote[i]:
            parts.append(b"R%08X%d\r" % (aid, n) if ext[i] else b"r%03X%d\r" % (aid, n))
        else:
            head = b"T%08X%d" % (aid, n) if ext[i] else b"t%03X%d" % (aid, n)
            parts.append(head + blob[16 * i: 16 * i + 2 * n] + b"\r")
    return b"".join(parts)


def _valid_transmit(cmd: bytes) -> bool:
    """Whether *cmd* is a well-formed ``t``/``T``/``r``/``R`` command."""
    width = 8 if cmd[:1] in (b"T", b"R") else 3
    m = re.fullmatch(rb"[tTrR]([0-9A-Fa-f]{%d})([0-8])([0-9A-Fa-f]*)" % width, cmd)
    if m is None:
        return False
    if cmd[:1] in (b"r", b"R"):
        return m.group(3) == b""
    return len(m.group(3)) == 2 * int(m.group(2))


class SlcanPtyAdapter:
    """A pseudo-terminal that behaves as an slcan (Lawicel) USB-CAN adapter.

    A client opens :attr:`path` as a serial port (python-can's ``slcan`` interface does) and
    talks Lawicel: ``O``/``L`` open (normal / listen-only), ``C`` close, ``S0``-``S8``
    bitrate and ``sXXYY`` bit timing (channel closed only), ``V`` and ``v`` versions, ``N``
    serial number, ``F`` status flags (bit 3: frames lost to a full buffer since the last
    ``F``), ``Z0``, ``M``/``m``/``W``/``X``/``Q``/``U`` acknowledged. Transmit commands
    ``t``/``T``/``r``/``R`` are acknowledged with ``z``/``Z`` while open and counted in
    :attr:`transmitted`, not echoed; a data frame is handed to :attr:`on_transmit` (the
    simulated amplifier obeys its command this way). Every command is answered ``\\r`` on
    success and ``\\a`` on error, as the adapters do.

    Frames are written with :meth:`send_frames` while the channel is open. If the client
    falls behind and more than *max_pending* bytes wait, new frames are dropped (counted in
    :attr:`dropped`), as an adapter's full buffer does. Closing the adapter (or the process
    exiting) closes the pty: the client's next read fails.

    Parameters
    ----------
    max_pending : int
        Bytes that may wait for the client before frames are dropped.
    """

    VERSION = b"1013"
    SW_VERSION = b"0107"
    SERIAL_NUMBER = b"EV01"

    def __init__(self, max_pending: int = 256 * 1024) -> None:
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # no echo, no line discipline until the client sets its own
        os.set_blocking(self._master, False)
        self.path: str = os.ttyname(self._slave)
        self.max_pending = max_pending
        self.is_open = False
        self.listen_only = False
        self.bitrate_command = b"S6"
        self.transmitted = 0
        #: Called with (identifier, extended, data) of each frame the client transmits.
        self.on_transmit: Callable[[int, bool, bytes], object] | None = None
        #: Called each time a client opens the channel (a new recording starts).
        self.on_open: Callable[[], object] | None = None
        self.opened = 0
        self.dropped = 0
        self._overrun = False
        self._commands = bytearray()
        self._pending = bytearray()
        self._closed = False

    def fileno(self) -> int:
        """The pty's master file descriptor."""
        return self._master

    # -- commands ------------------------------------------------------------------------
    def _answer(self, cmd: bytes) -> bytes:  # noqa: PLR0911 - one answer per command
        ok, bell = b"\r", b"\a"
        c = cmd[:1]
        if not cmd:
            return ok
        if c in (b"O", b"L"):
            if self.is_open:
                return bell
            self.is_open, self.listen_only = True, c == b"L"
            self.opened += 1
            log.info("slcan: channel opened (%s)", cmd.decode("ascii", "replace"))
            if self.on_open is not None:
                self.on_open()
            return ok
        if c == b"C":
            if self.is_open:
                log.info("slcan: channel closed")
            self.is_open = False
            return ok
        if c == b"S":
            if self.is_open or re.fullmatch(rb"S[0-8]", cmd) is None:
                return bell
            self.bitrate_command = cmd
            return ok
        if c == b"s":
            if self.is_open or re.fullmatch(rb"s[0-9A-Fa-f]{4}", cmd) is None:
                return bell
            self.bitrate_command = cmd
            return ok
        if cmd == b"V":
            return b"V" + self.VERSION + ok
        if cmd == b"v":
            return b"v" + self.SW_VERSION + ok
        if cmd == b"N":
            return b"N" + self.SERIAL_NUMBER + ok
        if cmd == b"F":
            if not self.is_open:
                return bell
            flags, self._overrun = (0x08 if self._overrun else 0), False
            return b"F%02X" % flags + ok
        if c in (b"t", b"T", b"r", b"R"):
            if not self.is_open or self.listen_only or not _valid_transmit(cmd):
                return bell
            self.transmitted += 1
            if c in (b"t", b"T") and self.on_transmit is not None:
                width = 8 if c == b"T" else 3
                ident = int(cmd[1:1 + width], 16)
                data = bytes.fromhex(cmd[2 + width:].decode("ascii"))
                self.on_transmit(ident, c == b"T", data)
            return (b"Z" if c in (b"T", b"R") else b"z") + ok
        if cmd in (b"Z0",) or c in (b"M", b"m", b"W", b"X", b"Q", b"U"):
            return ok
        return bell

    def _read_commands(self) -> None:
        try:
            data = os.read(self._master, 4096)
        except BlockingIOError:
            return
        except OSError as err:  # EIO: no client has the port open (not with our slave fd)
            if err.errno != errno.EIO:
                raise
            return
        self._commands += data.replace(b"\n", b"")
        while (end := self._commands.find(b"\r")) >= 0:
            cmd = bytes(self._commands[:end])
            del self._commands[: end + 1]
            answer = self._answer(cmd)
            log.debug("slcan: %r -> %r", cmd, answer)
            self._pending += answer

    def _flush(self) -> None:
        if not self._pending:
            return
        try:
            written = os.write(self._master, self._pending)
        except BlockingIOError:
            return
        del self._pending[:written]

    def poll(self, timeout: float = 0.0) -> None:
        """Answer waiting commands and write pending bytes; wait at most *timeout* s."""
        wlist = [self._master] if self._pending else []
        r, _, _ = select.select([self._master], wlist, [], max(timeout, 0.0))
        if r:
            self._read_commands()
        if self._pending:
            self._flush()

    # -- frames --------------------------------------------------------------------------
    def send_frames(self, table: FrameTable, start: int = 0, stop: int | None = None) -> int:
        """Queue frames ``start:stop`` of *table* for the client; return how many were taken.

        Nothing is taken while the channel is closed; frames are dropped (and counted) while
        more than ``max_pending`` bytes wait.
        """
        stop = len(table) if stop is None else stop
        if not self.is_open or stop <= start:
            return 0
        if len(self._pending) > self.max_pending:
            self.dropped += stop - start
            self._overrun = True
            return 0
        self._pending += encode_slcan(table, start, stop)
        self._flush()
        return stop - start

    def unread(self) -> int:
        """Bytes written to the pty that the client has not read yet, plus those pending."""
        buf = fcntl.ioctl(self._slave, termios.FIONREAD, b"\0\0\0\0")
        return struct.unpack("i", buf)[0] + len(self._pending)

    def drain(self, timeout: float = 2.0, *, stalled: float | None = None) -> bool:
        """Wait until the client has read everything (at most *timeout* s; with *stalled*,
        also no longer than *stalled* s without the client reading a byte); True if it has.

        A client on a busy machine reads late and in bursts: a long *timeout* with a
        *stalled* limit waits for it as long as it keeps reading, and not for one that has
        stopped (a recording that ended)."""
        # FIONREAD misses bytes still in the kernel's flip buffer on their way to the client's
        # queue: only trust an empty queue that stays empty for a while.
        deadline = time.monotonic() + timeout
        empty_since = None
        left, progress = self.unread(), time.monotonic()
        while (now := time.monotonic()) < deadline:
            unread = self.unread()
            if unread < left:
                left, progress = unread, now
            elif stalled is not None and now - progress >= stalled:
                return unread == 0
            if unread == 0:
                empty_since = now if empty_since is None else empty_since
                if now - empty_since >= 0.1:
                    return True
            else:
                empty_since = None
            self.poll(0.01)
        return self.unread() == 0

    def close(self) -> None:
        """Close the pty: the adapter vanishes for the client."""
        if self._closed:
            return
        self._closed = True
        for fd in (self._master, self._slave):
            try:
                os.close(fd)
            except OSError:  # pragma: no cover - already gone
                pass

    def __enter__(self) -> SlcanPtyAdapter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
