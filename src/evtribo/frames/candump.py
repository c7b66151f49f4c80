"""candump ``-L`` text logs (``.log``, ``.log.gz``), read and written with numpy in bulk.

A line looks like ``(1763700000.000123) vcan0 0C1#1122334455667788``: the timestamp in
seconds, the channel, the identifier (3 hex digits for standard 11-bit IDs, 8 for extended
29-bit IDs; the ``CAN_ERR_FLAG`` bit ``0x20000000`` marks an error frame), ``#`` and the
payload in hex. ``123#R`` (or ``123#R4``) is a remote frame, ``123##<flags><hex>`` a CAN FD
frame. python-can's writer appends `` R``/`` T`` (direction); that is accepted too. Each
frame keeps its channel (a log of several buses holds the same ID once per bus; candump pads
the channel names of such a log to one width). ``DROPCOUNT`` notices, CAN XL frames, raw DLC
codes and over-long classic frames: see :mod:`evtribo.frames.candump_line`.

How the reader stays fast: the file is read in blocks of whole lines; lines are grouped by
length, each group is copied as one ``(lines, length)`` byte matrix (a strided view of the
block, no Python loop), its layout is taken from its first line, and every row matching that
layout is parsed column-wise (hex through a lookup table, timestamps as exact integers
divided by a power of ten, so the result equals ``float()`` of the text). Rows that do not
match (rare: a remote frame among data frames, a stray space, a damaged line) go through a
per-line parser; a line that parser refuses is damaged.

Error frames keep their error-class bits as ``arbitration_id`` and their payload (the Linux
SocketCAN convention); python-can's reader reports them with ID 0 and no payload.
"""

from __future__ import annotations

import gzip
import os
import re
from collections.abc import Callable, Iterator
from typing import IO, Any, cast

import numpy as np
import numpy.typing as npt

from evtribo.files import PARTIAL_SUFFIX
from evtribo.frames.candump_line import FD_SIZES, Notice, parse_line

# the writer (and the CAN_ERR constants the logger shares) live in candump_writer; its
# names stay importable from here
from evtribo.frames.candump_writer import (
    CAN_EFF_MASK,
    CAN_ERR_BUSERROR,
    CAN_ERR_FLAG,
    frame_field,
    write_candump,
)
from evtribo.frames.table import CLASSIC_WIDTH, FD_WIDTH, NO_CHANNEL, FrameTable

_BLOCK = 1 << 22  # bytes read at a time

_HEX = np.full(256, 255, dtype=np.uint8)
for _i, _c in enumerate(b"0123456789abcdef"):
    _HEX[_c] = _i
for _i, _c in enumerate(b"ABCDEF"):
    _HEX[_c] = 10 + _i

#: ``on_bad(line_number, reason)`` is called for every damaged line.
BadLineHandler = Callable[[int, str], None]


class _Chunk:
    """Columns of one block, one row per line; ``valid`` marks the rows holding a frame."""

    def __init__(self, n: int, width: int) -> None:
        self.timestamp = np.zeros(n, dtype=np.float64)
        self.arbitration_id = np.zeros(n, dtype=np.uint32)
        self.is_extended = np.zeros(n, dtype=bool)
        self.is_remote = np.zeros(n, dtype=bool)
        self.is_error = np.zeros(n, dtype=bool)
        self.is_fd = np.zeros(n, dtype=bool)
        self.dlc = np.zeros(n, dtype=np.uint8)
        self.data = np.zeros((n, width), dtype=np.uint8)
        self.valid = np.zeros(n, dtype=bool)
        self.channel_index = np.full(n, NO_CHANNEL, dtype=np.int16)
        self.names: dict[str, int] = {}
        self.drops: dict[str, int] = {}
        self.xl_frames = 0

    def code(self, name: bytes | str) -> int:
        """The index of channel *name* (numbered in order of first appearance)."""
        text = name.decode("ascii", "replace") if isinstance(name, bytes) else name
        return self.names.setdefault(text, len(self.names))

    def widen(self, nbytes: int) -> None:
        """Make room for payloads of *nbytes*."""
        if nbytes > self.data.shape[1]:
            wide = np.zeros((len(self.valid), FD_WIDTH), dtype=np.uint8)
            wide[:, :self.data.shape[1]] = self.data
            self.data = wide

    def table(self) -> FrameTable:
        v: Any = slice(None) if self.valid.all() else self.valid
        index = self.channel_index[v]
        names = tuple(self.names)
        if len(names) > 1:  # number the channels in order of their first frame
            _codes, first = np.unique(index, return_index=True)
            order = index[np.sort(first)]
            remap = np.zeros(len(names), dtype=np.int16)
            remap[order] = np.arange(len(order), dtype=np.int16)
            index = remap[index]
            names = tuple(names[k] for k in order)
        return FrameTable(
            timestamp=self.timestamp[v], arbitration_id=self.arbitration_id[v],
            is_extended=self.is_extended[v], is_remote=self.is_remote[v],
            is_error=self.is_error[v], is_fd=self.is_fd[v], dlc=self.dlc[v],
            data=self.data[v], channel=names[index[0]] if len(index) else None,
            channel_index=index, channel_names=names, reported_drops=self.drops,
            xl_frames=self.xl_frames,
        )


