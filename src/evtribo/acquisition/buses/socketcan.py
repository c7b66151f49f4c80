"""SocketCAN as a saturated bus needs it: python-can's ``socketcan`` bus, with a receive queue
sized for the bus and the kernel's count of the frames that queue dropped.

python-can's :class:`can.interfaces.socketcan.SocketcanBus` opens a ``CAN_RAW`` socket with
the kernel's receive timestamps (``SO_TIMESTAMPNS``: a frame read late keeps the time it
arrived) and error frames (``CAN_RAW_ERR_FILTER`` = ``CAN_ERR_MASK``). Two things it leaves
to the system matter on a busy bus:

- **the receive queue**: ``net.core.rmem_default`` (212,992 bytes on Debian) holds a few
  hundred frames; a receiver busy for a tenth of a second on a saturated bus (a laptop
  drawing the live view) loses the rest. :class:`SocketcanBus` asks for
  :data:`DEFAULT_RECEIVE_BUFFER` bytes with ``SO_RCVBUFFORCE`` (root or ``CAP_NET_ADMIN``:
  beyond ``net.core.rmem_max``), else ``SO_RCVBUF`` (up to ``net.core.rmem_max``), and says
  what the kernel granted (:class:`ReceiveQueue`);
- **what the queue dropped**: with ``SO_RXQ_OVFL`` every frame comes with the kernel's count
  of the frames this socket dropped so far (what ``candump -d`` shows);
  :meth:`SocketcanBus.queue_dropped` is the latest count (``SO_MEMINFO`` gives it also
  after the last frame).

The kernel's timestamps are kept in whole microseconds, as ``candump -L`` writes them (a
log of the same frames recorded by both has the same times). It also takes CAN FD frames
by default (``CAN_RAW_FD_FRAMES``; classic ones still come as
classic frames), so that ``evtribo acquire`` records an FD rig without an option. The frames
are python-can's :class:`can.Message`, read as python-can reads them.

``evtribo acquire --interface socketcan`` opens this bus (:func:`evtribo.acquisition.buses.bus.
open_bus`); ``--bus-option receive_buffer=BYTES`` asks for another queue (0: the system's
default), ``--bus-option fd=False`` refuses FD frames.
"""

from __future__ import annotations

import errno
import logging
import select
import socket
import struct
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import can
from can.interfaces.socketcan import SocketcanBus as _PythonCanSocketcanBus
from can.interfaces.socketcan.constants import (
    CAN_EFF_FLAG,
    CAN_ERR_FLAG,
    CAN_RTR_FLAG,
    SO_TIMESTAMPNS,
)
from can.interfaces.socketcan.socketcan import dissect_can_frame

__all__ = ["DEFAULT_RECEIVE_BUFFER", "KernelFrame", "ReceiveQueue", "SocketcanBus",
           "size_receive_queue"]

log = logging.getLogger(__name__)

#: Bytes of receive queue asked for (the kernel doubles it for its bookkeeping): 64 MiB
#: granted hold ~90,000 frames, ten seconds of a saturated 1 Mbit/s bus.
DEFAULT_RECEIVE_BUFFER = 32 * 1024 * 1024
#: Linux socket options python's :mod:`socket` does not name.
SO_RCVBUFFORCE = 33
SO_RXQ_OVFL = 40
SO_MEMINFO = 55
#: Index of the socket's drop count in ``SO_MEMINFO``'s array (``SK_MEMINFO_DROPS``).
_MEMINFO_DROPS = 8
_CANFD_MTU = 72
_TIMESPEC = struct.Struct("@ll")
_COUNT = struct.Struct("@I")
_ANCILLARY = socket.CMSG_SPACE(_TIMESPEC.size) + socket.CMSG_SPACE(_COUNT.size)
_RMEM_MAX = Path("/proc/sys/net/core/rmem_max")
#: The largest receive queue a socket option can ask for (a C int), bytes.
_INT_MAX = 2**31 - 1


@dataclass(frozen=True)
class ReceiveQueue:
    """A socket's receive queue, as asked for and as granted.

    Attributes
    ----------
    requested_bytes : int or None
        What was asked for (None: the system's default was kept).
    bytes : int
        What the kernel granted (``SO_RCVBUF`` read back: twice the request, the kernel's
        bookkeeping included).
    forced : bool
        Granted through ``SO_RCVBUFFORCE``, beyond ``net.core.rmem_max``.
    rmem_max_bytes : int or None
        ``net.core.rmem_max``, the limit without ``SO_RCVBUFFORCE``.
    """

    requested_bytes: int | None
    bytes: int
    forced: bool
    rmem_max_bytes: int | None

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return asdict(self)


def _rmem_max() -> int | None:
    try:
        return int(_RMEM_MAX.read_text().strip())
    except (OSError, ValueError):
        return None


def size_receive_queue(sock: socket.socket, requested: int | None) -> ReceiveQueue:
    """Ask for a receive queue of *requested* bytes on *sock*.

    ``SO_RCVBUFFORCE`` first (root or ``CAP_NET_ADMIN``), else ``SO_RCVBUF``, which the
    kernel caps at ``net.core.rmem_max``; a queue smaller than asked for is logged as a
    warning naming the setting to raise.

    Parameters
    ----------
    sock : socket.socket
    requested : int or None, bytes
        None or 0 keeps the system's default.

    Returns
    -------
    ReceiveQueue
    """
    limit = _rmem_max()
    if not requested:
        return ReceiveQueue(None, sock.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF),
                            False, limit)
    forced = True
    try:
        sock.setsockopt(socket.SOL_SOCKET, SO_RCVBUFFORCE, requested)
    except PermissionError:
        forced = False
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, requested)
    granted = sock.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF)
    if granted < requested:
        log.warning("the receive queue holds %d bytes, not the %d asked for: without root, "
                    "the kernel allows at most net.core.rmem_max (%s bytes; raise it with "
                    "sudo sysctl -w net.core.rmem_max=%d)", granted, requested, limit,
                    requested)
    return ReceiveQueue(requested, granted, forced, limit)


