"""One entry point for every log format: :func:`read_frames` picks the reader by suffix.

The registry maps a suffix to a reader function ``reader(path, on_bad) -> (FrameTable,
lines)``, the way python-can's ``MESSAGE_READERS`` maps suffixes to reader classes. A
``.gz`` name is read by the reader of the suffix before it (``run-01.log.gz``). A lab's own
format is a reader in its own module, found, as python-can finds its readers
(``can.io.message_reader``), through the entry point group ``evtribo.log_readers``: the
entry point's name is the suffix (``.mylog``), the object it names the reader; a suffix
evtribo reads already stays evtribo's.

The content is looked at first (:func:`~evtribo.canlog.io.sniff.sniff`): a file that is
another format than its suffix says (Vector ASC text named ``.log``, a SavvyCAN CSV named
``.csv``, a BLF named ``.log``) is refused, naming what it looks like and how to convert it,
instead of being read as zero frames and a damaged line per line. A ``.log`` holding
candump's screen output with timestamps (``candump -ta``/``-tz``/``-td``/``-tA``) is read by
:mod:`evtribo.canlog.io.candump_text`; without timestamps it is refused (no time base). A text
log in which no line is a frame is refused too.

Damaged records: a reader reports each to ``on_bad(line, reason)``. :func:`read_frames`
logs a warning naming the file and line (the first :data:`MAX_WARNINGS` of them, then a
summary), counts them in :class:`ReadReport`, and with ``strict=True`` raises
:class:`~evtribo.errors.LogFormatError` at the first one instead.
"""

from __future__ import annotations

import difflib
import logging
import os
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

from can.io.player import MESSAGE_READERS

from evtribo.canlog.io.candump import iter_candump, read_candump
from evtribo.canlog.io.candump_text import read_candump_text
from evtribo.canlog.io.pycan import read_with_python_can
from evtribo.canlog.io.sniff import Sniffed, sniff
from evtribo.canlog.io.table import FrameTable
from evtribo.errors import LogFormatError
from evtribo.store.files import PARTIAL_SUFFIX, check_regular_file, sha256_file
from evtribo.util.plugins import Registry
from evtribo.warning.collect import emitter

__all__ = ["ENTRY_POINTS", "FORMAT_NAMES", "MAX_WARNINGS", "READERS", "STREAM_BLOCK", "FrameStream",
           "ReadReport", "log_suffix", "read_frames", "sha256_log", "supported_suffixes"]

log = logging.getLogger(__name__)
emit = emitter(__name__)

Reader = Callable[[str | os.PathLike[str], Callable[[int | None, str], None]],
                  tuple[FrameTable, int]]

#: The entry point group of plug-ins' log readers (the entry point's name: the suffix).
ENTRY_POINTS = "evtribo.log_readers"


def _suffix(entry: str, reader: Reader) -> str:
    """The suffix a plug-in's reader is registered under: its entry point's name, as
    :func:`log_suffix` gives suffixes (``.mylog``)."""
    name = entry.lower()
    return name if name.startswith(".") else f".{name}"


#: Suffix -> reader. ``.log`` is evtribo's own vectorised candump reader; the others are
#: python-can's readers (``.mf4`` only where python-can's optional ``asammdf`` is installed);
#: then the plug-ins' (read the first time a suffix the builtins lack is asked for).
READERS: Registry[Reader] = Registry(ENTRY_POINTS, "log reader",
                                     check=lambda obj: obj if callable(obj) else None,
                                     key=_suffix)
READERS.register(".log", read_candump)
for _builtin in MESSAGE_READERS:
    if _builtin != ".log":
        READERS.register(_builtin, read_with_python_can)

#: The formats' names, for messages.
FORMAT_NAMES = {".log": "candump -L", ".asc": "Vector ASC", ".blf": "Vector BLF",
                ".trc": "PEAK TRC", ".csv": "python-can CSV", ".db": "python-can SQLite",
                ".mf4": "ASAM MF4"}

#: Damaged lines logged one by one before a summary.
MAX_WARNINGS = 20

#: Bytes of a candump ``-L`` log read (and parsed) at a time by :class:`FrameStream`.
STREAM_BLOCK = 1 << 22


@dataclass
class ReadReport:
    """What reading a log found.

    Attributes
    ----------
    path : str
        The log.
    format : str
        Its suffix (``.log``, ``.asc``...; ``.log.gz`` for a gzipped candump log).
    frames : int
        Frames read (every kind: data, remote, error).
    lines : int
        Lines read (text formats; 0 for binary formats).
    skipped_lines : int
        Damaged lines (or records) skipped.
    skipped : list of (int or None, str)
        Line number and reason of each skipped line (the first 1000).
    channels : dict of str to int
        Frames per channel (``""``: frames of a log that names no channel).
    dropped_frames : int
        Frames the recording tool said it dropped (candump's ``DROPCOUNT`` notices), on
        every channel; by channel in ``FrameTable.reported_drops``.
    xl_frames : int
        CAN XL frames (counted, not held in the table).
    time_base : str
        How the log wrote its times when that is not seconds since the epoch (``"-tz"``,
        ``"-td"``, ``"-tA"`` for candump's screen output), else ``""``.
    """

    path: str
    format: str
    frames: int = 0
    lines: int = 0
    skipped_lines: int = 0
    skipped: list[tuple[int | None, str]] = field(default_factory=list)
    channels: dict[str, int] = field(default_factory=dict)
    dropped_frames: int = 0
    xl_frames: int = 0
    time_base: str = ""


