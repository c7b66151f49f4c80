"""candump's screen output, written as can-utils' candump.c and lib.c print it.

An independent formatter for the tests (the reader must not test itself): ``sprint_timestamp``
(``-ta``, ``-tz``, ``-td``, ``-tA``), the device name right-aligned to the longest one,
``-x``'s direction and flags, and ``snprintf_long_canframe`` (identifier indented once an
extended frame was seen, ``[len]``, ``[NN]`` for CAN FD, ``remote request``,
``ERRORFRAME``, ``-a``'s ASCII column).
"""

from __future__ import annotations

import datetime as dt

import can

CAN_ERR_FLAG = 0x20000000
CAN_ERR_BUSERROR = 0x80


def timestamp_text(mode: str, micros: int, first: int, last: int) -> str:
    """``sprint_timestamp``: the field for a frame at *micros* (µs), the first frame at
    *first* and the previous one at *last*."""
    if mode == "a":
        return f"({micros // 10**6:010d}.{micros % 10**6:06d}) "
    if mode == "A":
        stamp = dt.datetime.fromtimestamp(micros // 10**6, dt.UTC)
        return f"({stamp:%Y-%m-%d %H:%M:%S}.{micros % 10**6:06d}) "
    diff = micros - (last if mode == "d" else first)
    return f"({diff // 10**6:03d}.{diff % 10**6:06d}) "


def long_frame(msg: can.Message, indent: bool, ascii_view: bool = False) -> str:
    """``snprintf_long_canframe`` of a classic or FD frame (hex view)."""
    buf = [" "] * 15
    if msg.is_error_frame:
        ident, offset = f"{CAN_ERR_FLAG | (msg.arbitration_id or CAN_ERR_BUSERROR):08X}", 10
    elif msg.is_extended_id:
        ident, offset = f"{msg.arbitration_id:08X}", 10
    elif indent:
        ident, offset = "     " + f"{msg.arbitration_id:03X}", 10
    else:
        ident, offset = f"{msg.arbitration_id:03X}", 5
    buf[:len(ident)] = ident
    length = msg.dlc if msg.is_remote_frame else len(msg.data)
    if msg.is_fd:
        buf[offset:offset + 4] = f"[{length:02d}]"
    else:
        buf[offset + 1:offset + 4] = f"[{length}]"
        if msg.is_remote_frame:
            return "".join(buf[:offset + 5]) + " remote request"
    text = "".join(buf[:offset + 5])
    text += "".join(f" {b:02X}" for b in msg.data)
    if length <= 8:
        if msg.is_error_frame:
            text += "ERRORFRAME".rjust(3 * (8 - length) + 13)
        elif ascii_view:
            text += "'".rjust(3 * (8 - length) + 4)
            text += "".join(chr(b) if 0x1F < b < 0x7F else "." for b in msg.data) + "'"
    return text


def screen_log(msgs: list[can.Message], mode: str | None, *, extra: bool = False,
               ascii_view: bool = False, default_channel: str = "vcan0") -> str:
    """What ``candump -t<mode> [-x] [-a] any`` prints for *msgs* (no timestamps: None)."""
    names = [str(m.channel) if m.channel is not None else default_channel for m in msgs]
    width = max(len(n) for n in names)
    micros = [round(m.timestamp * 1e6) for m in msgs]
    lines, indent, last = [], False, micros[0] if micros else 0
    for msg, name, us in zip(msgs, names, micros, strict=True):
        indent = indent or (msg.is_extended_id and not msg.is_error_frame)
        line = " " + (timestamp_text(mode, us, micros[0], last) if mode else "")
        line += " " + name.rjust(width)
        if extra:
            line += "  RX - -"
        line += "  " + long_frame(msg, indent, ascii_view)
        lines.append(line)
        last = us
    return "\n".join(lines) + "\n"