def _digits_value(mat: npt.NDArray[np.uint8]) -> npt.NDArray[np.float64]:
    """Decimal digit columns (at most 16) to exact integers, as float64 (exact below 2**53).

    Eight ASCII digits at a time are read as one little-endian uint64 and folded in three
    multiply-shift-mask steps (the "SWAR" trick), instead of a loop over columns.
    """
    n, k = mat.shape
    padded = np.full((n, 16), 48, dtype=np.uint8)
    padded[:, 16 - k:] = mat
    words = padded.view("<u8") - np.uint64(0x3030303030303030)
    words = (words * np.uint64(10) + (words >> np.uint64(8))) & np.uint64(0x00FF00FF00FF00FF)
    words = (words * np.uint64(100) + (words >> np.uint64(16))) & np.uint64(0x0000FFFF0000FFFF)
    words = (words * np.uint64(10000) + (words >> np.uint64(32))) & np.uint64(0xFFFFFFFF)
    return words[:, 0].astype(np.float64) * 1e8 + words[:, 1].astype(np.float64)


def _hex_nibbles(chars: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint8]:
    """Values of hex digits (garbage for other characters: check :func:`_is_hex`)."""
    return (chars & np.uint8(15)) + np.uint8(9) * (chars >> np.uint8(6))


def _is_hex(chars: npt.NDArray[np.uint8]) -> npt.NDArray[np.bool_]:
    return ((chars - np.uint8(48)) < 10) | (((chars | np.uint8(0x20)) - np.uint8(97)) < 6)


def _is_digit(chars: npt.NDArray[np.uint8]) -> npt.NDArray[np.bool_]:
    return (chars - np.uint8(48)) < 10


def _hex_value(nib: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint32]:
    out = np.zeros(nib.shape[0], dtype=np.uint32)
    for k in range(nib.shape[1]):
        out = (out << np.uint32(4)) | nib[:, k]
    return out


def _layout(line: bytes) -> dict[str, int] | None:
    """Column layout of a well-formed, fixed-width line, or None to use the slow path."""
    m = re.fullmatch(
        rb"\((\d+)(?:\.(\d+))?\) +(\S+) ([0-9A-Fa-f]{3}|[0-9A-Fa-f]{8})#(#[0-9A-Fa-f])?"
        rb"((?:[0-9A-Fa-f]{2})*)(_[0-9A-Fa-f])?( [RTrt])?", line)
    if m is None or len(m[1]) + len(m[2] or b"") > 16:
        return None
    fd = m[5] is not None
    nbytes = len(m[6]) // 2
    if nbytes > (64 if fd else 8) or (fd and nbytes not in FD_SIZES):
        return None
    if m[7] and (fd or nbytes != 8):  # a raw DLC code follows 8 bytes of a classic frame
        return None
    return {
        "int0": m.start(1), "int1": m.end(1),
        "dot": m.start(2) - 1 if m[2] else -1, "frac1": m.end(2) if m[2] else -1,
        "ch0": m.start(3), "ch1": m.end(3), "id0": m.start(4), "id1": m.end(4),
        "fd": int(fd), "flags": m.start(5) + 1 if fd else -1,
        "data0": m.start(6), "nbytes": nbytes, "raw_dlc": m.start(7) if m[7] else -1,
        "dir": m.start(8) if m[8] else -1,
    }