def log_suffix(path: str | os.PathLike[str]) -> str:
    """The format suffix of *path*: ``.log``, ``.asc``..., or ``.log.gz`` for gzip.

    A trailing :data:`PARTIAL_SUFFIX` is ignored: ``run-01.log.part`` is a ``.log``.

    Parameters
    ----------
    path : path-like
        A log's path.

    Returns
    -------
    str
    """
    name = os.path.basename(os.fspath(path)).lower()
    if name.endswith(PARTIAL_SUFFIX) and len(name) > len(PARTIAL_SUFFIX):
        name = name[: -len(PARTIAL_SUFFIX)]
    stem, ext = os.path.splitext(name)
    if ext == ".gz":
        return os.path.splitext(stem)[1] + ext
    return ext


def supported_suffixes() -> list[str]:
    """Every suffix :func:`read_frames` accepts (each also with ``.gz``).

    Returns
    -------
    list of str
    """
    return sorted(READERS)


def _looks_like(path: str | os.PathLike[str], found: Sniffed | None) -> str:
    """`` It looks like ...: how to convert it.`` (empty when nothing is known)."""
    if found is None or found.kind == "unknown":
        return ""
    return f" It looks like {found.description}: {found.hint(path)}."


def _reader(path: str | os.PathLike[str], fmt: str, base: str) -> Reader:
    """The reader for *path*, after a look at its content; or a LogFormatError saying what
    the file is when it is not what its suffix says."""
    if fmt == ".db.gz":
        raise LogFormatError("a gzipped SQLite database cannot be read in place: decompress "
                             "it first (gunzip), then give evtribo the .db", path=path)
    if READERS.is_plugin(base):  # a lab's format: its reader knows it (and its .gz)
        return READERS[base]
    found = sniff(path)
    if found is not None and found.encoding is not None:
        raise LogFormatError(f"{found.description}: {found.hint(path)}.", path=path)
    if found is not None and found.kind not in ("unknown", "binary") and found.suffix != base:
        raise LogFormatError(f"not a {_name(base)} log.{_looks_like(path, found)}", path=path)
    if found is not None and found.kind == "candump-text":
        return read_candump_text
    return READERS[base]


def _checked_reader(path: str | os.PathLike[str]) -> tuple[str, Reader]:
    """The log's format suffix and its reader; a LogFormatError when there is none."""
    fmt = log_suffix(path)
    base = fmt[:-3] if fmt.endswith(".gz") else fmt
    if base not in READERS:
        close = difflib.get_close_matches(base, READERS, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close and base else ""
        looks = _looks_like(path, sniff(path)) if os.path.isfile(path) else ""
        raise LogFormatError(
            f"unknown log format {fmt or '(no suffix)'!r}{hint}; supported: "
            + ", ".join(supported_suffixes()) + f" (each also gzipped, .gz).{looks}", path=path)
    try:  # a FIFO or a device is refused by name, never read
        check_regular_file(path, LogFormatError, what="CAN log")
        os.close(os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY | os.O_CLOEXEC))
    except FileNotFoundError:
        raise LogFormatError("no such file", path=path) from None
    except PermissionError as err:  # mode 000, another user's log, a folder not to enter
        raise LogFormatError(f"cannot read: {err.strerror}", path=path) from None
    return fmt, _reader(path, fmt, base)


def sha256_log(path: str | os.PathLike[str]) -> str:
    """The SHA-256 of a log's bytes; a log that is no regular file, or that the user may not
    read, is refused by name.

    Parameters
    ----------
    path : path-like
        The log.

    Returns
    -------
    str
        64 hexadecimal digits.

    Raises
    ------
    LogFormatError
        A FIFO, a device or a folder; a log the user may not read (``cannot read:
        Permission denied``).
    """
    try:
        return sha256_file(path, LogFormatError, what="CAN log")
    except PermissionError as err:
        raise LogFormatError(f"cannot read: {err.strerror}", path=path) from None


