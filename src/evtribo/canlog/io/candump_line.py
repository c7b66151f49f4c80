"""One candump ``-L`` line at a time: the reader's slow path, and candump's notices.

Besides frames (``(1763700000.000123) vcan0 0C1#1122334455667788``) a candump log holds:

- ``DROPCOUNT: dropped 3 CAN frames on 'can0' socket (total drops 3)``: frames the kernel
  dropped before candump could read them (its socket's receive queue overflowed). They
  are no damaged line: :func:`parse_line` returns a :class:`Notice` with their number;
- CAN XL frames, ``(t) can0 45123#80:00:00000000#11223344`` (a 5-digit priority/VCID, the
  XL header, the payload): a :class:`Notice` too, so that they are counted as frames the
  rig does not describe rather than as damage;
- a classic frame's raw DLC code after its 8 bytes (``123#1122334455667788_9``,
  ``123#R8_F``), which candump writes for DLC codes 9 to 15: a valid 8-byte frame.

An over-long classic frame (``064#F001FFFFFFFFFFFFFFFF``, 10 bytes) is kept whole, as
python-can's ``CanutilsLogReader`` keeps it.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

from evtribo.canlog.io.candump_writer import CAN_EFF_MASK, CAN_ERR_FLAG
from evtribo.canlog.io.table import impossible_time

#: Payload sizes a CAN FD frame can have, bytes.
FD_SIZES = (0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64)
#: Longest payload kept (CAN FD's; an over-long classic frame up to this is kept whole).
MAX_PAYLOAD = 64
#: Longest line of a text log held, bytes: a CAN XL frame's line (2048 bytes of payload in
#: hex) is about 4.2 kB; a longer line is no frame and is damaged without being held.
MAX_LINE = 1 << 16


def too_long(length: int) -> str:
    """Why a line of *length* bytes is damaged.

    Parameters
    ----------
    length : int
        The line's length, bytes.

    Returns
    -------
    str
    """
    return (f"a line of {length:,} bytes, longer than any frame's ({MAX_LINE:,} at most): "
            "not read")


def bounded_readline(stream: Any) -> bytes | str | int:
    """The next line of a file (text or binary), or, for a line longer than
    :data:`MAX_LINE`, its length (its bytes read past, never held).

    Parameters
    ----------
    stream : file
        Open for reading, text or binary.

    Returns
    -------
    bytes, str or int
        The line with its newline (``b""``/``""`` at the end), or an over-long line's
        length in bytes (characters for a text file).
    """
    line = stream.readline(MAX_LINE + 1)
    newline = b"\n" if isinstance(line, bytes) else "\n"
    if len(line) <= MAX_LINE or line.endswith(newline):
        return line
    total = len(line)
    while True:
        more = stream.readline(1 << 20)
        total += len(more)
        if not more or more.endswith(newline):
            return total

_LINE = re.compile(
    r"\s*\(\s*(?P<ts>\d+(?:\.\d*)?)\s*\)\s+(?P<ch>\S+)\s+(?P<id>[0-9A-Fa-f]{1,8})#"
    r"(?P<data>\S*?)(?:\s+(?P<dir>[RTrt]))?\s*"
)
_XL = re.compile(r"\s*\(\s*\d+(?:\.\d*)?\s*\)\s+(?P<ch>\S+)\s+[0-9A-Fa-f]{5}#"
                 r"[0-9A-Fa-f]{2}:[0-9A-Fa-f]{2}:[0-9A-Fa-f]{8}#(?:[0-9A-Fa-f]{2})*"
                 r"(?:\s+[RTrt])?\s*")
_DROPCOUNT = re.compile(r"\s*DROPCOUNT: dropped (?P<n>\d+) CAN frames? on "
                        r"'(?P<ch>[^']*)' socket.*")
_REMOTE = re.compile(r"[Rr](?P<len>\d?)(?:_(?P<raw>[0-9A-Fa-f]))?")


@dataclass(frozen=True)
class Notice:
    """A candump line that is no CAN frame but says something about the recording.

    Attributes
    ----------
    kind : str
        ``"dropped"`` (a ``DROPCOUNT`` notice) or ``"xl"`` (a CAN XL frame).
    channel : str
        The channel (socket) it names.
    count : int
        Frames dropped (``"dropped"``), or 1.
    """

    kind: str
    channel: str
    count: int = 1


def notice(text: str) -> Notice | None:
    """The :class:`Notice` a candump line (``-L`` or screen output) holds, if any.

    Parameters
    ----------
    text : str
        One line.

    Returns
    -------
    Notice or None
    """
    m = _DROPCOUNT.fullmatch(text)
    if m is not None:
        return Notice("dropped", m["ch"], int(m["n"]))
    m = _XL.fullmatch(text)
    if m is not None:
        return Notice("xl", m["ch"])
    return None


def _payload(data: str, fd: bool) -> bytes | str:
    """A data field's bytes, or the reason it is damaged."""
    raw_dlc = None
    if not fd and len(data) == 18 and data[16] == "_":  # 8 bytes and a raw DLC code
        data, raw_dlc = data[:16], data[17]
        if raw_dlc.upper() not in "0123456789ABCDEF":
            return f"bad raw DLC code {raw_dlc!r} after the payload"
    if len(data) % 2:
        return f"odd number of hex digits in payload {data!r} (truncated?)"
    try:
        payload = bytes.fromhex(data)
    except ValueError:
        return f"bad hex in payload {data!r}"
    if len(payload) > MAX_PAYLOAD:
        return f"payload of {len(payload)} bytes is too long for {'CAN FD' if fd else 'CAN'}"
    if fd and len(payload) not in FD_SIZES:
        return f"{len(payload)} bytes is not a CAN FD payload size"
    return payload