def _row_checks(mat: npt.NDArray[np.uint8], lay: dict[str, int]
                ) -> list[tuple[npt.NDArray[np.uint8], Callable[..., Any] | int]]:
    """(columns, test) pairs a row of the layout must pass: a character or a predicate."""
    close = lay["int1"] if lay["dot"] < 0 else lay["frac1"]
    checks: list[tuple[npt.NDArray[np.uint8], Callable[..., Any] | int]] = [
        (mat[:, 0], ord("(")), (mat[:, close], ord(")")),
        (mat[:, close + 1], ord(" ")), (mat[:, lay["ch1"]], ord(" ")),
        (mat[:, lay["id1"]], ord("#")),
        (mat[:, lay["int0"]:lay["int1"]], _is_digit),
        (mat[:, lay["id0"]:lay["id1"]], _is_hex),
        (mat[:, lay["data0"]:lay["data0"] + 2 * lay["nbytes"]], _is_hex),
    ]
    if lay["dot"] >= 0:
        checks += [(mat[:, lay["dot"]], ord(".")),
                   (mat[:, lay["dot"] + 1:lay["frac1"]], _is_digit)]
    if lay["fd"]:
        checks += [(mat[:, lay["flags"] - 1], ord("#")), (mat[:, lay["flags"]], _is_hex)]
    if lay["raw_dlc"] >= 0:
        checks += [(mat[:, lay["raw_dlc"]], ord("_")), (mat[:, lay["raw_dlc"] + 1], _is_hex)]
    if lay["dir"] >= 0:
        checks += [(mat[:, lay["dir"]], ord(" ")),
                   (mat[:, lay["dir"] + 1] | np.uint8(0x20), lambda c: (c == ord("r"))
                    | (c == ord("t")))]
    return checks


def _channels(mat: npt.NDArray[np.uint8], lay: dict[str, int], out: _Chunk
              ) -> tuple[npt.NDArray[np.int16] | int, npt.NDArray[np.bool_] | None]:
    """Each row's channel code, and which rows name no valid channel (None: all do).

    The channel field runs from after ``") "`` to the space before the identifier: candump
    right-aligns the names of a log of several buses, so a shorter name comes with spaces
    before it. When every row holds the same field (a one-bus log) this is one comparison
    of 8 bytes per row, read as one integer and masked to the field.
    """
    ch0 = (lay["int1"] if lay["dot"] < 0 else lay["frac1"]) + 2
    width = lay["ch1"] - ch0
    if width <= 8 and ch0 + 8 <= mat.shape[1] and mat.strides[1] == 1:
        mask = np.uint64((1 << (8 * width)) - 1)
        keys = mat[:, ch0:ch0 + 8].view("<u8")[:, 0] & mask
    else:  # long fields: the bytes themselves
        keys = np.ascontiguousarray(mat[:, ch0:ch0 + width]).view(f"V{width}").ravel()

    def code(row: int) -> int:
        name = mat[row, ch0:ch0 + width].tobytes().lstrip(b" ")
        return -1 if not name or b" " in name else out.code(name)

    if bool((keys == keys[0]).all()):
        first = code(0)
        return (first, None) if first >= 0 else (first, np.ones(len(mat), dtype=bool))
    _unique, firsts, inverse = np.unique(keys, return_index=True, return_inverse=True)
    codes = np.array([code(i) for i in firsts], dtype=np.int16)[inverse.ravel()]
    bad = codes < 0
    return codes, bad if bad.any() else None


def _parse_group(mat: npt.NDArray[np.uint8], lay: dict[str, int],
                 rows_in: npt.NDArray[np.intp] | None, out: _Chunk) -> npt.NDArray[np.bool_]:
    """Parse the rows of *mat* that follow *lay* into *out*; return which rows did.

    *rows_in* gives each row's index in *out* (None: row ``i`` of *mat* is row ``i``).
    """
    checks = _row_checks(mat, lay)
    rows: Any = slice(None) if rows_in is None else rows_in
    out.widen(lay["nbytes"])

    def passes(cols: npt.NDArray[np.uint8], test: Callable[..., Any] | int
               ) -> npt.NDArray[np.bool_]:
        return cols == test if isinstance(test, int) else test(cols)

    # whole-matrix tests first (one reduction each); per-row masks only when one fails
    ok = np.ones(len(mat), dtype=bool)
    if not all(bool(passes(c, t).all()) for c, t in checks):
        for c, t in checks:
            r = passes(c, t)
            ok &= r if r.ndim == 1 else r.all(axis=1)
        rows = np.flatnonzero(ok) if rows_in is None else rows_in[ok]
        mat = mat[ok]
    if lay["dot"] >= 0:
        num = np.concatenate([mat[:, lay["int0"]:lay["int1"]],
                              mat[:, lay["dot"] + 1:lay["frac1"]]], axis=1)
        whole = _digits_value(num)
        scale = 10.0 ** (lay["frac1"] - lay["dot"] - 1)
    else:
        whole = _digits_value(mat[:, lay["int0"]:lay["int1"]])
        scale = 1.0
    can_id = _hex_value(_hex_nibbles(mat[:, lay["id0"]:lay["id1"]]))
    long_id = lay["id1"] - lay["id0"] == 8
    # integers below 2**53 are exact (and so is one division); 3-digit IDs must be <= 0x7FF
    keep = whole < 2.0**53
    if not long_id:
        keep &= can_id <= 0x7FF
    channels, bad_channel = _channels(mat, lay, out) if len(mat) else (0, None)
    if bad_channel is not None:
        keep &= ~bad_channel
    if not keep.all():  # the others go to the slow path
        ok[np.flatnonzero(ok)[~keep]] = False
        if isinstance(rows, slice):
            rows = np.arange(len(keep))
        mat, rows, whole, can_id = mat[keep], rows[keep], whole[keep], can_id[keep]
        if not isinstance(channels, int):
            channels = channels[keep]
    ts = whole / scale
    if long_id:
        error = (can_id & np.uint32(CAN_ERR_FLAG)) != 0
        out.is_extended[rows] = ~error
        out.is_error[rows] = error
    out.timestamp[rows] = ts
    out.channel_index[rows] = channels
    out.arbitration_id[rows] = can_id & np.uint32(CAN_EFF_MASK)
    out.is_fd[rows] = bool(lay["fd"])
    nb = lay["nbytes"]
    out.dlc[rows] = nb
    if nb:
        d_nib = _hex_nibbles(mat[:, lay["data0"]:lay["data0"] + 2 * nb])
        out.data[rows, :nb] = (d_nib[:, 0::2] << np.uint8(4)) | d_nib[:, 1::2]
    out.valid[rows] = True
    return ok


