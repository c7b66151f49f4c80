"""How one DBC signal is pulled out of payload bytes, vectorised over frames.

:class:`SignalCodec` is compiled from a cantools ``Signal``: Intel (little-endian) and
Motorola (big-endian, DBC "sawtooth" start bit) layouts of any start bit and length up to 64
bits are assembled from byte columns into a uint64, shifted and masked; with 8-byte payloads
a whole column is read as one uint64 (``'<u8'`` or ``'>u8'``). Signed values are
sign-extended; 32- and 64-bit IEEE floats are reinterpreted. ``raw_to_scaled`` is cantools'
``raw * scale + offset``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from cantools.database.can import Signal

from evtribo.warning.collect import emitter

emit = emitter(__name__)

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class SignalCodec:
    """How to pull one signal out of payload bytes.

    Attributes mirror cantools' ``Signal``: ``start`` (DBC start bit), ``length`` (bits),
    ``byte_order`` (``"little_endian"`` or ``"big_endian"``), ``is_signed``, ``is_float``,
    ``scale``, ``offset``, ``choices`` (raw code -> name, or None).
    """

    name: str
    start: int
    length: int
    byte_order: str
    is_signed: bool
    is_float: bool
    scale: float
    offset: float
    choices: dict[int, str] | None = None

    @classmethod
    def from_signal(cls, signal: Signal) -> SignalCodec:
        """Compile a cantools signal."""
        choices = None
        if signal.choices:
            choices = {int(k): str(v) for k, v in signal.choices.items()}
        return cls(signal.name, signal.start, signal.length, signal.byte_order,
                   bool(signal.is_signed), bool(signal.is_float), signal.scale, signal.offset,
                   choices)

    def _lsb_shift_be(self) -> tuple[int, int]:
        """Motorola: (first byte, big-endian bit position of the MSB)."""
        p = (self.start // 8) * 8 + (7 - self.start % 8)
        return p // 8, p

    def _unsigned(self, data: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint64]:
        n, width = data.shape
        length = self.length
        mask = np.uint64((1 << length) - 1)
        if self.byte_order == "little_endian":
            first, shift = divmod(self.start, 8)
            nbytes = (shift + length + 7) // 8
            if width == 8 and first + nbytes <= 8:
                word = np.ascontiguousarray(data).view("<u8")[:, 0]
                return (word >> np.uint64(self.start)) & mask
            acc = np.zeros(n, dtype=np.uint64)
            for k in range(min(nbytes, 8)):
                acc |= _col(data, first + k) << np.uint64(8 * k)
            acc >>= np.uint64(shift)
            if nbytes == 9:
                acc |= _col(data, first + 8) << np.uint64(64 - shift)
            return acc & mask
        first, p = self._lsb_shift_be()
        last = (p + length - 1) // 8
        tail = 8 * (last + 1) - (p + length)  # bits after the LSB in the last byte
        if width == 8 and last < 8:
            word = np.ascontiguousarray(data).view(">u8")[:, 0]
            return (word >> np.uint64(64 - p - length)) & mask
        nbytes = last - first + 1
        lo = max(first, last - 7)
        acc = np.zeros(n, dtype=np.uint64)
        for b in range(lo, last + 1):
            acc |= _col(data, b) << np.uint64(8 * (last - b))
        acc >>= np.uint64(tail)
        if nbytes == 9:
            acc |= _col(data, first) << np.uint64(64 - tail)
        return acc & mask

    def raw(self, data: npt.NDArray[np.uint8]) -> npt.NDArray[np.generic]:
        """Raw values from payload rows ``(n, width)``: int64 (signed), uint64 or float64."""
        u = self._unsigned(data)
        if self.is_float:
            if self.length == 32:
                with np.errstate(invalid="ignore"):  # signalling NaNs stay NaN
                    return u.astype(np.uint32).view(np.float32).astype(np.float64)
            if self.length == 64:
                return u.view(np.float64)
            raise ValueError(f"signal {self.name}: float of {self.length} bits")
        if self.is_signed:
            if self.length == 64:
                return u.view(np.int64)
            v = u.astype(np.int64)
            v -= (v & np.int64(1 << (self.length - 1))) << np.int64(1)
            return v
        return u

    def raw_to_scaled(self, raw: npt.NDArray[np.generic]) -> Array:
        """Physical values, ``raw * scale + offset`` in float64 (:func:`scaled`)."""
        return scaled(raw, self.scale, self.offset)

    def decode(self, data: npt.NDArray[np.uint8]) -> Array:
        """Physical values from payload rows."""
        return self.raw_to_scaled(self.raw(data))

    def choice_names(self, raw: npt.NDArray[np.generic]) -> npt.NDArray[np.object_]:
        """Value-table names of raw codes, as cantools' ``decode_choices`` gives them: where
        the table lacks a code, its physical value as text (``raw * scale + offset`` in
        Python's arithmetic, as cantools computes it); None where there is no code (a
        multiplexed signal absent from a frame)."""
        table = self.choices or {}
        codes, inverse = np.unique(raw, return_inverse=True)
        names = np.array([self._choice_name(c, table) for c in codes.tolist()], dtype=object)
        return names[inverse.ravel()]

    def _choice_name(self, code: float, table: dict[int, str]) -> str | None:
        if code != code:  # noqa: PLR0124 - NaN: no code in this frame
            return None
        value = code if self.is_float else int(code)
        if float(value).is_integer() and int(value) in table:
            return table[int(value)]
        return str(value * self.scale + self.offset)

    def last_byte(self) -> int:
        """The payload byte (from 0) that holds the signal's last bit: a frame must be
        longer than it to carry the signal."""
        if self.byte_order == "little_endian":
            return (self.start + self.length - 1) // 8
        return (self._lsb_shift_be()[1] + self.length - 1) // 8


def _col(data: npt.NDArray[np.uint8], k: int) -> npt.NDArray[np.uint64]:
    if k >= data.shape[1]:
        return np.zeros(data.shape[0], dtype=np.uint64)
    return data[:, k].astype(np.uint64)


def scaled(raw: npt.NDArray[np.generic], scale: float, offset: float) -> Array:
    """Physical values of raw codes, ``raw * scale + offset`` in float64, as every signal is
    decoded (and as the cache gives back the forces it keeps as codes).

    Parameters
    ----------
    raw : ndarray
        Raw codes (integers, or a float signal's values).
    scale, offset : float

    Returns
    -------
    ndarray of float64
    """
    with np.errstate(invalid="ignore", over="ignore"):  # NaN and inf as cantools gives
        value = raw.astype(np.float64)
        if scale != 1:
            value *= scale
        if offset != 0:
            value += offset
    return value


#: Largest share of a signal's samples outside its declared range that are taken for bad
#: samples; more, and the range is taken for wrong (the samples are kept, and it is said).
MAX_OUT_OF_RANGE = 0.01


def bad_samples(t: Array, values: Array, signal: Signal, t0: float, name: str
                ) -> npt.NDArray[np.bool_]:
    """The samples of a signal no sensor gives: no number (infinite, or NaN where every
    frame carries the signal: a multiplexed one's NaN are frames without it), or outside the
    DBC's declared ``[minimum|maximum]`` (by more than half a scale step; a float node's
    3.4e38 "no reading"), said (``samples-bad``, or ``samples-range-wrong`` where most miss
    the range).

    Outside the range, the samples are bad only while they are few (at most
    :data:`MAX_OUT_OF_RANGE` of them: spikes); where more miss it, the range is wrong for
    the sensor, and they are kept.

    Parameters
    ----------
    t : ndarray of float, s
        The samples' times.
    values : ndarray of float
        The samples, in the signal's unit.
    signal : cantools.database.can.Signal
        The signal.
    t0 : float, s
        The trial's start, for the time said.
    name : str
        The signal as the sentence names it (``FzCell.Fz``).

    Returns
    -------
    ndarray of bool
        The samples to leave out.
    """
    with np.errstate(invalid="ignore"):
        # NaN where a multiplexed signal is not in a frame: no sample, not a bad one
        bad = np.isinf(values) if signal.multiplexer_ids else ~np.isfinite(values)
        lo, hi = signal.minimum, signal.maximum
        step = abs(float(signal.scale)) / 2 if not signal.is_float else 0.0
        outside = np.zeros(values.size, dtype=bool)
        if lo is not None:
            outside |= values < float(lo) - step
        if hi is not None:
            outside |= values > float(hi) + step
    unit = f" {signal.unit}" if signal.unit else ""
    declared = f"[{lo}, {hi}]{unit}"
    share = np.count_nonzero(outside) / max(values.size, 1)
    if share > MAX_OUT_OF_RANGE:
        emit("samples-range-wrong", share=float(share), signal=name, range=declared)
        return bad
    bad |= outside
    if bad.any():
        k = int(np.argmax(bad))
        emit("samples-bad", samples=int(bad.sum()), signal=name, range=declared,
             at_s=float(t[k] - t0), value=float(values[k]))
    return bad


__all__ = ["MAX_OUT_OF_RANGE", "SignalCodec", "bad_samples", "scaled"]
