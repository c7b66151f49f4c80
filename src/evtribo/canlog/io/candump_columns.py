"""The column parser of candump ``-L`` lines: a block's lines as byte matrices, parsed a
column at a time (see :mod:`evtribo.canlog.io.candump` for how it is used).

Lines of one layout (the same timestamp, channel and identifier columns) are parsed
together: their characters checked and converted column-wise with numpy, hex through one
table lookup per character (which also marks what is not hex), timestamps as exact integers
divided by a power of ten (so the result equals ``float()`` of the text), their digits
checked eight at a time in the same 64-bit words. A row that does not pass is left to the
caller.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from evtribo.canlog.io.candump_line import FD_SIZES
from evtribo.canlog.io.candump_writer import CAN_EFF_MASK, CAN_ERR_FLAG
from evtribo.canlog.io.table import FD_WIDTH, NO_CHANNEL, FrameTable

__all__ = ["line_rows"]

_HEX = np.full(256, 255, dtype=np.uint8)
for _i, _c in enumerate(b"0123456789abcdef"):
    _HEX[_c] = _i
for _i, _c in enumerate(b"ABCDEF"):
    _HEX[_c] = 10 + _i
#: The byte two hex digits spell, indexed by the digits read as one little-endian 16-bit
#: word (first digit in the low byte); -1 where either is not a hex digit.
_FIRST, _SECOND = _HEX[np.arange(1 << 16) & 0xFF], _HEX[np.arange(1 << 16) >> 8]
_HEX_PAIR = np.where((_FIRST < 16) & (_SECOND < 16),
                     16 * _FIRST.astype(np.int16) + _SECOND, -1).astype(np.int16)
del _FIRST, _SECOND

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
        if len(names) > 1 or not len(index):
            # number the channels in order of their first frame; a name whose every line
            # was damaged names none
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


def _digits_value(*parts: npt.NDArray[np.uint8]
                  ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]:
    """Decimal digit columns (at most 16, given as blocks of columns read one after the
    other: a timestamp's whole seconds and its fraction) to exact integers, as float64
    (exact below 2**53), and which rows hold only digits.

    Eight ASCII digits at a time are read as one little-endian uint64 and folded in three
    multiply-shift-mask steps (the "SWAR" trick), instead of a loop over columns; the same
    words are checked at once: a byte is a digit when its high bit is clear, adding 0x46
    leaves it clear (at most ``'9'``) and adding 0x50 sets it (at least ``'0'``); a byte
    with its high bit set makes its row fail whatever the carries.
    """
    n = parts[0].shape[0]
    padded = np.full((n, 16), 48, dtype=np.uint8)
    at = 16 - sum(part.shape[1] for part in parts)
    for part in parts:  # copied into place: no matrix of the blocks joined first
        padded[:, at:at + part.shape[1]] = part
        at += part.shape[1]
    raw = padded.view("<u8")
    high = np.uint64(0x8080808080808080)
    fails = (raw | (raw + np.uint64(0x4646464646464646))
             | ~(raw + np.uint64(0x5050505050505050))) & high
    digits = (fails[:, 0] | fails[:, 1]) == 0
    words = raw - np.uint64(0x3030303030303030)
    words = (words * np.uint64(10) + (words >> np.uint64(8))) & np.uint64(0x00FF00FF00FF00FF)
    words = (words * np.uint64(100) + (words >> np.uint64(16))) & np.uint64(0x0000FFFF0000FFFF)
    words = (words * np.uint64(10000) + (words >> np.uint64(32))) & np.uint64(0xFFFFFFFF)
    return words[:, 0].astype(np.float64) * 1e8 + words[:, 1].astype(np.float64), digits


def _hex_nibbles(chars: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint8]:
    """Values of hex digits, 255 for other characters (one table lookup per character)."""
    return np.take(_HEX, chars)


def _hex_bytes(chars: npt.NDArray[np.uint8]) -> npt.NDArray[np.int16]:
    """The bytes an even number of hex digits per row spell, -1 for a pair that is not two
    hex digits: one lookup per pair (half the lookups of one per digit, and no shifting
    them together: 4.0 -> 2.4 ms for 89 k payloads of 8 bytes)."""
    return np.take(_HEX_PAIR, np.ascontiguousarray(chars).view("<u2"))


def _is_hex(chars: npt.NDArray[np.uint8]) -> npt.NDArray[np.bool_]:
    return ((chars - np.uint8(48)) < 10) | (((chars | np.uint8(0x20)) - np.uint8(97)) < 6)


def _hex_value(nib: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint32]:
    out = np.zeros(nib.shape[0], dtype=np.uint32)
    for k in range(nib.shape[1]):
        out = (out << np.uint32(4)) | nib[:, k]
    return out


def _rows_all(ok: npt.NDArray[np.bool_]) -> npt.NDArray[np.bool_]:
    return ok if ok.ndim == 1 else np.all(ok, axis=1)


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
    """(columns, test) pairs a row of the layout must pass besides its digits and hex
    (:func:`_parse_group` checks those as it reads them): a character or a predicate."""
    close = lay["int1"] if lay["dot"] < 0 else lay["frac1"]
    checks: list[tuple[npt.NDArray[np.uint8], Callable[..., Any] | int]] = [
        (mat[:, 0], ord("(")), (mat[:, close], ord(")")),
        (mat[:, close + 1], ord(" ")), (mat[:, lay["ch1"]], ord(" ")),
        (mat[:, lay["id1"]], ord("#")),
    ]
    if lay["dot"] >= 0:
        checks.append((mat[:, lay["dot"]], ord(".")))
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
        # (a newline too: a row of a block taken as a matrix must not hide one)
        return -1 if not name or b" " in name or b"\n" in name else out.code(name)

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
    rows: Any = slice(None) if rows_in is None else rows_in
    out.widen(lay["nbytes"])
    # each test over the whole matrix, one reduction each; per-row masks only when one fails
    failed: list[npt.NDArray[np.bool_]] = []
    for cols, test in _row_checks(mat, lay):
        passed = cols == test if isinstance(test, int) else test(cols)
        if not passed.all():
            failed.append(_rows_all(passed))
    if lay["dot"] >= 0:
        whole, digits = _digits_value(mat[:, lay["int0"]:lay["int1"]],
                                      mat[:, lay["dot"] + 1:lay["frac1"]])
        scale = 10.0 ** (lay["frac1"] - lay["dot"] - 1)
    else:
        whole, digits = _digits_value(mat[:, lay["int0"]:lay["int1"]])
        scale = 1.0
    if not digits.all():
        failed.append(digits)
    id_nib = _hex_nibbles(mat[:, lay["id0"]:lay["id1"]])
    if id_nib.max(initial=0) > 15:
        failed.append(_rows_all(id_nib < 16))
    nb = lay["nbytes"]
    payload = _hex_bytes(mat[:, lay["data0"]:lay["data0"] + 2 * nb]) if nb else None
    if payload is not None and payload.min(initial=0) < 0:
        failed.append(_rows_all(payload >= 0))
    ok = np.ones(len(mat), dtype=bool)
    if failed:
        for f in failed:
            ok &= f
        rows = np.flatnonzero(ok) if rows_in is None else rows_in[ok]
        mat, whole, id_nib = mat[ok], whole[ok], id_nib[ok]
        if payload is not None:
            payload = payload[ok]
    can_id = _hex_value(id_nib)
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
        if payload is not None:
            payload = payload[keep]
    ts = whole / scale
    if long_id:
        error = (can_id & np.uint32(CAN_ERR_FLAG)) != 0
        out.is_extended[rows] = ~error
        out.is_error[rows] = error
    out.timestamp[rows] = ts
    out.channel_index[rows] = channels
    out.arbitration_id[rows] = can_id & np.uint32(CAN_EFF_MASK)
    out.is_fd[rows] = bool(lay["fd"])
    out.dlc[rows] = nb
    if payload is not None:
        out.data[rows, :nb] = payload
    out.valid[rows] = True
    return ok


def line_rows(buf: npt.NDArray[np.uint8], starts: npt.NDArray[np.intp], width: int
              ) -> npt.NDArray[np.uint8]:
    """The *width* bytes from each of *starts* as the rows of a matrix.

    Parameters
    ----------
    buf : ndarray of uint8
        Holds *width* bytes from the last start.
    starts : ndarray of int
    width : int

    Returns
    -------
    ndarray of uint8, shape (len(starts), width)
        A copy: each row is taken as one item of *width* bytes (a memory copy per row, three
        times faster than indexing a sliding window view byte by byte).
    """
    items = np.ndarray(buffer=buf, dtype=f"V{width}", shape=(len(buf) - width + 1,),
                       strides=(1,))
    return items[starts].view(np.uint8).reshape(len(starts), width)
