"""CAN frames to signals, vectorised, compiled from the DBC's signal definitions.

Two entry points:

``decode_messages(frames, db) -> dict[str, DecodedMessage]``
    Every message of the database found in the frames; each
    :class:`DecodedMessage` holds ``timestamp`` (s), the ``raw`` codes of each signal
    (integers, or floats for IEEE float signals) and gives ``scaled(name)`` (physical value,
    ``raw * scale + offset`` as cantools' ``raw_to_scaled``) and ``choice_names(name)``
    (value-table names). Used by ``evtribo decode``.

``decode_trial(frames, rig) -> TrialSignals``
    The forces of one trial: ``.normal`` and ``.tangential`` (:class:`CellSignals`: ``t`` s,
    ``value`` N, ``counter``, ``dropped`` frames), ``.excitation`` (None, or
    :class:`ExcitationSignals`: ``t``, ``enabled``, ``amplitude`` V, ``frequency`` Hz,
    ``waveform`` names), and the counts ``frames`` (rig frames decoded) and
    ``ignored_frames`` (other IDs, error and remote frames, frames too short, frames of a
    multiplexed message whose multiplexer value the DBC does not know).

How a signal is extracted (:class:`SignalCodec`): Intel (little-endian) and Motorola
(big-endian, DBC "sawtooth" start bit) layouts of any start bit and length up to 64 bits are
assembled from byte columns into a uint64, shifted and masked; with 8-byte payloads a whole
column is read as one uint64 (``'<u8'`` or ``'>u8'``). Signed values are sign-extended;
32- and 64-bit IEEE floats are reinterpreted. Multiplexed messages fall back to cantools'
``decode`` frame by frame; a frame cantools refuses (an unknown multiplexer value) gets NaN
signals and is counted, not fatal. Frames match a message by ID and standard/extended kind; frames
shorter than the message's length are not decoded (cantools refuses them too).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from cantools.database import DecodeError
from cantools.database.can import Database, Message, Signal

from evtribo.dropped import missing_frames
from evtribo.frames.table import FrameTable
from evtribo.rig import Rig, SignalRef

log = logging.getLogger(__name__)

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
        """Physical values, ``raw * scale + offset`` in float64."""
        with np.errstate(invalid="ignore", over="ignore"):  # NaN and inf as cantools gives
            value = raw.astype(np.float64)
            if self.scale != 1:
                value *= self.scale
            if self.offset != 0:
                value += self.offset
        return value

    def decode(self, data: npt.NDArray[np.uint8]) -> Array:
        """Physical values from payload rows."""
        return self.raw_to_scaled(self.raw(data))

    def choice_names(self, raw: npt.NDArray[np.generic]) -> npt.NDArray[np.object_]:
        """Value-table names of raw codes (the code as text where the table lacks it)."""
        table = self.choices or {}
        codes, inverse = np.unique(raw, return_inverse=True)
        names = np.array([table.get(int(c), str(c)) if not self.is_float else str(c)
                          for c in codes], dtype=object)
        return names[inverse.ravel()]


def _col(data: npt.NDArray[np.uint8], k: int) -> npt.NDArray[np.uint64]:
    if k >= data.shape[1]:
        return np.zeros(data.shape[0], dtype=np.uint64)
    return data[:, k].astype(np.uint64)


@dataclass
class DecodedMessage:
    """One message's frames, decoded.

    Attributes
    ----------
    name : str
    frame_id : int
    is_extended : bool
    timestamp : ndarray of float64, s
    index : ndarray of int64
        Row of each decoded frame in the frame table.
    raw : dict of str to ndarray
        Raw code of each signal (NaN where a multiplexed signal is absent).
    codecs : dict of str to SignalCodec
    units : dict of str to str
    undecoded : ndarray of int64
        Rows (in the frame table) of frames cantools refused, such as a multiplexer value
        the DBC does not know; their signals are NaN.
    """

    name: str
    frame_id: int
    is_extended: bool
    timestamp: Array
    index: npt.NDArray[np.int64]
    raw: dict[str, npt.NDArray[np.generic]] = field(default_factory=dict)
    codecs: dict[str, SignalCodec] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    undecoded: npt.NDArray[np.int64] = field(
        default_factory=lambda: np.zeros(0, dtype=np.int64))

    def __len__(self) -> int:
        return int(self.timestamp.shape[0])

    def scaled(self, signal: str) -> Array:
        """Physical values of *signal* (float64, in its DBC unit)."""
        return self.codecs[signal].raw_to_scaled(self.raw[signal])

    def choice_names(self, signal: str) -> npt.NDArray[np.object_]:
        """Value-table names of *signal*'s raw codes."""
        return self.codecs[signal].choice_names(self.raw[signal])

    @property
    def signals(self) -> dict[str, Array]:
        """Every signal's physical values."""
        return {name: self.scaled(name) for name in self.raw}


