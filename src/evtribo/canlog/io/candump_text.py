"""candump's screen output with timestamps (``candump -ta``, ``-tz``, ``-td``, ``-tA``).

What ``candump can0 -ta > run-01.log`` writes, one frame per line::

     (1609395080.446193)  can0  0C1   [8]  11 22 33 44 55 66 77 88
     (000.001586)  can0  00000343   [8]  8C 04 8C 04 94 04 9B 04
     (2020-12-27 11:59:14.820230)  can0  1F4   [2]  01 02
     (1609395080.447000)  can0  RX - -  0C1   [8]  11 22 ...  '.."3DUfw'   (-x, -a)

The timestamp's kind is found from the file: ``-ta`` (seconds since the Unix epoch, what
``candump -L`` writes too), ``-tz`` (seconds since the first frame: the first time is 0
and the times never decrease), ``-td`` (seconds since the previous frame: the first time
is 0 and some time is smaller than the one before it; the times are summed, as exact
integers, into seconds since the first frame), ``-tA`` (local date and time; read as UTC,
since the log does not say its time zone: the times between frames are exact). A ``-td`` log
whose deltas never decrease cannot be told from a ``-tz`` log: ``candump -L`` is the format
to record.

Each ``-td`` delta is printed rounded down to the microsecond (the nanosecond with ``-N``):
their sum can run early by up to one unit per frame, which is said in a warning. Without
timestamps (plain ``candump can0``) there is no time base at all: such a log is refused
before this reader sees it (:mod:`evtribo.canlog.io.sniff`).

Remote frames (``remote request``), error frames (``ERRORFRAME``, with ``-e``'s explanation
lines after them), CAN FD frames (``[12]``), the raw DLC view (``{F}``, ``-8``), byte values
in binary (``-b``), direction and flags (``-x``), the ASCII column (``-a``), colours (``-c``)
and ``DROPCOUNT`` notices are read; CAN XL frames (``[0016] (..|..:..:........)``) are
counted, not kept.
"""

from __future__ import annotations

import datetime as dt
import logging
import os
import re
from typing import Any

import numpy as np

from evtribo.canlog.io.candump import _open_binary
from evtribo.canlog.io.candump_line import FD_SIZES, bounded_readline, notice, too_long
from evtribo.canlog.io.candump_writer import CAN_EFF_MASK, CAN_ERR_FLAG
from evtribo.canlog.io.table import CLASSIC_WIDTH, FD_WIDTH, FrameTable
from evtribo.warning.collect import emitter

log = logging.getLogger(__name__)
emit = emitter(__name__)

_ANSI = re.compile(r"\x1b\[[0-9;]*m")
_FRAME = re.compile(
    r"\s*(?:\((?P<ts>[^)]*)\)\s*)?(?P<ch>\S+)\s+(?:(?P<dir>[RT]X)\s+\S\s\S\s+)?"
    r"(?P<id>[0-9A-Fa-f]{3}|[0-9A-Fa-f]{8})\s+"
    r"(?:\[(?P<len>\d{1,2})\]|\{(?P<raw>[0-9A-Fa-f])\}|(?P<xl>\[\d{4}\]))(?P<rest>.*)")
_SECONDS = re.compile(r"\s*(?P<int>\d+)\.(?P<frac>\d{1,9})\s*")
_DATE = re.compile(r"\s*(?P<date>\d{4}-\d\d-\d\d \d\d:\d\d:\d\d)\.(?P<frac>\d{1,9})\s*")
#: Earliest ``-ta`` time, s (1973): smaller first times are ``-tz`` or ``-td``.
_ABSOLUTE_FROM = 10**8


def _time(text: str) -> tuple[int, int, bool] | str:
    """(nanoseconds, the unit it was printed in (ns), is a date), or why it is damaged."""
    m = _SECONDS.fullmatch(text)
    date = False
    if m is None:
        m = _DATE.fullmatch(text)
        if m is None:
            return f"bad timestamp {text[:30]!r}"
        try:
            stamp = dt.datetime.strptime(m["date"], "%Y-%m-%d %H:%M:%S")
        except ValueError:
            return f"bad date {m['date']!r}"
        seconds = int(stamp.replace(tzinfo=dt.UTC).timestamp())
        date = True
    else:
        seconds = int(m["int"])
    frac = m["frac"]
    unit = 10 ** (9 - len(frac))
    if seconds >= 2**33:
        return f"timestamp {text[:30]!r} is too large"
    return seconds * 10**9 + int(frac) * unit, unit, date


def _payload(m: re.Match[str]) -> tuple[bool, bool, bool, bytes] | str:
    """(remote, fd, error, payload) of a frame line, or why it is damaged."""
    rest = m["rest"].strip()
    if m["len"] is not None:
        fd = len(m["len"]) == 2
        n = int(m["len"])
        if (fd and n not in FD_SIZES) or (not fd and n > 8):
            return f"bad length [{m['len']}]"
    else:
        fd, n = False, min(int(m["raw"], 16), 8)
    if rest == "remote request":
        return (True, False, False, bytes(n)) if not fd else "a CAN FD frame cannot be remote"
    words = rest.split(None, n)
    after = words[n] if len(words) > n else ""
    if len(words) < n or (after and not after.startswith(("'", "`", "ERRORFRAME"))):
        return f"expected {n} data bytes, got {rest[:60]!r}"
    try:
        values = [int(w, 2) if len(w) == 8 else int(w, 16) for w in words[:n]]
        payload = bytes(values)
    except ValueError:
        return f"bad data bytes {rest[:60]!r}"
    if any(len(w) not in (2, 8) for w in words[:n]):
        return f"bad data bytes {rest[:60]!r}"
    error = len(m["id"]) == 8 and bool(int(m["id"], 16) & CAN_ERR_FLAG)
    return False, fd, error, payload


