"""candump ``-L`` text logs (``.log``, ``.log.gz``), read and written with numpy in bulk.

A line looks like ``(1763700000.000123) vcan0 0C1#1122334455667788``: the timestamp in
seconds, the channel, the identifier (3 hex digits for standard 11-bit IDs, 8 for extended
29-bit IDs; the ``CAN_ERR_FLAG`` bit ``0x20000000`` marks an error frame), ``#`` and the
payload in hex. ``123#R`` (or ``123#R4``) is a remote frame, ``123##<flags><hex>`` a CAN FD
frame. python-can's writer appends `` R``/`` T`` (direction); that is accepted too. Each
frame keeps its channel (a log of several buses holds the same ID once per bus; candump pads
the channel names of such a log to one width). ``DROPCOUNT`` notices, CAN XL frames, raw DLC
codes and over-long classic frames: see :mod:`evtribo.canlog.io.candump_line`.

How the reader stays fast and small: the file is read in blocks of whole lines
(:func:`iter_candump` yields each block's frames, so memory follows the block, not the
file); a block whose lines all have one length is already a ``(lines, length)`` byte matrix,
else its lines are grouped by length (one stable radix sort of the lengths) and each group
copied as one matrix (a memory copy per line, no Python loop); a group's layout is taken
from its first line, and every row matching that layout is parsed column-wise
(:mod:`evtribo.canlog.io.candump_columns`: hex by a table lookup per character, timestamps
as exact integers divided by a power of ten, so the result equals ``float()`` of the
text). Rows that do not match (rare: a remote frame among data
frames, a stray space, a damaged line) go through a per-line parser; a line that parser
refuses is damaged.

Error frames keep their error-class bits as ``arbitration_id`` and their payload (the Linux
SocketCAN convention); python-can's reader reports them with ID 0 and no payload.

What it replaces: python-can's ``CanutilsLogReader`` (one :class:`can.Message` per line);
``tests/canlog/test_python_can_logs.py`` and ``tests/canlog/test_candump_details.py`` hold
the reader against :class:`can.LogReader` frame for frame.
"""

from __future__ import annotations

import gzip
import os
from collections.abc import Iterator
from typing import IO, cast

import numpy as np
import numpy.typing as npt

from evtribo.canlog.io.candump_columns import (
    BadLineHandler,
    _Chunk,
    _layout,
    _parse_group,
    line_rows,
)
from evtribo.canlog.io.candump_line import FD_SIZES, MAX_LINE, Notice, parse_line, too_long

# the writer (and the CAN_ERR constants the logger shares) live in candump_writer; its
# names stay importable from here
from evtribo.canlog.io.candump_writer import (
    CAN_EFF_MASK,
    CAN_ERR_BUSERROR,
    CAN_ERR_FLAG,
    frame_field,
    write_candump,
)
from evtribo.canlog.io.table import CLASSIC_WIDTH, FrameTable
from evtribo.store.files import PARTIAL_SUFFIX

_BLOCK = 1 << 22  # bytes read at a time
_HEAD = 1 << 12  # bytes searched for the end of a block's first line (longer: no matrix)

