"""candump ``-L`` text logs (``.log``, ``.log.gz``), read and written with numpy in bulk.

A line looks like ``(1763700000.000123) vcan0 0C1#1122334455667788``: the timestamp in
seconds, the channel, the identifier (3 hex digits for standard 11-bit IDs, 8 for extended
29-bit IDs; the ``CAN_ERR_FLAG`` bit ``0x20000000`` marks an error frame), ``#`` and the
payload in hex. ``123#R`` (or ``123#R4``) is a remote frame, ``123##<flags><hex>`` a CAN FD
frame. python-can's writer appends `` R``/`` T`` (direction); that is accepted too.

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
import io
import os
import re
from collections.abc import Callable, Iterator
from typing import IO, Any

import numpy as np
import numpy.typing as npt

from evtribo.frames.table import CLASSIC_WIDTH, FD_WIDTH, FrameTable

CAN_ERR_FLAG = 0x20000000
CAN_EFF_MASK = 0x1FFFFFFF
#: Payload sizes a CAN FD frame can have, bytes.
FD_SIZES = (0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64)
_BLOCK = 1 << 22  # bytes read at a time

_HEX = np.full(256, 255, dtype=np.uint8)
for _i, _c in enumerate(b"0123456789abcdef"):
    _HEX[_c] = _i
for _i, _c in enumerate(b"ABCDEF"):
    _HEX[_c] = 10 + _i
_HEX_OUT = np.frombuffer(b"0123456789ABCDEF", dtype=np.uint8)

_LINE = re.compile(
    r"\s*\(\s*(?P<ts>\d+(?:\.\d*)?)\s*\)\s+(?P<ch>\S+)\s+(?P<id>[0-9A-Fa-f]{1,8})#"
    r"(?P<data>\S*?)(?:\s+(?P<dir>[RTrt]))?\s*"
)

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
        self.channel: str | None = None

    def table(self) -> FrameTable:
        v = self.valid
        return FrameTable(
            timestamp=self.timestamp[v], arbitration_id=self.arbitration_id[v],
            is_extended=self.is_extended[v], is_remote=self.is_remote[v],
            is_error=self.is_error[v], is_fd=self.is_fd[v], dlc=self.dlc[v],
            data=self.data[v], channel=self.channel,
        )


def parse_line(text: str) -> tuple[Any, ...] | str:
    """Parse one candump line (slow path).

    Returns
    -------
    tuple or str
        ``(timestamp, channel, can_id, extended, remote, error, fd, payload)``, or the reason
        the line is damaged.
    """
    m = _LINE.fullmatch(text)
    if m is None:
        return "not a candump -L line '(time) channel id#data'"
    ts = float(m["ts"])
    id_text, data = m["id"], m["data"]
    can_id = int(id_text, 16)
    extended = len(id_text) > 3
    error = extended and bool(can_id & CAN_ERR_FLAG)
    fd = data.startswith("#")
    remote = False
    if fd:
        if len(data) < 2 or _HEX[ord(data[1])] == 255:
            return "CAN FD frame without a flags digit after '##'"
        data = data[2:]
    if data[:1] in ("R", "r") and not fd:
        remote = True
        if len(data) > 1 and not data[1:].isdigit():
            return f"bad remote-frame length {data[1:]!r}"
        payload = bytes(int(data[1:] or 0))
        if len(payload) > 8:
            return f"remote-frame length {len(payload)} > 8"
    else:
        if len(data) % 2:
            return f"odd number of hex digits in payload {data!r} (truncated?)"
        try:
            payload = bytes.fromhex(data)
        except ValueError:
            return f"bad hex in payload {data!r}"
        if len(payload) > (64 if fd else 8):
            return f"payload of {len(payload)} bytes is too long for {'CAN FD' if fd else 'CAN'}"
        if fd and len(payload) not in FD_SIZES:
            return f"{len(payload)} bytes is not a CAN FD payload size"
    if not extended and can_id > 0x7FF:
        return f"standard ID {id_text} > 0x7FF"
    return ts, m["ch"], can_id & CAN_EFF_MASK, extended and not error, remote, error, fd, payload


def _digits_value(mat: npt.NDArray[np.uint8]) -> npt.NDArray[np.float64]:
    """Decimal digit columns to exact integers (float64; exact below 2**53)."""
    w = 10.0 ** np.arange(mat.shape[1] - 1, -1, -1)
    return (mat - np.uint8(48)).astype(np.float64) @ w


def _hex_value(nib: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint32]:
    out = np.zeros(nib.shape[0], dtype=np.uint32)
    for k in range(nib.shape[1]):
        out = (out << np.uint32(4)) | nib[:, k]
    return out


def _layout(line: bytes) -> dict[str, int] | None:
    """Column layout of a well-formed, fixed-width line, or None to use the slow path."""
    m = re.fullmatch(
        rb"\((\d+)(?:\.(\d+))?\) (\S+) ([0-9A-Fa-f]{3}|[0-9A-Fa-f]{8})#(#[0-9A-Fa-f])?"
        rb"((?:[0-9A-Fa-f]{2})*)( [RTrt])?", line)
    if m is None or len(m[1]) + len(m[2] or b"") > 16:
        return None
    fd = m[5] is not None
    nbytes = len(m[6]) // 2
    if nbytes > (64 if fd else 8) or (fd and nbytes not in FD_SIZES):
        return None
    return {
        "int0": m.start(1), "int1": m.end(1),
        "dot": m.start(2) - 1 if m[2] else -1, "frac1": m.end(2) if m[2] else -1,
        "ch0": m.start(3), "ch1": m.end(3), "id0": m.start(4), "id1": m.end(4),
        "fd": int(fd), "flags": m.start(5) + 1 if fd else -1,
        "data0": m.start(6), "nbytes": nbytes, "dir": m.start(7) if m[7] else -1,
    }


def _parse_group(mat: npt.NDArray[np.uint8], lay: dict[str, int], rows: npt.NDArray[np.intp],
                 out: _Chunk) -> npt.NDArray[np.bool_]:
    """Parse the rows of *mat* that follow *lay* into *out*; return which rows did."""
    ok = (mat[:, 0] == ord("(")) & (mat[:, lay["int1"] if lay["dot"] < 0 else lay["frac1"]]
                                      == ord(")"))
    ok &= (mat[:, lay["ch0"] - 1] == ord(" ")) & (mat[:, lay["ch1"]] == ord(" "))
    ok &= mat[:, lay["id1"]] == ord("#")
    int_d = mat[:, lay["int0"]:lay["int1"]]
    ok &= ((int_d - np.uint8(48)) < 10).all(axis=1)
    if lay["dot"] >= 0:
        frac_d = mat[:, lay["dot"] + 1:lay["frac1"]]
        ok &= (mat[:, lay["dot"]] == ord(".")) & ((frac_d - np.uint8(48)) < 10).all(axis=1)
    id_nib = _HEX[mat[:, lay["id0"]:lay["id1"]]]
    ok &= (id_nib != 255).all(axis=1)
    nb = lay["nbytes"]
    d_nib = _HEX[mat[:, lay["data0"]:lay["data0"] + 2 * nb]]
    ok &= (d_nib != 255).all(axis=1)
    if lay["fd"]:
        ok &= (mat[:, lay["flags"] - 1] == ord("#")) & (_HEX[mat[:, lay["flags"]]] != 255)
    if lay["dir"] >= 0:
        ok &= (mat[:, lay["dir"]] == ord(" ")) & np.isin(mat[:, lay["dir"] + 1],
                                                         np.frombuffer(b"RTrt", np.uint8))
    if not ok.all():
        mat, id_nib, d_nib, rows = mat[ok], id_nib[ok], d_nib[ok], rows[ok]
    if lay["dot"] >= 0:
        num = np.concatenate([mat[:, lay["int0"]:lay["int1"]],
                              mat[:, lay["dot"] + 1:lay["frac1"]]], axis=1)
        whole = _digits_value(num)
        scale = 10.0 ** (lay["frac1"] - lay["dot"] - 1)
    else:
        whole = _digits_value(mat[:, lay["int0"]:lay["int1"]])
        scale = 1.0
    exact = whole < 2.0**53  # integers below 2**53 are exact, and so is one division
    if not exact.all():  # leave the others to the slow path (float() of the text)
        ok[np.flatnonzero(ok)[~exact]] = False
        mat, id_nib, d_nib, rows, whole = (mat[exact], id_nib[exact], d_nib[exact],
                                           rows[exact], whole[exact])
    ts = whole / scale
    can_id = _hex_value(id_nib)
    long_id = lay["id1"] - lay["id0"] == 8
    error = (can_id & np.uint32(CAN_ERR_FLAG)) != 0 if long_id else np.zeros(len(rows), bool)
    std_ok = long_id or bool((can_id <= 0x7FF).all())
    if not std_ok:  # 3 hex digits above 0x7FF: leave those rows to the slow path
        keep = can_id <= 0x7FF
        ok[np.flatnonzero(ok)[~keep]] = False
        ts, can_id, d_nib, rows, error = ts[keep], can_id[keep], d_nib[keep], rows[keep], \
            error[keep]
    out.timestamp[rows] = ts
    out.arbitration_id[rows] = can_id & np.uint32(CAN_EFF_MASK)
    out.is_extended[rows] = long_id & ~error
    out.is_error[rows] = error
    out.is_fd[rows] = bool(lay["fd"])
    out.dlc[rows] = nb
    if nb:
        out.data[rows, :nb] = (d_nib[:, 0::2] << np.uint8(4)) | d_nib[:, 1::2]
    out.valid[rows] = True
    return ok


def _parse_block(block: bytes, first_line: int, on_bad: BadLineHandler) -> FrameTable:
    buf = np.frombuffer(block, dtype=np.uint8)
    nl = np.flatnonzero(buf == 10)
    starts = np.concatenate(([0], nl + 1))
    ends = np.concatenate((nl, [len(buf)]))
    if starts[-1] >= len(buf):  # block ends with a newline
        starts, ends = starts[:-1], ends[:-1]
    cr = (ends > starts) & (buf[np.maximum(ends - 1, 0)] == 13)
    ends = ends - cr
    lengths = ends - starts
    width = FD_WIDTH if b"##" in block else CLASSIC_WIDTH
    out = _Chunk(len(starts), width)
    slow = np.zeros(len(starts), dtype=bool)
    windows = np.lib.stride_tricks.sliding_window_view
    for length in np.unique(lengths):
        rows = np.flatnonzero(lengths == length)
        if length == 0:
            continue
        mat = windows(buf, int(length))[starts[rows]]
        lay = _layout(mat[0].tobytes())
        if lay is None:
            slow[rows] = True
            continue
        if out.channel is None:
            out.channel = mat[0, lay["ch0"]:lay["ch1"]].tobytes().decode("ascii", "replace")
        ok = _parse_group(mat, lay, rows, out)
        slow[rows[~ok]] = True
    for i in np.flatnonzero(slow):
        text = block[starts[i]:ends[i]].decode("utf-8", "replace")
        if not text.strip():
            continue
        parsed = parse_line(text)
        if isinstance(parsed, str):
            on_bad(first_line + int(i), parsed)
            continue
        ts, ch, can_id, ext, remote, err, fd, payload = parsed
        if len(payload) > out.data.shape[1]:
            wide = np.zeros((len(out.valid), FD_WIDTH), dtype=np.uint8)
            wide[:, :out.data.shape[1]] = out.data
            out.data = wide
        out.timestamp[i], out.arbitration_id[i] = ts, can_id
        out.is_extended[i], out.is_remote[i], out.is_error[i], out.is_fd[i] = ext, remote, err, fd
        out.dlc[i] = len(payload)
        if not remote:
            out.data[i, :len(payload)] = np.frombuffer(payload, dtype=np.uint8)
        out.valid[i] = True
        if out.channel is None:
            out.channel = ch
    return out.table()


def _open_binary(path: str | os.PathLike[str]) -> IO[bytes]:
    if os.fspath(path).lower().endswith(".gz"):
        return gzip.open(path, "rb")
    return open(path, "rb")  # noqa: SIM115 - closed by the caller


def iter_blocks(stream: IO[bytes], block_size: int = _BLOCK) -> Iterator[tuple[bytes, int]]:
    """Blocks of whole lines of *stream*, with the 1-based number of each block's first line."""
    rest = b""
    line = 1
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
        yield block, line
        line += block.count(b"\n")
    if rest:
        yield rest, line