class _Rows:
    """What the lines held, in file order."""

    def __init__(self) -> None:
        self.ns: list[int] = []          # every timestamp read, frames and CAN XL frames
        self.unit = 1                    # coarsest unit a time was printed in, ns
        self.dates = 0
        self.frame_at: list[int] = []    # position in ns of each frame
        self.fields: list[tuple[Any, ...]] = []
        self.drops: dict[str, int] = {}
        self.xl = 0
        self.lost_times = 0              # damaged lines whose time could not be read


def _read_line(text: str, number: int, rows: _Rows, on_bad: Any) -> None:
    found = notice(text)
    if found is not None and found.kind == "dropped":
        rows.drops[found.channel] = rows.drops.get(found.channel, 0) + found.count
        return
    m = _FRAME.fullmatch(text)
    if m is None or m["ts"] is None:
        rows.lost_times += 1
        on_bad(number, "not a candump line '(time) channel id [len] data'"
               if m is None else "no timestamp")
        return
    stamp = _time(m["ts"])
    if isinstance(stamp, str):
        rows.lost_times += 1
        on_bad(number, stamp)
        return
    ns, unit, date = stamp
    rows.ns.append(ns)
    rows.unit = max(rows.unit, unit)
    rows.dates += date
    if m["xl"] is not None:
        rows.xl += 1
        return
    parsed = _payload(m)
    if isinstance(parsed, str):
        on_bad(number, parsed)
        return
    can_id = int(m["id"], 16)
    long_id = len(m["id"]) == 8
    rows.frame_at.append(len(rows.ns) - 1)
    rows.fields.append((m["ch"], can_id & CAN_EFF_MASK, long_id and not parsed[2], *parsed))


def _times(rows: _Rows, path: str | os.PathLike[str]) -> tuple[np.ndarray, str]:
    """Seconds of every timestamp read, and how they were written."""
    ns = np.asarray(rows.ns, dtype=np.int64)
    if rows.dates:
        log.info("%s: candump -tA log: local date and time read as UTC (the log does not "
                 "say its time zone); the times between frames are exact", os.fspath(path))
        return ns / 1e9, "-tA"
    if not len(ns) or ns[0] >= _ABSOLUTE_FROM * 10**9:
        return ns / 1e9, "-ta"
    if np.all(ns[1:] >= ns[:-1]):
        log.info("%s: candump -tz log: times in seconds from the first frame",
                 os.fspath(path))
        return ns / 1e9, "-tz"
    total = np.cumsum(ns)
    unit = "µs" if rows.unit >= 1000 else "ns"
    emit("candump-deltas", log=os.fspath(path), deltas=len(ns) - 1, unit=unit,
         lost=f" (and {rows.lost_times} deltas of damaged lines are missing)"
         if rows.lost_times else "")
    return total / 1e9, "-td"


def read_candump_text(path: str | os.PathLike[str], on_bad: Any) -> tuple[FrameTable, int]:
    """Read candump's screen output with timestamps (plain or gzip).

    Parameters
    ----------
    path : path-like
    on_bad : callable
        Called as ``on_bad(line_number, reason)`` for each damaged line.

    Returns
    -------
    frames : FrameTable
        In file order; ``extras["time_base"]`` says how the times were written
        (``"-ta"``, ``"-tz"``, ``"-td"`` or ``"-tA"``).
    lines : int
    """
    rows = _Rows()
    number = 0
    with _open_binary(path) as stream:
        while raw := bounded_readline(stream):
            number += 1
            if isinstance(raw, int):  # no frame's line: damaged, not held
                on_bad(number, too_long(raw))
                continue
            text = raw.decode("utf-8", "replace") if isinstance(raw, bytes) else raw
            text = _ANSI.sub("", text).rstrip("\r\n")
            if not text.strip() or text.startswith("\t"):  # blank, or an error's explanation
                continue
            _read_line(text, number, rows, on_bad)
    seconds, time_base = _times(rows, path)
    n = len(rows.fields)
    width = FD_WIDTH if any(len(f[-1]) > CLASSIC_WIDTH for f in rows.fields) else CLASSIC_WIDTH
    data = np.zeros((n, width), dtype=np.uint8)
    names: dict[str, int] = {}
    index = np.zeros(n, dtype=np.int16)
    for i, (ch, _id, _ext, remote, _fd, _err, payload) in enumerate(rows.fields):
        index[i] = names.setdefault(ch, len(names))
        if payload and not remote:
            data[i, :len(payload)] = np.frombuffer(payload, dtype=np.uint8)
    cols = list(zip(*rows.fields, strict=True)) if n else [()] * 7
    frames = FrameTable(
        timestamp=seconds[np.asarray(rows.frame_at, dtype=np.int64)],
        arbitration_id=np.asarray(cols[1], dtype=np.uint32).reshape(n),
        is_extended=np.asarray(cols[2], dtype=bool).reshape(n),
        is_remote=np.asarray(cols[3], dtype=bool).reshape(n),
        is_error=np.asarray(cols[5], dtype=bool).reshape(n),
        is_fd=np.asarray(cols[4], dtype=bool).reshape(n),
        dlc=np.asarray([len(p) for p in cols[6]], dtype=np.uint8).reshape(n),
        data=data, channel=rows.fields[0][0] if n else None, channel_index=index,
        channel_names=tuple(names), reported_drops=rows.drops, xl_frames=rows.xl)
    frames.extras["time_base"] = time_base
    return frames, number


__all__ = ["read_candump_text"]