def message_mask(frames: FrameTable, message: Message) -> npt.NDArray[np.bool_]:
    """Frames carrying *message*: same ID and ID kind, data frames (not error or remote)."""
    return ((frames.arbitration_id == np.uint32(message.frame_id))
            & (frames.is_extended == bool(message.is_extended_frame))
            & ~frames.is_error & ~frames.is_remote)


def decode_message(frames: FrameTable, message: Message, signals: list[str] | None = None,
                   *, mask: npt.NDArray[np.bool_] | None = None) -> DecodedMessage:
    """Decode the frames of one message (all its signals, or those named)."""
    sel = message_mask(frames, message) if mask is None else mask
    full = sel & (frames.dlc >= message.length)
    short = int(np.count_nonzero(sel)) - int(np.count_nonzero(full))
    if short:
        log.warning("%d frames of %s (0x%X) are shorter than its %d bytes: not decoded",
                    short, message.name, message.frame_id, message.length)
    index = np.flatnonzero(full)
    data = frames.data[index]
    wanted = [s for s in message.signals if signals is None or s.name in signals]
    out = DecodedMessage(message.name, message.frame_id, bool(message.is_extended_frame),
                         frames.timestamp[index], index)
    for sig in wanted:
        out.codecs[sig.name] = SignalCodec.from_signal(sig)
        out.units[sig.name] = sig.unit or ""
    if message.is_multiplexed():
        failed, first_error = _decode_multiplexed(message, data, frames.dlc[index], out)
        if failed.size:
            out.undecoded = index[failed]
            log.warning("%d frames of %s (0x%X) could not be decoded (first, frame %d: %s): "
                        "their signals are NaN", failed.size, message.name, message.frame_id,
                        out.undecoded[0], first_error)
    else:
        for name, codec in out.codecs.items():
            out.raw[name] = codec.raw(data)
    return out


def _decode_multiplexed(message: Message, data: npt.NDArray[np.uint8],
                        dlc: npt.NDArray[np.uint8], out: DecodedMessage
                        ) -> tuple[npt.NDArray[np.int64], str]:
    """Decode frame by frame with cantools; return the positions of the frames it refused,
    and cantools' message for the first one."""
    cols = {name: np.full(len(dlc), np.nan) for name in out.codecs}
    failed: list[int] = []
    first_error = ""
    for i in range(len(dlc)):
        try:
            values = message.decode(data[i, :dlc[i]].tobytes(), decode_choices=False,
                                    scaling=False)
        except DecodeError as err:  # a multiplexer value the DBC does not know...
            first_error = first_error or str(err)
            failed.append(i)
            continue
        for name, v in values.items():
            if name in cols:
                cols[name][i] = float(v)
    out.raw.update(cols)
    return np.asarray(failed, dtype=np.int64), first_error