def read_candump(path: str | os.PathLike[str], on_bad: BadLineHandler,
                 block_size: int = _BLOCK) -> tuple[FrameTable, int]:
    """Read a candump ``-L`` log (plain or gzip).

    Parameters
    ----------
    path : path-like
        The log; a name ending in ``.gz`` is decompressed.
    on_bad : callable
        Called as ``on_bad(line_number, reason)`` for each damaged line (it may raise).
    block_size : int
        Bytes read at a time (memory use grows with it, not with the file).

    Returns
    -------
    frames : FrameTable
        The frames in file order.
    lines : int
        Lines read.
    """
    tables = []
    lines = 0
    with _open_binary(path) as stream:
        for block, first in iter_blocks(stream, block_size):
            tables.append(_parse_block(block, first, on_bad))
            lines = first - 1 + block.count(b"\n") + (0 if block.endswith(b"\n") else 1)
    if not tables:
        return FrameTable.empty(), 0
    table = tables[0] if len(tables) == 1 else FrameTable.concat(tables)
    table.channel = next((t.channel for t in tables if t.channel), None)
    return table, lines


def _format_block(frames: FrameTable, channel: bytes, fd_flags: npt.NDArray[np.uint8]) -> bytes:
    n = len(frames)
    micros = np.round(frames.timestamp * 1e6).astype(np.int64)
    if n and micros.min() < 0:
        raise ValueError("candump logs cannot hold negative timestamps")
    secs, frac = np.divmod(micros, 1_000_000)
    int_digits = np.maximum(np.floor(np.log10(np.maximum(secs, 1))).astype(np.int64) + 1, 1)
    long_id = frames.is_extended | frames.is_error
    dlc = frames.dlc.astype(np.int64)
    fd = frames.is_fd
    data_chars = np.where(frames.is_remote, 1, 2 * dlc) + 2 * fd
    lengths = 1 + int_digits + 8 + 1 + len(channel) + 1 + np.where(long_id, 8, 3) + 1 \
        + data_chars + 1
    offsets = np.concatenate(([0], np.cumsum(lengths)))
    out = np.zeros(int(offsets[-1]), dtype=np.uint8)
    key = np.stack([int_digits, long_id, frames.is_remote, fd, dlc], axis=1)
    groups, inverse = np.unique(key, axis=0, return_inverse=True)
    can_id = np.where(frames.is_error, frames.arbitration_id | CAN_ERR_FLAG,
                      frames.arbitration_id).astype(np.int64)
    for g, (nd, lid, rem, isfd, nb) in enumerate(groups):
        rows = np.flatnonzero(inverse.ravel() == g)
        m = len(rows)
        cols: list[npt.NDArray[np.uint8]] = [np.full((m, 1), ord("("), np.uint8)]
        cols.append(_decimal(secs[rows], int(nd)))
        cols.append(np.full((m, 1), ord("."), np.uint8))
        cols.append(_decimal(frac[rows], 6))
        cols.append(np.frombuffer(b") " + channel + b" ", np.uint8)[None, :].repeat(m, 0))
        cols.append(_HEX_OUT[(can_id[rows, None] >> (4 * np.arange(7 if lid else 2, -1, -1)))
                             & 15])
        cols.append(np.full((m, 1), ord("#"), np.uint8))
        if isfd:
            cols.append(np.full((m, 1), ord("#"), np.uint8))
            cols.append(_HEX_OUT[fd_flags[rows] & 15][:, None])
        if rem:
            cols.append(np.full((m, 1), ord("R"), np.uint8))
        elif nb:
            d = frames.data[rows, :nb]
            hexd = np.empty((m, 2 * nb), np.uint8)
            hexd[:, 0::2] = _HEX_OUT[d >> 4]
            hexd[:, 1::2] = _HEX_OUT[d & 15]
            cols.append(hexd)
        cols.append(np.full((m, 1), ord("\n"), np.uint8))
        mat = np.concatenate(cols, axis=1)
        view = np.lib.stride_tricks.as_strided(out, shape=(len(out) - mat.shape[1] + 1,
                                                            mat.shape[1]), strides=(1, 1))
        view[offsets[rows]] = mat
    return out.tobytes()