class FrameStream:
    """A log's frames, block by block: memory follows the block, not the log.

    candump ``-L`` logs (``.log``, ``.log.gz``) are read in blocks of
    :data:`STREAM_BLOCK` bytes of whole lines; the other formats are read whole (one
    block). The log is checked when the stream is made (suffix, existence, content), so a
    wrong file fails before anything is written; each iteration reads the log again.

    Parameters
    ----------
    path : path-like
        The log, as :func:`read_frames` takes it.
    strict : bool
        Raise at the first damaged line instead of skipping it.
    block_size : int
        Bytes of a candump ``-L`` log read at a time.
    warn : bool
        Log a warning per damaged line (the first :data:`MAX_WARNINGS`); False for a second
        reading of a log already warned of.

    Attributes
    ----------
    report : ReadReport
        Counts of the frames read so far; whole once the stream is exhausted.

    Raises
    ------
    LogFormatError
        As :func:`read_frames`: when made (unknown suffix, missing file, another format), or
        while iterating (a damaged line with *strict*, an unreadable file, a text log
        without one frame, at its end).
    """

    def __init__(self, path: str | os.PathLike[str], *, strict: bool = False,
                 block_size: int = STREAM_BLOCK, warn: bool = True) -> None:
        self.path = path
        self.format, self._read = _checked_reader(path)
        self.strict = strict
        self.block_size = block_size
        self.warn = warn
        self.report = ReadReport(path=os.fspath(path), format=self.format)

    def _on_bad(self, line: int | None, reason: str) -> None:
        path, report = self.path, self.report
        if self.strict:
            raise LogFormatError(f"damaged line: {reason}", path=path, line=line)
        report.skipped_lines += 1
        if len(report.skipped) < 1000:
            report.skipped.append((line, reason))
        if self.warn and report.skipped_lines <= MAX_WARNINGS:
            where = os.fspath(path) if line is None else f"{os.fspath(path)}:{line}"
            emit("damaged-line", where=where, reason=reason)

    def _blocks(self) -> Iterator[tuple[FrameTable, int]]:
        if self._read is read_candump:
            yield from iter_candump(self.path, self._on_bad, self.block_size)
        else:
            yield self._read(self.path, self._on_bad)

    def __iter__(self) -> Iterator[FrameTable]:
        """The frames, one table per block, in file order."""
        self.report = report = ReadReport(path=os.fspath(self.path), format=self.format)
        fmt = self.format
        blocks = self._blocks()
        while True:
            try:
                frames, lines = next(blocks)
            except StopIteration:
                break
            except LogFormatError:
                raise
            except (OSError, EOFError, ValueError, zlib.error) as err:
                raise LogFormatError(f"cannot read {fmt} log: {err}", path=self.path) from err
            _add(report, frames, lines)
            yield frames
        if not report.frames and report.skipped_lines and not report.xl_frames:
            line, reason = report.skipped[0]
            if not report.lines:  # a binary log
                raise LogFormatError(f"cannot read {fmt} log: {reason}", path=self.path)
            base = fmt.removesuffix(".gz")
            raise LogFormatError(
                f"not a {_name(base)} log: no line of it is a frame (line {line}: {reason})."
                f"{_looks_like(self.path, sniff(self.path))}", path=self.path)
        if self.warn and report.skipped_lines > MAX_WARNINGS:
            emit("damaged-lines-more", log=os.fspath(self.path), lines=report.skipped_lines,
                 listed=MAX_WARNINGS)


def read_frames(path: str | os.PathLike[str], *, strict: bool = False
                ) -> tuple[FrameTable, ReadReport]:
    """Read a CAN log into columns.

    Parameters
    ----------
    path : path-like
        The log; its suffix picks the reader (see :data:`READERS`), ``.gz`` is decompressed,
        and ``.part`` (an acquisition's temporary name) is ignored.
    strict : bool
        Raise at the first damaged line instead of skipping it.

    Returns
    -------
    frames : FrameTable
        The frames in file order.
    report : ReadReport
        Counts, and the damaged lines skipped.

    Raises
    ------
    LogFormatError
        Unknown suffix, unreadable file, a file of another format than its suffix says, a
        text log without one frame, or (``strict``) a damaged line; the message names the
        file and the line.
    """
    stream = FrameStream(path, strict=strict)
    tables = list(stream)
    if not tables:
        return FrameTable.empty(), stream.report
    return (tables[0] if len(tables) == 1 else FrameTable.concat(tables)), stream.report


def _name(base: str) -> str:
    """``candump -L (.log)``: a format's name and suffix."""
    return f"{FORMAT_NAMES[base]} ({base})" if base in FORMAT_NAMES else base


def _add(report: ReadReport, frames: FrameTable, lines: int) -> None:
    """Add the counts of a block of *frames* (and its *lines*) to *report*."""
    report.frames += len(frames)
    report.lines += lines
    for k, v in frames.channel_counts().items():
        name = "" if k is None else k
        report.channels[name] = report.channels.get(name, 0) + v
    report.dropped_frames += sum(frames.reported_drops.values())
    report.xl_frames += frames.xl_frames
    report.time_base = report.time_base or str(frames.extras.get("time_base", "")).replace(
        "-ta", "")