def decode_messages(frames: FrameTable, db: Database, *, messages: list[str] | None = None
                    ) -> dict[str, DecodedMessage]:
    """Decode every message of *db* present in *frames* (or the messages named).

    Returns
    -------
    dict of str to DecodedMessage
        By message name, in DBC order; messages without frames are left out.
    """
    out = {}
    for message in db.messages:
        if messages is not None and message.name not in messages:
            continue
        mask = message_mask(frames, message)
        if mask.any():
            out[message.name] = decode_message(frames, message, mask=mask)
    return out


# --- trials ---------------------------------------------------------------------------------

@dataclass
class CellSignals:
    """One load cell's samples.

    Attributes
    ----------
    t : ndarray of float64, s
        Frame timestamps as logged, in increasing order.
    value : ndarray of float64, N
    counter : ndarray of int64 or None
        The cell's rolling frame counter, when the rig names one.
    dropped : int
        Frames missing, by the counter (wrap-around aware) and by timing gaps.
    dropped_method : str
        How they were counted (:class:`evtribo.dropped.DropCount`'s ``method``).
    dropped_note : str or None
        Why the count may be unreliable.
    """

    t: Array
    value: Array
    counter: npt.NDArray[np.int64] | None
    dropped: int
    dropped_method: str = "counter"
    dropped_note: str | None = None


@dataclass
class ExcitationSignals:
    """The amplifier's status frames (roles the rig does not name are None).

    Attributes
    ----------
    t : ndarray of float64, s
    enabled : ndarray of bool or None
    amplitude : ndarray of float64, V, or None
    frequency : ndarray of float64, Hz, or None
    waveform : ndarray of str (object) or None
        Value-table names (``"sine"``, ``"square"``...).
    """

    t: Array
    enabled: npt.NDArray[np.bool_] | None = None
    amplitude: Array | None = None
    frequency: Array | None = None
    waveform: npt.NDArray[np.object_] | None = None


@dataclass
class TrialSignals:
    """What a trial's log says about the forces and the excitation.

    Attributes
    ----------
    normal, tangential : CellSignals
    excitation : ExcitationSignals or None
        None when the rig names no ``excitation_*`` signal.
    frames : int
        Frames of the rig's messages decoded.
    ignored_frames : int
        Other frames: other IDs, error and remote frames, frames too short, frames
        cantools refuses (a multiplexer value the DBC does not know).
    skipped_lines : int
        Damaged lines skipped while reading (set by the reader's caller).
    """

    normal: CellSignals
    tangential: CellSignals
    excitation: ExcitationSignals | None
    frames: int
    ignored_frames: int
    skipped_lines: int = 0

    @property
    def dropped_frames(self) -> int:
        """Frames missing from both load cells."""
        return self.normal.dropped + self.tangential.dropped


def _decoded_only(msg: DecodedMessage, undecoded: list[npt.NDArray[np.int64]]
                  ) -> DecodedMessage:
    """*msg* without the frames cantools refused (noted in *undecoded*): they are no samples."""
    if not msg.undecoded.size:
        return msg
    undecoded.append(msg.undecoded)
    keep = ~np.isin(msg.index, msg.undecoded)
    return DecodedMessage(msg.name, msg.frame_id, msg.is_extended, msg.timestamp[keep],
                          msg.index[keep], {k: v[keep] for k, v in msg.raw.items()},
                          msg.codecs, msg.units)


def _cell(frames: FrameTable, force: SignalRef, counter: SignalRef | None,
          undecoded: list[npt.NDArray[np.int64]]) -> CellSignals:
    names = [force.signal.name] + ([counter.signal.name] if counter is not None
                                   and counter.message is force.message else [])
    msg = _decoded_only(decode_message(frames, force.message, names), undecoded)
    backwards = np.any(msg.timestamp[1:] < msg.timestamp[:-1])
    order = np.argsort(msg.timestamp, kind="stable") if backwards else None
    t = msg.timestamp if order is None else msg.timestamp[order]
    value = msg.scaled(force.signal.name)
    value = value if order is None else value[order]
    count = None
    modulus = None
    if counter is not None:
        cmsg = msg if counter.message is force.message else decode_message(
            frames, counter.message, [counter.signal.name])
        if cmsg is msg:
            raw = msg.raw[counter.signal.name].astype(np.int64)
            count = raw if order is None else raw[order]
            modulus = 1 << counter.signal.length
        else:
            log.warning("counter %s is not in the force's message %s: timing gaps only",
                        counter.qualified_name, force.message.name)
    found = missing_frames(t, count, modulus)
    return CellSignals(t, value, count, found.count, found.method, found.note)