def _decimal(values: npt.NDArray[np.int64], digits: int) -> npt.NDArray[np.uint8]:
    p = 10 ** np.arange(digits - 1, -1, -1, dtype=np.int64)
    return ((values[:, None] // p) % 10 + 48).astype(np.uint8)


def write_candump(target: str | os.PathLike[str] | IO[Any], frames: FrameTable,
                  channel: str = "vcan0", *, block_frames: int = 200_000) -> None:
    """Write *frames* as a candump ``-L`` log, vectorised.

    Timestamps are written with 6 decimals (µs), as ``candump -L`` and python-can's
    ``CanutilsLogWriter`` do; ``CanutilsLogReader`` reads the file back frame for frame.

    Parameters
    ----------
    target : path-like or file object
        A path (``.gz`` compresses), or a binary or text file opened for writing.
    frames : FrameTable
        The frames, in the order to write them. Error frames are written with
        ``CAN_ERR_FLAG`` set in the ID. ``frames.extras["fd_flags"]`` (uint8 array), when
        present, gives the CAN FD flag digit.
    channel : str
        Channel name written on every line.
    block_frames : int
        Frames formatted at a time (bounds memory).
    """
    ch = channel.encode("ascii")
    if isinstance(target, (str, os.PathLike)):
        opener = gzip.open if os.fspath(target).lower().endswith(".gz") else open
        with opener(target, "wb") as fh:
            write_candump(fh, frames, channel, block_frames=block_frames)
        return
    text = isinstance(target, io.TextIOBase)
    flags = np.asarray(frames.extras.get("fd_flags", np.zeros(len(frames), np.uint8)),
                       dtype=np.uint8)
    for start in range(0, len(frames), block_frames):
        idx = np.arange(start, min(start + block_frames, len(frames)))
        block = _format_block(frames.take(idx), ch, flags[idx])
        target.write(block.decode("ascii") if text else block)
