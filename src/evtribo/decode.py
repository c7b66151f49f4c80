"""CAN frames to signals, vectorised, compiled from the DBC's signal definitions.

Two entry points:

``decode_messages(frames, db) -> dict[str, DecodedMessage]``
    Every message of the database found in the frames; each
    :class:`DecodedMessage` holds ``timestamp`` (s), the ``raw`` codes of each signal
    (integers, or floats for IEEE float signals) and gives ``scaled(name)`` (physical value,
    ``raw * scale + offset`` as cantools' ``raw_to_scaled``) and ``choice_names(name)``
    (value-table names). Used by ``evtribo decode``.

``decode_trial(frames, rig, channel=None) -> TrialSignals``
    The forces of one trial: ``.normal`` and ``.tangential`` (:class:`CellSignals`: ``t`` s,
    ``value`` N, ``counter``, ``dropped`` frames), ``.excitation`` (None, or
    :class:`ExcitationSignals`: ``t``, ``enabled``, ``amplitude`` V, ``frequency`` Hz,
    ``waveform`` names), and the counts ``frames`` (rig frames decoded) and
    ``ignored_frames`` (other IDs, other channels, error and remote frames, CAN XL frames,
    frames too short, frames of a multiplexed message whose multiplexer value the DBC does
    not know). The rig's frames come from one channel (bus): the one named, else the one
    carrying most of them, with a warning when the rig's IDs arrive on several (the same ID
    on two buses is two streams, never merged).

How a signal is extracted: :class:`~evtribo.signal_codec.SignalCodec` (any byte order,
start bit, length up to 64 bits, sign, IEEE float), vectorised over frames. Multiplexed
messages fall back to cantools' ``decode`` frame by frame; a frame cantools refuses (an
unknown multiplexer value) gets NaN signals and is counted, not fatal. Frames match a
message by ID and standard/extended kind (a standard 0x0C1 frame is not the extended message
0x000000C1: such frames are not decoded, and a warning says so); frames shorter than the
message's length are not decoded (cantools refuses them too).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from cantools.database import DecodeError
from cantools.database.can import Database, Message

from evtribo.dropped import missing_frames_received
from evtribo.errors import UserInputError
from evtribo.frames.table import FrameTable
from evtribo.rig import Rig, SignalRef
from evtribo.signal_codec import SignalCodec

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]


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
    wanted = [m for m in db.messages if messages is None or m.name in messages]
    for text in kind_mismatches(frames, wanted, db):
        log.warning("%s", text)
    for message in wanted:
        mask = message_mask(frames, message)
        if mask.any():
            out[message.name] = decode_message(frames, message, mask=mask)
    return out


def _id_text(frame_id: int, extended: bool) -> str:
    kind = "extended (29-bit)" if extended else "standard (11-bit)"
    return f"{kind} ID 0x{frame_id:08X}" if extended else f"{kind} ID 0x{frame_id:03X}"


def kind_mismatches(frames: FrameTable, messages: list[Message], db: Database) -> list[str]:
    """Why frames whose ID number is one of *messages*' but of the other kind (standard
    or extended) are not decoded as it: one sentence per message, when *db* has no message
    of that number and kind."""
    known = {(m.frame_id, bool(m.is_extended_frame)) for m in db.messages}
    data = ~frames.is_error & ~frames.is_remote
    ids: dict[bool, npt.NDArray[np.uint32]] = {}  # IDs of the data frames of each kind
    out = []
    for m in messages:
        ext = bool(m.is_extended_frame)
        other = not ext
        if (m.frame_id, other) in known:
            continue
        if other not in ids:
            kind = frames.is_extended if other else ~frames.is_extended
            ids[other] = frames.arbitration_id[kind & data]
        n = int(np.count_nonzero(ids[other] == np.uint32(m.frame_id)))
        if n:
            out.append(f"{n} frames have the {_id_text(m.frame_id, other)}, but the DBC's "
                       f"message {m.name} has the {_id_text(m.frame_id, ext)}: not decoded as "
                       f"{m.name} (the kind of ID is part of it)")
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
        Other frames: other IDs, other channels, error and remote frames, CAN XL frames,
        frames too short, frames cantools refuses (a multiplexer value the DBC does not know).
    skipped_lines : int
        Damaged lines skipped while reading (set by the reader's caller).
    channel : str or None
        The channel the rig's frames were decoded from (None: the log names none).
    logger_dropped : int
        Frames the recording tool said it dropped on that channel (candump's ``DROPCOUNT``
        notices): frames of any ID, lost before they were logged.
    warnings : list of str
        What the decoder found worth saying about this trial (the rig's IDs on several
        channels, frames whose kind of ID is not the DBC's).
    """

    normal: CellSignals
    tangential: CellSignals
    excitation: ExcitationSignals | None
    frames: int
    ignored_frames: int
    skipped_lines: int = 0
    channel: str | None = None
    logger_dropped: int = 0
    warnings: list[str] = field(default_factory=list)

    @property
    def dropped_frames(self) -> int:
        """Frames lost: those missing from both load cells (counters, timing), or those the
        recording tool said it dropped when it says more (a frame it dropped is also missing
        from its cell's counter: the two counts overlap, so the larger is taken, not the
        sum)."""
        return max(self.normal.dropped + self.tangential.dropped, self.logger_dropped)


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