def _parse_block(block: bytes | memoryview, first_line: int, on_bad: BadLineHandler
                 ) -> tuple[FrameTable, int]:
    """Frames of a block of whole lines, and the number of lines."""
    buf = np.frombuffer(block, dtype=np.uint8)
    head = np.flatnonzero(buf[:_HEAD] == 10)
    step = int(head[0]) + 1 if len(head) else 0
    if (step > 2 and len(buf) % step == 0 and buf[step - 2] != 13
            and bool((buf[step - 1::step] == 10).all())):
        # a newline ends every line of the first's length: if there is no other, the block
        # is a (lines, length) matrix. There is none when every row parses (no check of a
        # row lets a newline through), which spares a search of the whole block for them.
        n = len(buf) // step
        mat = buf.reshape(n, step)[:, :step - 1]
        lay = _layout(mat[0].tobytes())
        if lay is not None:
            out = _Chunk(n, CLASSIC_WIDTH)
            ok = _parse_group(mat, lay, None, out)
            if ok.all():
                return out.table(), n
            if np.count_nonzero(buf == 10) == n:  # the rows are lines: a few are damaged
                starts = np.arange(n) * step
                _slow_lines(block, starts, starts + step - 1, np.flatnonzero(~ok),
                            first_line=first_line, on_bad=on_bad, out=out)
                return out.table(), n
    nl = np.flatnonzero(buf == 10)
    starts = np.concatenate(([0], nl + 1))
    ends = np.concatenate((nl, [len(buf)]))
    if starts[-1] >= len(buf):  # block ends with a newline
        starts, ends = starts[:-1], ends[:-1]
    cr = (ends > starts) & (buf[np.maximum(ends - 1, 0)] == 13)
    ends = ends - cr
    lengths = ends - starts
    out = _Chunk(len(starts), CLASSIC_WIDTH)
    slow = np.zeros(len(starts), dtype=bool)
    counts = np.bincount(lengths)
    # the lines of each length, in file order: one stable sort instead of a scan per length
    by_length = np.argsort(lengths.astype(np.uint16) if len(counts) <= 1 << 16 else lengths,
                           kind="stable")  # a radix sort on 16 bits
    ends_at = np.cumsum(counts)
    for length in np.flatnonzero(counts):
        if length == 0:
            continue
        rows = by_length[ends_at[length] - counts[length]:ends_at[length]]
        mat = line_rows(buf, starts[rows], int(length))
        lay = _layout(mat[0].tobytes())
        if lay is None:
            slow[rows] = True
            continue
        ok = _parse_group(mat, lay, rows, out)
        slow[rows[~ok]] = True
    _slow_lines(block, starts, ends, np.flatnonzero(slow), first_line=first_line,
                on_bad=on_bad, out=out)
    return out.table(), len(starts)


def _slow_lines(block: bytes | memoryview, starts: npt.NDArray[np.intp],
                ends: npt.NDArray[np.intp], which: npt.NDArray[np.intp], *, first_line: int,
                on_bad: BadLineHandler, out: _Chunk) -> None:
    for i in which:
        text = str(block[starts[i]:ends[i]], "utf-8", "replace")
        if not text.strip():
            continue
        parsed = parse_line(text)
        if isinstance(parsed, str):
            on_bad(first_line + int(i), parsed)
            continue
        if isinstance(parsed, Notice):
            if parsed.kind == "dropped":
                out.drops[parsed.channel] = out.drops.get(parsed.channel, 0) + parsed.count
            else:
                out.xl_frames += 1
            continue
        ts, ch, can_id, ext, remote, err, fd, payload = parsed
        out.widen(len(payload))
        out.timestamp[i], out.arbitration_id[i] = ts, can_id
        out.is_extended[i], out.is_remote[i], out.is_error[i], out.is_fd[i] = ext, remote, err, fd
        out.dlc[i] = len(payload)
        if not remote:
            out.data[i, :len(payload)] = np.frombuffer(payload, dtype=np.uint8)
        out.channel_index[i] = out.code(ch)
        out.valid[i] = True


def _open_binary(path: str | os.PathLike[str]) -> IO[bytes]:
    if os.fspath(path).lower().removesuffix(PARTIAL_SUFFIX).endswith(".gz"):
        # a GzipFile is a binary file, though typeshed does not call it IO[bytes]
        return cast("IO[bytes]", gzip.open(path, "rb"))
    return open(path, "rb")


def iter_blocks(stream: IO[bytes], block_size: int = _BLOCK) -> Iterator[bytes]:
    """Blocks of whole lines of *stream* (the last may lack its newline); a line longer than
    :data:`MAX_LINE` is left out (:func:`iter_candump` reports it as damaged).

    Parameters
    ----------
    stream : binary file
    block_size : int
        About how many bytes a block holds.

    Yields
    ------
    bytes
    """
    for view in _line_blocks(stream, block_size):
        if not isinstance(view, int):
            yield bytes(view)