def _hold(t_src: Array, values: npt.NDArray[np.generic], t: Array) -> npt.NDArray[np.generic]:
    """Values of a stream sampled at *t* by holding the last value (first one before)."""
    idx = np.clip(np.searchsorted(t_src, t, side="right") - 1, 0, max(len(t_src) - 1, 0))
    return values[idx] if len(t_src) else np.zeros(len(t), dtype=values.dtype)


def _excitation(frames: FrameTable, rig: Rig, undecoded: list[npt.NDArray[np.int64]]
                ) -> ExcitationSignals | None:
    roles = {r: ref for r, ref in rig.roles.items() if r.startswith("excitation_")}
    if not roles:
        return None
    by_msg: dict[str, DecodedMessage] = {}
    for ref in roles.values():
        if ref.message.name not in by_msg:
            names = [r.signal.name for r in roles.values() if r.message is ref.message]
            by_msg[ref.message.name] = _decoded_only(
                decode_message(frames, ref.message, names), undecoded)
    base = next(iter(roles.values()))
    t = by_msg[base.message.name].timestamp
    out = ExcitationSignals(t=t)
    for role, ref in roles.items():
        msg = by_msg[ref.message.name]
        name = ref.signal.name
        raw = msg.raw[name]
        if role == "excitation_enabled":
            values: npt.NDArray[np.generic] = raw != 0
        elif role == "excitation_waveform":
            values = msg.choice_names(name)
        else:
            values = msg.scaled(name)
        if msg.name != base.message.name:
            values = _hold(msg.timestamp, values, t)
        setattr(out, role.removeprefix("excitation_"), values)
    return out


def decode_trial(frames: FrameTable, rig: Rig) -> TrialSignals:
    """Decode a trial's frames with *rig*'s roles.

    Parameters
    ----------
    frames : FrameTable
        The trial's log, any order.
    rig : Rig

    Returns
    -------
    TrialSignals
    """
    total = len(frames)
    finite = np.isfinite(frames.timestamp)
    if not finite.all():
        log.warning("%d frames with a timestamp that is not a finite number: not decoded",
                    total - int(np.count_nonzero(finite)))
        frames = frames.take(finite)
    ts = frames.timestamp
    if np.any(ts[1:] < ts[:-1]):  # logs merged or written out of order
        frames = frames.sorted_by_time()
    undecoded: list[npt.NDArray[np.int64]] = []
    # the counter the logger checks too: the rig's role, or a *Counter signal of the cell
    normal = _cell(frames, rig.normal_force, rig.counter("normal"), undecoded)
    tangential = _cell(frames, rig.tangential_force, rig.counter("tangential"), undecoded)
    excitation = _excitation(frames, rig, undecoded)
    decoded = np.zeros(len(frames), dtype=bool)
    for ref in rig.roles.values():
        m = ref.message
        decoded |= message_mask(frames, m) & (frames.dlc >= m.length)
    for rows in undecoded:
        decoded[rows] = False
    n = int(np.count_nonzero(decoded))
    return TrialSignals(normal, tangential, excitation, frames=n,
                        ignored_frames=total - n)


__all__ = ["CellSignals", "DecodedMessage", "ExcitationSignals", "SignalCodec",
           "TrialSignals", "decode_message", "decode_messages", "decode_trial",
           "message_mask"]
