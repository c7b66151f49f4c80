"""Writing candump ``-L`` logs: one frame's field (:func:`frame_field`, for the logger,
which formats one frame at a time) and whole frame tables, vectorised (:func:`write_candump`).

Both write the same text for the same frame, with the same Linux error-frame constants
(which :mod:`evtribo.canlog.io.candump`'s reader uses too).
"""

from __future__ import annotations

import gzip
import io
import os
from typing import IO, Any, cast

import numpy as np
import numpy.typing as npt

from evtribo.canlog.io.ids import id_text
from evtribo.canlog.io.table import FrameTable

#: Linux ``CAN_ERR_FLAG``: set in the identifier of an error frame.
CAN_ERR_FLAG = 0x20000000
#: Linux ``CAN_ERR_BUSERROR``: the error class written when the frame names none.
CAN_ERR_BUSERROR = 0x00000080
#: Mask of a 29-bit identifier.
CAN_EFF_MASK = 0x1FFFFFFF
_HEX_OUT = np.frombuffer(b"0123456789ABCDEF", dtype=np.uint8)


def frame_field(arbitration_id: int, data: bytes, *, is_extended: bool = False,
                is_remote: bool = False, is_error: bool = False, is_fd: bool = False,
                dlc: int | None = None, fd_flags: int = 0) -> str:
    """One frame's ``ID#DATA`` field, candump style (the line without time and channel).

    The one-frame form of what :func:`write_candump` writes for a whole table (the logger
    formats frames one at a time with it): a 3-digit standard or 8-digit extended ID; an
    error frame as ``CAN_ERR_FLAG`` | its class (``CAN_ERR_BUSERROR`` when it has none); a
    remote frame as ``R`` and its length (``123#R4``, ``123#R`` for 0); a CAN FD frame as
    ``ID##<flags digit><data>``.

    Parameters
    ----------
    arbitration_id : int
    data : bytes
        Payload (ignored for a remote frame).
    is_extended, is_remote, is_error, is_fd : bool
    dlc : int, optional
        Requested length of a remote frame, bytes (default ``len(data)``).
    fd_flags : int
        CAN FD flags digit (1 bit-rate switch, 2 error state indicator).

    Returns
    -------
    str
    """
    if is_error:
        can_id = CAN_ERR_FLAG | ((arbitration_id & CAN_EFF_MASK) or CAN_ERR_BUSERROR)
        return f"{can_id:08X}#{bytes(data).hex().upper()}"
    ident = id_text(arbitration_id, is_extended)
    if is_remote:
        length = len(data) if dlc is None else dlc
        return f"{ident}#R{length:X}" if length else f"{ident}#R"
    if is_fd:
        return f"{ident}##{fd_flags & 15:X}{bytes(data).hex().upper()}"
    return f"{ident}#{bytes(data).hex().upper()}"


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
    data_chars = np.where(frames.is_remote, 1 + (dlc > 0), 2 * dlc) + 2 * fd
    lengths = 1 + int_digits + 8 + 1 + len(channel) + 1 + np.where(long_id, 8, 3) + 1 \
        + data_chars + 1
    offsets = np.concatenate(([0], np.cumsum(lengths)))
    out = np.zeros(int(offsets[-1]), dtype=np.uint8)
    key = np.stack([int_digits, long_id, frames.is_remote, fd, dlc], axis=1)
    groups, inverse = np.unique(key, axis=0, return_inverse=True)
    # an error frame without an error class is written as a bus error, as python-can does
    err_class = np.where(frames.arbitration_id == 0, CAN_ERR_BUSERROR, frames.arbitration_id)
    can_id = np.where(frames.is_error, err_class | CAN_ERR_FLAG,
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
        if rem:  # R, then the requested length when there is one (123#R4)
            cols.append(np.full((m, 1), ord("R"), np.uint8))
            if nb:
                cols.append(np.full((m, 1), _HEX_OUT[nb], np.uint8))
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
        # a GzipFile is a binary file, though typeshed does not call it IO[bytes]
        fh = cast("IO[bytes]", gzip.open(target, "wb")) \
            if os.fspath(target).lower().endswith(".gz") else open(target, "wb")
        with fh:
            write_candump(fh, frames, channel, block_frames=block_frames)
        return
    text = isinstance(target, io.TextIOBase)
    flags = np.asarray(frames.extras.get("fd_flags", np.zeros(len(frames), np.uint8)),
                       dtype=np.uint8)
    for start in range(0, len(frames), block_frames):
        idx = np.arange(start, min(start + block_frames, len(frames)))
        block = _format_block(frames.take(idx), ch, flags[idx])
        target.write(block.decode("ascii") if text else block)


__all__ = ["CAN_EFF_MASK", "CAN_ERR_BUSERROR", "CAN_ERR_FLAG", "frame_field",
           "write_candump"]