def _in_time_order(msg: DecodedMessage) -> DecodedMessage:
    """*msg* with its frames sorted by time (stable: frames stamped alike keep their order)."""
    ts = msg.timestamp
    if not np.any(ts[1:] < ts[:-1]):
        return msg
    order = np.argsort(ts, kind="stable")
    return DecodedMessage(msg.name, msg.frame_id, msg.is_extended, ts[order], msg.index[order],
                          {k: v[order] for k, v in msg.raw.items()}, msg.codecs, msg.units)


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
    count = received = None
    modulus = None
    if counter is not None:
        cmsg = msg if counter.message is force.message else decode_message(
            frames, counter.message, [counter.signal.name])
        if cmsg is msg:
            received = msg.raw[counter.signal.name].astype(np.int64)
            count = received if order is None else received[order]
            modulus = 1 << counter.signal.length
        else:
            log.warning("counter %s is not in the force's message %s: timing gaps only",
                        counter.qualified_name, force.message.name)
    # counted in the order the frames came in: a clock that jumped back must not make the
    # frames from before and after the jump look like gaps in each other
    found = missing_frames_received(msg.timestamp, received, modulus)
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
            by_msg[ref.message.name] = _in_time_order(_decoded_only(
                decode_message(frames, ref.message, names), undecoded))
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


def _rig_messages(rig: Rig) -> list[Message]:
    """The messages of the rig's roles, each once."""
    return list({id(r.message): r.message for r in rig.roles.values()}.values())


def _rig_mask(frames: FrameTable, rig: Rig) -> npt.NDArray[np.bool_]:
    mask = np.zeros(len(frames), dtype=bool)
    for m in _rig_messages(rig):
        mask |= message_mask(frames, m)
    return mask


def _rig_channel(frames: FrameTable, rig: Rig, channel: str | None, warnings: list[str]
                 ) -> tuple[FrameTable, str | None]:
    """The frames of the channel the rig is decoded from, and its name."""
    if channel is not None and channel not in frames.channel_names:
        have = ", ".join(frames.channel_names) or "none (its format names no channel)"
        raise UserInputError(f"the log has no channel {channel!r}; its channels: {have}",
                             key="channel")
    if len(frames.channel_names) <= 1 and channel is None:
        return frames, frames.channel
    counts = frames.channel_counts(_rig_mask(frames, rig))
    chosen = channel if channel is not None else (
        max(counts, key=lambda k: counts[k]) if counts else frames.channel)
    if len(counts) > 1:
        shared = [m.name for m in _rig_messages(rig)
                  if len(frames.channel_counts(message_mask(frames, m))) > 1]
        text = ("the rig's messages arrive on several channels ("
                + ", ".join(f"{k}: {v} frames" for k, v in counts.items()) + ")"
                + (f", {', '.join(shared)} on more than one" if shared else "")
                + f": decoded from {chosen}"
                + (" (the channel carrying most of them)" if channel is None else "")
                + "; the others are ignored, never merged (choose with channel=...)")
        log.warning("%s", text)
        warnings.append(text)
    return frames.take(frames.on_channel(chosen)), chosen


def decode_trial(frames: FrameTable, rig: Rig, *, channel: str | None = None
                 ) -> TrialSignals:
    """Decode a trial's frames with *rig*'s roles.

    Parameters
    ----------
    frames : FrameTable
        The trial's log, any order.
    rig : Rig
    channel : str, optional
        The channel (bus) to decode the rig's frames from. Default: the one that carries
        most of the rig's frames (a warning names the others when there are several).

    Returns
    -------
    TrialSignals

    Raises
    ------
    UserInputError
        *channel* is not one of the log's channels.
    """
    total = len(frames) + frames.xl_frames
    warnings: list[str] = []
    frames, chosen = _rig_channel(frames, rig, channel, warnings)
    for text in kind_mismatches(frames, _rig_messages(rig), rig.database):
        log.warning("%s", text)
        warnings.append(text)
    drops = frames.reported_drops
    logger_dropped = (sum(drops.values()) if chosen is None or len(frames.channel_names) <= 1
                      else drops.get(chosen, 0))
    finite = np.isfinite(frames.timestamp)
    if not finite.all():
        log.warning("%d frames with a timestamp that is not a finite number: not decoded",
                    len(frames) - int(np.count_nonzero(finite)))
        frames = frames.take(finite)
    # logs merged or written out of order, clocks that jumped: each stream is put in time
    # order on its own, after its lost frames are counted in the order they came in
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
    return TrialSignals(normal, tangential, excitation, frames=n, ignored_frames=total - n,
                        channel=chosen, logger_dropped=logger_dropped, warnings=warnings)


__all__ = ["CellSignals", "DecodedMessage", "ExcitationSignals", "SignalCodec",
           "TrialSignals", "decode_message", "decode_messages", "decode_trial",
           "kind_mismatches", "message_mask"]
