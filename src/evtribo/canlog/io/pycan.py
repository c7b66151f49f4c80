"""Logs read through python-can's readers (``.asc``, ``.blf``, ``.trc``, ``.csv``, ``.db``...).

python-can parses these one message at a time; the messages are gathered into a
:class:`~evtribo.canlog.io.table.FrameTable`. A record python-can's reader cannot parse is
reported to ``on_bad`` with its line number (text formats); reading then resumes on the next
line for ``.asc``, ``.trc`` and ``.csv``. A binary file (``.blf``) cannot be resynchronised:
reading stops at the damaged object, and what was read before it is kept.

``.db`` (python-can's SQLite log) is opened read-only (python-can's reader would open it for
writing); a file that is no such database is an error. ``.mf4`` needs the optional
``asammdf`` (``pip install 'evtribo[mf4]'``); without it, reading one says so.
"""

from __future__ import annotations

import gzip
import importlib.util
import math
import os
import re
import sqlite3
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import IO, Any

import can
import numpy as np
from can.io.generic import BinaryIOMessageReader
from can.io.player import MESSAGE_READERS
from can.io.sqlite import SqliteReader

from evtribo.canlog.io.candump_line import bounded_readline, too_long
from evtribo.canlog.io.table import (
    CLASSIC_WIDTH,
    FD_WIDTH,
    NO_CHANNEL,
    FrameTable,
    impossible_time,
)
from evtribo.errors import LogFormatError
from evtribo.store.files import PARTIAL_SUFFIX

__all__ = ["MF4_EXTRA", "frames_from_messages", "read_with_python_can"]

#: The extra that installs what python-can's MF4 reader needs.
MF4_EXTRA = "pip install 'evtribo[mf4]'"

BadLineHandler = Callable[[int | None, str], None]


#: Lines kept between two frames (a longer run of comments or events is not checked).
_MAX_RECENT = 10_000

#: An ``.asc`` line python-can passes over in silence although it starts like a frame
#: (time, channel, identifier): a frame line cut short or damaged. Events, comments and
#: status lines (``CAN 1 Status:...``, ``1 Statistic:``...) do not match.
_ASC_FRAME_LIKE = re.compile(r"\s*\d+(?:\.\d*)?(?:\s+(?:\d+|CANFD)(?:\s+[0-9A-Fa-f]+x?"
                             r"(?:\s.*)?)?)?\s*")


class _CountingFile:
    """A text file that counts the lines handed out (to name a damaged line)."""

    def __init__(self, raw: IO[str], on_bad: BadLineHandler) -> None:
        self._raw = raw
        self._on_bad = on_bad
        self.line = 0
        self._pending: list[str] = []
        #: Lines handed out since the last frame came back: (line number, text).
        self.recent: list[tuple[int, str]] = []

    def push(self, text: str) -> None:
        """Hand *text* out again before the rest of the file (not counted)."""
        self._pending.append(text)
        self.line -= 1

    def __iter__(self) -> _CountingFile:
        return self

    def __next__(self) -> str:
        text = self.readline()
        if not text:
            raise StopIteration
        return text

    def readline(self, *_args: Any) -> str:
        text = self._pending.pop() if self._pending else bounded_readline(self._raw)
        while isinstance(text, int):  # no frame's line: damaged, never held
            self.line += 1
            self._on_bad(self.line, too_long(text))
            text = bounded_readline(self._raw)
        assert isinstance(text, str)
        if text:
            self.line += 1
            if len(self.recent) < _MAX_RECENT:
                self.recent.append((self.line, text))
        return text

    def __getattr__(self, name: str) -> Any:
        return getattr(self._raw, name)