class KernelFrame(can.Message):
    """A frame as the kernel delivered it: python-can's message, and the CAN FD flags byte
    whole (``CANFD_FDF`` too, which Linux 6 sets on every FD frame it receives: ``candump
    -L`` writes it, ``ID##4...``)."""

    __slots__ = ("fd_flags",)

    def __init__(self, *, fd_flags: int = 0, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.fd_flags = fd_flags


class SocketcanBus(_PythonCanSocketcanBus):
    """python-can's SocketCAN bus with a sized receive queue and the kernel's drop count.

    Parameters
    ----------
    channel : str
        The interface (``can0``, ``vcan0``).
    receive_buffer : int, bytes
        Receive queue to ask for (:data:`DEFAULT_RECEIVE_BUFFER`; 0 keeps the system's).
    fd : bool
        Take CAN FD frames too (default True).
    **kwargs
        python-can's (``receive_own_messages``, ``can_filters``, ``ignore_rx_error_frames``...).

    Attributes
    ----------
    receive_queue : ReceiveQueue
    """

    def __init__(self, channel: str = "", *, receive_buffer: int = DEFAULT_RECEIVE_BUFFER,
                 fd: bool = True, **kwargs: Any) -> None:
        if not isinstance(receive_buffer, int) or isinstance(receive_buffer, bool) \
                or receive_buffer < 0:
            raise ValueError(f"receive_buffer must be a number of bytes >= 0, got "
                             f"{receive_buffer!r}")
        if receive_buffer > _INT_MAX:  # setsockopt takes a C int
            raise ValueError(f"receive_buffer must be at most {_INT_MAX} bytes (the kernel "
                             f"takes a C int), got {receive_buffer!r}")
        super().__init__(channel, fd=fd, **kwargs)
        try:
            self.receive_queue = size_receive_queue(self.socket, receive_buffer)
            self.socket.setsockopt(socket.SOL_SOCKET, SO_RXQ_OVFL, 1)
        except BaseException:
            self.socket.close()
            raise
        self._dropped = 0

    def queue_dropped(self) -> int:
        """Frames the kernel dropped from this socket's full receive queue so far.

        Returns
        -------
        int
            The latest of ``SO_RXQ_OVFL``'s counts (carried by the frames received) and
            ``SO_MEMINFO``'s (which also counts drops after the last frame read).
        """
        try:
            info = self.socket.getsockopt(socket.SOL_SOCKET, SO_MEMINFO, 4 * 9)
            self._dropped = max(self._dropped, struct.unpack_from(
                "@9I", info)[_MEMINFO_DROPS])
        except OSError as err:  # a kernel without SO_MEMINFO, or a closed socket
            if err.errno not in (errno.ENOPROTOOPT, errno.EBADF, errno.EINVAL):
                raise
        return self._dropped

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        try:
            ready, _, _ = select.select([self.socket], [], [], timeout)
        except OSError as err:  # the interface went down
            raise can.CanOperationError(f"Failed to receive: {err.strerror}",
                                        err.errno) from err
        if not ready:
            return None, self._is_filtered
        return self._capture(), self._is_filtered

    def _capture(self) -> KernelFrame:
        """One frame from the socket, as python-can's ``capture_message`` makes it, and the
        kernel's drop count it carries."""
        try:
            frame, ancillary, flags, address = self.socket.recvmsg(_CANFD_MTU, _ANCILLARY)
        except OSError as err:
            raise can.CanOperationError(f"Error receiving: {err.strerror}", err.errno) from err
        timestamp = None
        for level, kind, data in ancillary:
            if level != socket.SOL_SOCKET:
                continue
            if kind == SO_RXQ_OVFL:
                self._dropped = _COUNT.unpack_from(data)[0]
            elif kind == SO_TIMESTAMPNS:  # in whole µs, as candump -L writes it
                seconds, nanoseconds = _TIMESPEC.unpack_from(data)
                timestamp = seconds + nanoseconds // 1000 * 1e-6
        can_id, dlc, fd_flags, data = dissect_can_frame(frame)
        extended = bool(can_id & CAN_EFF_FLAG)
        channel = address[0] if not self.channel and isinstance(address, tuple) \
            else self.channel
        is_fd = len(frame) == _CANFD_MTU
        return KernelFrame(
            fd_flags=fd_flags if is_fd else 0, timestamp=timestamp or 0.0, channel=channel,
            arbitration_id=can_id & (0x1FFFFFFF if extended else 0x7FF),
            is_extended_id=extended, is_remote_frame=bool(can_id & CAN_RTR_FLAG),
            is_error_frame=bool(can_id & CAN_ERR_FLAG), is_fd=is_fd,
            is_rx=not flags & socket.MSG_DONTROUTE, bitrate_switch=bool(fd_flags & 1),
            error_state_indicator=bool(fd_flags & 2), dlc=dlc, data=data)
