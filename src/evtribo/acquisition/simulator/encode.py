"""Physical values to CAN payloads, vectorised.

The packer reads the signal layout from a cantools message (start bit, length, byte order,
sign, scale and offset) and packs whole columns at once with 64-bit integer arithmetic, so a
trial of 100,000 frames is encoded in a few milliseconds. cantools decodes the result back.
"""

from __future__ import annotations

from collections.abc import Mapping

import cantools.database
import numpy as np
import numpy.typing as npt

__all__ = ["pack_signals", "scaled_to_raw"]


def scaled_to_raw(signal: cantools.database.can.Signal,
                  value: npt.ArrayLike) -> npt.NDArray[np.int64]:
    """Physical values to raw integers of *signal*, rounded and clipped to its bit range.

    Parameters
    ----------
    signal : cantools Signal
        The DBC signal (integer signals only).
    value : array_like
        Physical values, in the signal's unit.

    Returns
    -------
    ndarray of int64
        Raw values; out-of-range values saturate, as an ADC does.
    """
    if signal.is_float:
        raise ValueError(f"signal {signal.name!r}: float signals are not supported")
    raw = np.rint((np.asarray(value, dtype=np.float64) - signal.offset) / signal.scale)
    if signal.is_signed:
        lo, hi = -(1 << (signal.length - 1)), (1 << (signal.length - 1)) - 1
    else:
        lo, hi = 0, (1 << signal.length) - 1
    return np.clip(raw, lo, hi).astype(np.int64)


def _big_endian_shift(start: int, length: int) -> int:
    """Left shift of a Motorola signal's LSB in the payload read as a big-endian uint64."""
    msb = 8 * (start // 8) + (7 - start % 8)  # position counted from byte 0's MSB
    return 64 - (msb + length)


def pack_signals(message: cantools.database.can.Message,
                 values: Mapping[str, npt.ArrayLike], n: int) -> npt.NDArray[np.uint8]:
    """Encode *n* frames of *message* at once.

    Parameters
    ----------
    message : cantools Message
        The DBC message (classic CAN, up to 8 bytes).
    values : mapping of str to array_like
        Physical value of each signal, scalar or of length *n*; signals not given are 0
        (raw), ``*_raw`` keys are taken as raw integers.
    n : int
        Number of frames.

    Returns
    -------
    ndarray of uint8, shape (n, 8)
        Payloads, zero past the message's length.
    """
    little = np.zeros(n, dtype=np.uint64)
    big = np.zeros(n, dtype=np.uint64)
    for signal in message.signals:
        if signal.name in values:
            raw = scaled_to_raw(signal, np.broadcast_to(values[signal.name], (n,)))
        elif signal.name + "_raw" in values:
            raw = np.broadcast_to(np.asarray(values[signal.name + "_raw"], dtype=np.int64), (n,))
        else:
            continue
        mask = np.uint64((1 << signal.length) - 1)
        bits = raw.astype(np.uint64) & mask  # two's complement for negative values
        if signal.byte_order == "little_endian":
            little |= bits << np.uint64(signal.start)
        else:
            big |= bits << np.uint64(_big_endian_shift(signal.start, signal.length))
    out = little.astype("<u8").view(np.uint8).reshape(n, 8).copy()
    out |= big.astype(">u8").view(np.uint8).reshape(n, 8)
    out[:, message.length:] = 0
    return out