def frames_from_messages(messages: Iterable[can.Message], channel: str | None = None
                         ) -> FrameTable:
    """Gather python-can messages into a :class:`FrameTable`.

    Parameters
    ----------
    messages : iterable of can.Message
        The frames; ``dlc`` of a remote frame is its requested length (at most 8),
        otherwise the payload's length.
    channel : str, optional
        Channel name of the frames whose message names none (default: none). Each frame
        keeps its message's channel (python-can's ``msg.channel``, as text).

    Returns
    -------
    FrameTable
    """
    ts, ids, ext, rem, err, fd, dlc, payloads = [], [], [], [], [], [], [], []
    names: dict[str, int] = {}
    codes: list[int] = []
    for msg in messages:
        ts.append(msg.timestamp)
        ids.append(msg.arbitration_id)
        ext.append(msg.is_extended_id and not msg.is_error_frame)
        rem.append(msg.is_remote_frame)
        err.append(msg.is_error_frame)
        fd.append(msg.is_fd)
        data = bytes(msg.data or b"")
        # a remote frame asks for at most 8 bytes (DLC codes 9-15 of classic CAN mean 8;
        # CAN FD has no remote frames)
        dlc.append(min(msg.dlc, CLASSIC_WIDTH) if msg.is_remote_frame else len(data))
        payloads.append(data)
        name = channel if msg.channel is None else str(msg.channel)
        codes.append(NO_CHANNEL if name is None else names.setdefault(name, len(names)))
    n = len(ts)
    width = FD_WIDTH if any(len(p) > CLASSIC_WIDTH for p in payloads) else CLASSIC_WIDTH
    data_arr = np.zeros((n, width), dtype=np.uint8)
    for i, p in enumerate(payloads):
        if p:
            data_arr[i, :len(p)] = np.frombuffer(p, dtype=np.uint8)
    return FrameTable(
        timestamp=np.asarray(ts, dtype=np.float64).reshape(n),
        arbitration_id=np.asarray(ids, dtype=np.uint32).reshape(n),
        is_extended=np.asarray(ext, dtype=bool).reshape(n),
        is_remote=np.asarray(rem, dtype=bool).reshape(n),
        is_error=np.asarray(err, dtype=bool).reshape(n),
        is_fd=np.asarray(fd, dtype=bool).reshape(n),
        dlc=np.asarray(dlc, dtype=np.uint8).reshape(n),
        data=data_arr,
        channel=next((k for k, v in names.items() if codes and v == codes[0]), None),
        channel_index=np.asarray(codes, dtype=np.int16).reshape(n),
        channel_names=tuple(names),
    )


def _passed_over(counter: _CountingFile | None, suffix: str, on_bad: BadLineHandler,
                 keep_last: bool) -> None:
    """Report the ``.asc`` lines python-can skipped in silence that look like frames."""
    if counter is None:
        return
    lines = counter.recent[:-1] if keep_last else counter.recent
    if suffix == ".asc":
        for number, text in lines:
            if text.strip() and _ASC_FRAME_LIKE.fullmatch(text.rstrip("\r\n")):
                on_bad(number, f"not a complete frame record: {text.strip()[:60]!r}")
    counter.recent.clear()


def _checked_trc_lines(reader: Any, counter: _CountingFile | None,
                       on_bad: BadLineHandler) -> None:
    """Make python-can's TRC reader report lines it cannot split into columns (it logs them
    and goes on, uncounted)."""
    def parse_line(line: str) -> can.Message | None:
        try:  # _parse_cols is chosen by the header's version: look it up at each call
            return reader._parse_cols(tuple(line.split(maxsplit=reader._num_columns)))
        except IndexError:
            on_bad(None if counter is None else counter.line,
                   f"not a complete frame record: {line.strip()[:60]!r}")
            return None

    reader._parse_line = parse_line


def _resumable(reader: Any, counter: _CountingFile | None, suffix: str,
               on_bad: BadLineHandler) -> Iterator[can.Message]:
    if suffix == ".trc":
        _checked_trc_lines(reader, counter, on_bad)
    it = iter(reader)
    while True:
        try:
            msg = next(it)
        except StopIteration:
            _passed_over(counter, suffix, on_bad, keep_last=False)
            return
        except Exception as err:  # python-can raises ValueError, IndexError, struct.error...
            if counter is None:
                on_bad(None, f"cannot be read past this point ({type(err).__name__}: {err})")
                return
            _passed_over(counter, suffix, on_bad, keep_last=True)
            on_bad(counter.line, f"{type(err).__name__}: {err}")
            # start a fresh generator on the rest of the file, header already parsed
            reader._extract_header = lambda: None
            if suffix == ".csv":
                counter.push("timestamp,arbitration_id,extended,remote,error,dlc,data\n")
            it = iter(reader)
            continue
        _passed_over(counter, suffix, on_bad, keep_last=True)
        problem = _implausible(msg)
        if problem is not None:
            on_bad(None if counter is None else counter.line, problem)
            continue
        yield msg