def _parse_block(block: bytes, first_line: int, on_bad: BadLineHandler
                 ) -> tuple[FrameTable, int]:
    """Frames of a block of whole lines, and the number of lines."""
    buf = np.frombuffer(block, dtype=np.uint8)
    nl = np.flatnonzero(buf == 10)
    step = int(nl[0]) + 1 if len(nl) else 0
    if (step > 2 and len(block) == step * len(nl) and block[step - 2] != 13
            and bool((nl[1:] - nl[:-1] == step).all())):
        # every line has the same length: the block is already a (lines, length) matrix
        n = len(nl)
        out = _Chunk(n, CLASSIC_WIDTH)
        mat = buf.reshape(n, step)[:, :step - 1]
        lay = _layout(mat[0].tobytes())
        if lay is not None:
            ok = _parse_group(mat, lay, None, out)
            if not ok.all():
                starts = np.arange(n) * step
                _slow_lines(block, starts, starts + step - 1, np.flatnonzero(~ok),
                            first_line=first_line, on_bad=on_bad, out=out)
            return out.table(), n
    starts = np.concatenate(([0], nl + 1))
    ends = np.concatenate((nl, [len(buf)]))
    if starts[-1] >= len(buf):  # block ends with a newline
        starts, ends = starts[:-1], ends[:-1]
    cr = (ends > starts) & (buf[np.maximum(ends - 1, 0)] == 13)
    ends = ends - cr
    lengths = ends - starts
    out = _Chunk(len(starts), CLASSIC_WIDTH)
    slow = np.zeros(len(starts), dtype=bool)
    windows = np.lib.stride_tricks.sliding_window_view
    counts = np.bincount(lengths)
    for length in np.flatnonzero(counts):
        if length == 0:
            continue
        rows = np.flatnonzero(lengths == length) if counts[length] < len(lengths) \
            else np.arange(len(lengths))
        mat = windows(buf, int(length))[starts[rows]]
        lay = _layout(mat[0].tobytes())
        if lay is None:
            slow[rows] = True
            continue
        ok = _parse_group(mat, lay, rows, out)
        slow[rows[~ok]] = True
    _slow_lines(block, starts, ends, np.flatnonzero(slow), first_line=first_line,
                on_bad=on_bad, out=out)
    return out.table(), len(starts)


def _slow_lines(block: bytes, starts: npt.NDArray[np.intp], ends: npt.NDArray[np.intp],
                which: npt.NDArray[np.intp], *, first_line: int, on_bad: BadLineHandler,
                out: _Chunk) -> None:
    for i in which:
        text = block[starts[i]:ends[i]].decode("utf-8", "replace")
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
    """Blocks of whole lines of *stream* (the last may lack its newline).

    Parameters
    ----------
    stream : binary file
    block_size : int
        About how many bytes a block holds.

    Yields
    ------
    bytes
    """
    rest = b""
    while True:
        chunk = stream.read(block_size)
        if not chunk:
            break
        data = rest + chunk
        cut = data.rfind(b"\n")
        if cut < 0:
            rest = data
            continue
        block, rest = data[:cut + 1], data[cut + 1:]
        yield block
    if rest:
        yield rest


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
        for block in iter_blocks(stream, block_size):
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