def parse_line(text: str) -> tuple[Any, ...] | Notice | str:  # noqa: PLR0911 - one reason each
    """Parse one candump ``-L`` line (the reader's slow path).

    Parameters
    ----------
    text : str
        One line (without its newline).

    Returns
    -------
    tuple or Notice or str
        ``(timestamp, channel, can_id, extended, remote, error, fd, payload)`` for a frame
        (a remote frame's payload is zeros of its requested length); a :class:`Notice` for
        a ``DROPCOUNT`` line or a CAN XL frame; else the reason the line is damaged.
    """
    m = _LINE.fullmatch(text)
    if m is None or ":" in m["data"]:
        found = notice(text)
        if found is not None:
            return found
        if m is None:
            return "not a candump -L line '(time) channel id#data'"
    ts = float(m["ts"])
    if not math.isfinite(ts):
        return f"timestamp {m['ts'][:20]}... is too large"
    impossible = impossible_time(ts, m["ts"])
    if impossible is not None:
        return impossible
    id_text, data = m["id"], m["data"]
    can_id = int(id_text, 16)
    extended = len(id_text) > 3
    error = extended and bool(can_id & CAN_ERR_FLAG)
    fd = data.startswith("#")
    if fd:
        if len(data) < 2 or data[1].upper() not in "0123456789ABCDEF":
            return "CAN FD frame without a flags digit after '##'"
        data = data[2:]
    if data[:1] in ("R", "r") and not fd:
        r = _REMOTE.fullmatch(data)
        if r is None or (r["raw"] is not None and r["len"] != "8"):
            return f"bad remote-frame length {data[1:]!r}"
        payload: bytes | str = bytes(int(r["len"] or 0))
        if len(payload) > 8:
            return f"remote-frame length {len(payload)} > 8"
        remote = True
    else:
        payload = _payload(data, fd)
        if isinstance(payload, str):
            return payload
        remote = False
    if not extended and can_id > 0x7FF:
        return f"standard ID {id_text} > 0x7FF"
    return ts, m["ch"], can_id & CAN_EFF_MASK, extended and not error, remote, error, fd, payload


__all__ = ["FD_SIZES", "MAX_LINE", "MAX_PAYLOAD", "Notice", "bounded_readline", "notice",
           "parse_line", "too_long"]