def _implausible(msg: can.Message) -> str | None:
    """Why a message python-can parsed cannot be a CAN frame, or None if it can."""
    try:
        ts = float(msg.timestamp)
    except (TypeError, ValueError):
        return f"timestamp {msg.timestamp!r} is not a number"
    if not math.isfinite(ts):
        return f"timestamp {msg.timestamp!r} is not a finite number"
    impossible = impossible_time(ts)
    if impossible is not None:
        return impossible
    if not 0 <= msg.arbitration_id <= 0x1FFFFFFF:
        return f"identifier {msg.arbitration_id:#x} is out of range"
    size = msg.dlc if msg.is_remote_frame else len(msg.data or b"")
    if not 0 <= size <= FD_WIDTH:
        return f"payload length {size} is out of range 0..{FD_WIDTH}"
    return None


def read_with_python_can(path: str | os.PathLike[str], on_bad: BadLineHandler
                         ) -> tuple[FrameTable, int]:
    """Read *path* with the python-can reader its suffix names (``.gz`` decompressed).

    Parameters
    ----------
    path : path-like
        The log.
    on_bad : callable
        Called with each line the reader cannot parse: its number (None where not known)
        and what is wrong with it.

    Returns
    -------
    frames : FrameTable
    lines : int
        Lines read (text formats), else 0.
    """
    name = os.fspath(path).lower().removesuffix(PARTIAL_SUFFIX)  # an unfinished acquisition's name
    gz = name.endswith(".gz")
    suffix = os.path.splitext(name[:-3] if gz else name)[1]
    if suffix == ".db":
        return frames_from_messages(_sqlite_messages(path, on_bad)), 0
    if suffix == ".mf4" and importlib.util.find_spec("asammdf") is None:
        raise LogFormatError(f"reading .mf4 logs needs the optional package asammdf: "
                             f"{MF4_EXTRA}", path=path)
    reader_cls = MESSAGE_READERS[suffix]
    binary = issubclass(reader_cls, BinaryIOMessageReader)
    counter: _CountingFile | None = None
    handle: Any = None
    try:
        if binary:
            handle = gzip.open(path, "rb") if gz else open(path, "rb")
            reader = reader_cls(handle)
        else:
            handle = gzip.open(path, "rt") if gz else open(path, encoding="utf-8",
                                                           errors="replace")
            counter = _CountingFile(handle, on_bad)
            reader = reader_cls(counter)
    except OSError:
        if handle is not None:
            handle.close()
        raise
    except Exception as err:  # python-can's readers check their header with struct, asserts...
        if handle is not None:
            handle.close()
        raise ValueError(f"not a {suffix} file python-can can read "
                         f"({type(err).__name__}: {err})") from err
    try:
        frames = frames_from_messages(_resumable(reader, counter, suffix, on_bad))
    finally:
        reader.stop()
    return frames, (counter.line if counter is not None else 0)


def _sqlite_rows(conn: sqlite3.Connection, on_bad: BadLineHandler) -> Iterator[can.Message]:
    rows = conn.execute("SELECT * FROM messages")
    number = 0
    while True:
        try:
            row = rows.fetchone()
        except sqlite3.DatabaseError as err:  # damaged pages: keep what came before
            on_bad(None, f"cannot be read past row {number} ({type(err).__name__}: {err})")
            return
        if row is None:
            return
        number += 1
        try:
            msg = SqliteReader._assemble_message(row)
        except (TypeError, ValueError) as err:
            on_bad(None, f"row {number}: {type(err).__name__}: {err}")
            continue
        problem = _implausible(msg)
        if problem is not None:
            on_bad(None, f"row {number}: {problem}")
            continue
        yield msg


def _sqlite_messages(path: str | os.PathLike[str], on_bad: BadLineHandler
                     ) -> Iterator[can.Message]:
    """The messages of python-can's SQLite log, opened read-only (``mode=ro``).

    Raises ValueError when the file is no SQLite database or lacks python-can's
    ``messages`` table; a row python-can cannot assemble is reported to *on_bad*.
    """
    if os.path.getsize(path) == 0:
        raise ValueError("an empty file, not an SQLite database")
    uri = Path(path).resolve().as_uri() + "?mode=ro"
    try:
        conn = sqlite3.connect(uri, uri=True)
    except sqlite3.Error as err:
        raise ValueError(f"not an SQLite database ({err})") from err
    try:
        try:
            tables = [r[0] for r in conn.execute(
                "SELECT name FROM sqlite_master WHERE type='table'")]
        except sqlite3.DatabaseError as err:
            raise ValueError(f"not an SQLite database ({err})") from err
        if "messages" not in tables:
            raise ValueError("an SQLite database without python-can's 'messages' table "
                             f"(tables: {', '.join(tables) or 'none'})")
        yield from _sqlite_rows(conn, on_bad)
    finally:
        conn.close()