def _line_blocks(stream: IO[bytes], block_size: int) -> Iterator[memoryview | int]:
    """:func:`iter_blocks`' blocks as views of one buffer that is read into again: each is
    valid until the next is asked for, and nothing may keep it (a reader that parses a block
    whole before taking the next). A new buffer for every block would cost more than
    reading (the kernel hands out and zeroes its pages anew: 20-35 ms a 31 MB log, against
    4 ms read into one buffer).

    A line longer than :data:`MAX_LINE` (no frame's line is: a gzip bomb of zeros, a file
    of another kind) is not held: its bytes are read past up to its newline and its length
    yielded (an int) in its place, so memory stays within two blocks whatever the file
    holds."""
    readinto = getattr(stream, "readinto", None)
    if readinto is None:  # a stream that can only read()
        def readinto(into: memoryview) -> int:
            data = stream.read(len(into))
            into[:len(data)] = data
            return len(data)
    buf = bytearray(2 * block_size)
    held = 0  # bytes of an unfinished line at the start of buf (at most MAX_LINE)
    skipped = -1  # bytes of an over-long line read past so far (-1: none)
    while True:
        if held + block_size > len(buf):  # a line longer than a block: a larger buffer
            buf = buf[:held] + bytearray(held + block_size)
        with memoryview(buf)[held:held + block_size] as into:
            got = readinto(into)
        if not got:
            break
        end = held + got
        if skipped >= 0:  # inside an over-long line: up to its newline
            nl = buf.find(b"\n", 0, end)
            if nl < 0:
                skipped, held = skipped + end, 0
                continue
            yield skipped + nl + 1
            skipped, held = -1, end - nl - 1
            buf[:held] = buf[nl + 1:end]
            continue
        cut = buf.rfind(b"\n", 0, end)
        if cut < 0:
            if end > MAX_LINE:
                skipped, held = end, 0
            else:
                held = end
            continue
        yield memoryview(buf)[:cut + 1]
        held = end - cut - 1
        buf[:held] = buf[cut + 1:end]
    if skipped >= 0:
        yield skipped
    elif held:
        yield memoryview(buf)[:held]


def iter_candump(path: str | os.PathLike[str], on_bad: BadLineHandler,
                 block_size: int = _BLOCK) -> Iterator[tuple[FrameTable, int]]:
    """Read a candump ``-L`` log (plain or gzip) block by block.

    Parameters
    ----------
    path : path-like
        The log; a name ending in ``.gz`` is decompressed.
    on_bad : callable
        Called as ``on_bad(line_number, reason)`` for each damaged line (it may raise).
    block_size : int
        Bytes read at a time: memory use grows with it, not with the file.

    Yields
    ------
    frames : FrameTable
        The frames of one block of whole lines, in file order (its channels numbered in
        the block's own order of first appearance: match them by name).
    lines : int
        Lines of the block.
    """
    lines = 0
    with _open_binary(path) as stream:
        for block in _line_blocks(stream, block_size):
            if isinstance(block, int):  # a line no frame can have: damaged, not held
                lines += 1
                on_bad(lines, too_long(block))
                continue
            table, n = _parse_block(block, lines + 1, on_bad)
            lines += n
            yield table, n


def read_candump(path: str | os.PathLike[str], on_bad: BadLineHandler,
                 block_size: int = _BLOCK) -> tuple[FrameTable, int]:
    """Read a candump ``-L`` log (plain or gzip) whole.

    Parameters
    ----------
    path : path-like
        The log; a name ending in ``.gz`` is decompressed.
    on_bad : callable
        Called as ``on_bad(line_number, reason)`` for each damaged line (it may raise).
    block_size : int
        Bytes read at a time (see :func:`iter_candump`).

    Returns
    -------
    frames : FrameTable
        The frames in file order.
    lines : int
        Lines read.
    """
    tables = []
    lines = 0
    for table, n in iter_candump(path, on_bad, block_size):
        tables.append(table)
        lines += n
    if not tables:
        return FrameTable.empty(), 0
    return (tables[0] if len(tables) == 1 else FrameTable.concat(tables)), lines


__all__ = ["CAN_EFF_MASK", "CAN_ERR_BUSERROR", "CAN_ERR_FLAG", "FD_SIZES", "frame_field",
           "iter_blocks", "iter_candump", "parse_line", "read_candump", "write_candump"]
