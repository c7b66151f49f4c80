"""One entry point for every log format: :func:`read_frames` picks the reader by suffix.

The registry maps a suffix to a reader function ``reader(path, on_bad) -> (FrameTable,
lines)``, the way python-can's ``MESSAGE_READERS`` maps suffixes to reader classes. A
``.gz`` name is read by the reader of the suffix before it (``run-01.log.gz``).

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
from collections.abc import Callable
from dataclasses import dataclass, field

from can.io.player import MESSAGE_READERS

from evtribo.errors import LogFormatError
from evtribo.frames.candump import read_candump
from evtribo.frames.pycan import read_with_python_can
from evtribo.frames.table import FrameTable

log = logging.getLogger(__name__)

Reader = Callable[[str | os.PathLike[str], Callable[[int | None, str], None]],
                  tuple[FrameTable, int]]

#: Suffix -> reader. ``.log`` is evtribo's own vectorised candump reader; the others are
#: python-can's readers (``.mf4`` only where python-can's optional ``asammdf`` is installed).
READERS: dict[str, Reader] = {".log": read_candump}
for _suffix in MESSAGE_READERS:
    if _suffix != ".log":
        READERS[_suffix] = read_with_python_can

#: Damaged lines logged one by one before a summary.
MAX_WARNINGS = 20


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
    """

    path: str
    format: str
    frames: int = 0
    lines: int = 0
    skipped_lines: int = 0
    skipped: list[tuple[int | None, str]] = field(default_factory=list)


#: Suffix of a log left under its temporary name by an acquisition that did not finish
#: (``run-01.log.part``); it is read by the reader of the suffix before it.
PARTIAL_SUFFIX = ".part"


def log_suffix(path: str | os.PathLike[str]) -> str:
    """The format suffix of *path*: ``.log``, ``.asc``..., or ``.log.gz`` for gzip.

    A trailing :data:`PARTIAL_SUFFIX` is ignored: ``run-01.log.part`` is a ``.log``.
    """
    name = os.path.basename(os.fspath(path)).lower()
    if name.endswith(PARTIAL_SUFFIX) and len(name) > len(PARTIAL_SUFFIX):
        name = name[: -len(PARTIAL_SUFFIX)]
    stem, ext = os.path.splitext(name)
    if ext == ".gz":
        return os.path.splitext(stem)[1] + ext
    return ext


def supported_suffixes() -> list[str]:
    """Every suffix :func:`read_frames` accepts (each also with ``.gz``)."""
    return sorted(READERS)


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
        Unknown suffix, unreadable file, or (``strict``) a damaged line; the message names
        the file and the line.
    """
    fmt = log_suffix(path)
    base = fmt[:-3] if fmt.endswith(".gz") else fmt
    reader = READERS.get(base)
    if reader is None:
        close = difflib.get_close_matches(base, READERS, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close and base else ""
        raise LogFormatError(
            f"unknown log format {fmt or '(no suffix)'!r}{hint}; supported: "
            + ", ".join(supported_suffixes()) + " (each also gzipped, .gz)", path=path)
    if not os.path.isfile(path):
        raise LogFormatError("no such file", path=path)
    report = ReadReport(path=os.fspath(path), format=fmt)

    def on_bad(line: int | None, reason: str) -> None:
        if strict:
            raise LogFormatError(f"damaged line: {reason}", path=path, line=line)
        report.skipped_lines += 1
        if len(report.skipped) < 1000:
            report.skipped.append((line, reason))
        if report.skipped_lines <= MAX_WARNINGS:
            where = os.fspath(path) if line is None else f"{os.fspath(path)}:{line}"
            log.warning("%s: skipped damaged line: %s", where, reason)

    try:
        frames, lines = reader(path, on_bad)
    except LogFormatError:
        raise
    except (OSError, EOFError, ValueError, zlib.error) as err:
        raise LogFormatError(f"cannot read {fmt} log: {err}", path=path) from err
    report.frames = len(frames)
    report.lines = lines
    if report.skipped_lines > MAX_WARNINGS:
        log.warning("%s: %d damaged lines skipped in all (first %d listed)",
                    os.fspath(path), report.skipped_lines, MAX_WARNINGS)
    return frames, report
