"""CAN frames to signals, vectorised, compiled from the DBC's signal definitions.

Two entry points:

``decode_messages(frames, db) -> dict[str, DecodedMessage]``
    Every message of the database found in the frames; each :class:`DecodedMessage` holds
    ``timestamp`` (s), the ``raw`` codes of each signal (integers, or floats for IEEE float
    signals) and gives ``scaled(name)`` (physical value, ``raw * scale + offset`` as
    cantools' ``raw_to_scaled``) and ``choice_names(name)`` (value-table names). Used by
    ``evtribo decode``.

``decode_trial(frames, rig, channel=None) -> TrialSignals``
    The forces of one trial (:mod:`evtribo.canlog.signals`, the analysis's input): the two load
    cells, the excitation (waveforms named by the DBC's value table, else
    :data:`FALLBACK_WAVEFORMS` with a warning), and the counts of frames decoded and ignored
    (other IDs, other channels, error, remote and CAN XL frames, frames too short, unknown
    multiplexer values). Each cell's frames are put in the order sent first
    (:mod:`evtribo.canlog.sequence`: duplicates dropped, late frames put back, counter
    restarts and the logger's clock steps taken out). The rig's frames come from one channel
    (bus): the one named, else the one carrying most of them, with a warning when the rig's
    IDs arrive on several (the same ID on two buses is two streams, never merged).

How a signal is extracted: :class:`~evtribo.canlog.signal_codec.SignalCodec` (any byte order,
start bit, length up to 64 bits, sign, IEEE float), vectorised over frames. Multiplexed
messages fall back to cantools' ``decode`` frame by frame; a frame cantools refuses (an
unknown multiplexer value) gets NaN signals and is counted, not fatal. Frames match a
message by ID, standard/extended kind and CAN FD or classic kind (a standard 0x0C1 frame is
not the extended message 0x000000C1, a CAN FD frame on 0x0C1 not the classic message 0x0C1:
such frames are not decoded, and a warning says so); frames shorter than the message's
length are not decoded (cantools refuses them too).

What it replaces: cantools' ``Database.decode_message``, called once per frame (one Python
dict per frame); it stays the reference: ``tests/canlog/test_decode_conformance.py`` decodes
random frames of every message of cantools' own test DBCs both ways and requires the same
values, and multiplexed messages are decoded by cantools itself.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
from cantools.database import DecodeError
from cantools.database.can import Database, Message

from evtribo.canlog import sequence
from evtribo.canlog.counters.streams import CellFrames, CounterSignal, count_cells
from evtribo.canlog.frame_match import kind_mismatches, message_mask, rig_channel, rig_messages
from evtribo.canlog.io.table import IMPOSSIBLE_TIMESTAMP, FrameTable, take_rows
from evtribo.canlog.rig import Rig, SignalRef
from evtribo.canlog.signal_codec import SignalCodec, bad_samples
from evtribo.canlog.signals import (
    FALLBACK_WAVEFORMS,
    CellSignals,
    ExcitationSignals,
    TrialProvenance,
    TrialSignals,
)
from evtribo.warning.catalogue import kind
from evtribo.warning.collect import collecting, emitter
from evtribo.warning.record import Note, WarningRecord

emit = emitter(__name__)

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
    undecoded_reason : str
        cantools' reason for the first of them.
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
    undecoded_reason: str = ""

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


def decode_message(frames: FrameTable, message: Message, signals: list[str] | None = None,
                   *, mask: npt.NDArray[np.bool_] | None = None, quiet: bool = False
                   ) -> DecodedMessage:
    """Decode the frames of one message (all its signals, or those named).

    Parameters
    ----------
    frames : FrameTable
        The log's frames.
    message : cantools.database.can.Message
        The message.
    signals : list of str, optional
        The signals to decode (default: all).
    mask : ndarray of bool, optional
        The frames of the message, when already known (:func:`message_mask`).
    quiet : bool
        No warning on short or refused frames (a caller that counts them over blocks).

    Returns
    -------
    DecodedMessage
        Frames shorter than the message are left out (with a warning).
    """
    sel = message_mask(frames, message) if mask is None else mask
    full = sel & (frames.dlc >= message.length)
    short = int(np.count_nonzero(sel)) - int(np.count_nonzero(full))
    if short and not quiet:
        emit("frames-short", frames=short, message=message.name, frame_id=message.frame_id,
             length=message.length)
    index = np.flatnonzero(full)
    data = take_rows(frames.data, index)
    wanted = [s for s in message.signals if signals is None or s.name in signals]
    out = DecodedMessage(message.name, message.frame_id, bool(message.is_extended_frame),
                         frames.timestamp[index], index)
    for sig in wanted:
        out.codecs[sig.name] = SignalCodec.from_signal(sig)
        out.units[sig.name] = sig.unit or ""
    beyond = beyond_length(message)
    if beyond:  # cantools decodes none of its frames: neither does evtribo
        out.raw = {name: np.full(index.size, np.nan) for name in out.codecs}
        out.undecoded, out.undecoded_reason = index, beyond
        if index.size and not quiet:
            emit("frames-undecoded", frames=int(index.size), message=message.name,
                 frame_id=message.frame_id, reason=beyond)
    elif message.is_multiplexed():
        failed, out.undecoded_reason = _decode_multiplexed(message, data, frames.dlc[index], out)
        out.undecoded = index[failed]
        if failed.size and not quiet:
            emit("frames-decode-failed", frames=int(failed.size), message=message.name,
                 frame_id=message.frame_id, first=int(out.undecoded[0]),
                 reason=out.undecoded_reason)
    else:
        for name, codec in out.codecs.items():
            out.raw[name] = codec.raw(data)
    return out


def beyond_length(message: Message) -> str:
    """Why no frame of *message* can be decoded, when one of its signals lies beyond its
    length (cantools refuses every such frame), else ``""``.

    Parameters
    ----------
    message : cantools.database.can.Message

    Returns
    -------
    str
    """
    for sig in message.signals:
        last = SignalCodec.from_signal(sig).last_byte()
        if last >= message.length:
            return (f"its signal {sig.name} ends in byte {last + 1}, beyond the message's "
                    f"{message.length} bytes (cantools decodes none of its frames): fix the "
                    "DBC")
    return ""


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
        if not isinstance(values, dict):  # a container message's parts: no rig signal
            continue
        for name, v in values.items():
            if name in cols and isinstance(v, int | float):
                cols[name][i] = float(v)
    out.raw.update(cols)
    return np.asarray(failed, dtype=np.int64), first_error


def decode_messages(frames: FrameTable, db: Database, *, messages: list[str] | None = None
                    ) -> dict[str, DecodedMessage]:
    """Decode every message of *db* present in *frames* (or the messages named).

    Parameters
    ----------
    frames : FrameTable
        The log's frames.
    db : cantools.database.can.Database
        The DBC.
    messages : list of str, optional
        Names of the messages to decode (default: all).

    Returns
    -------
    dict of str to DecodedMessage
        By message name, in DBC order; messages without frames are left out.
    """
    out = {}
    wanted = [m for m in db.messages if messages is None or m.name in messages]
    kind_mismatches(frames, wanted, db)
    for message in wanted:
        mask = message_mask(frames, message)
        if mask.any():
            out[message.name] = decode_message(frames, message, mask=mask)
    return out


def _rows(msg: DecodedMessage, sel: npt.NDArray[Any]) -> DecodedMessage:
    """*msg*'s frames selected by *sel* (a mask or an order)."""
    return DecodedMessage(msg.name, msg.frame_id, msg.is_extended, msg.timestamp[sel],
                          msg.index[sel], {k: v[sel] for k, v in msg.raw.items()}, msg.codecs,
                          msg.units)


def _decoded_only(msg: DecodedMessage, undecoded: list[npt.NDArray[np.int64]]
                  ) -> DecodedMessage:
    """*msg* without the frames cantools refused (noted in *undecoded*): they are no samples."""
    if not msg.undecoded.size:
        return msg
    undecoded.append(msg.undecoded)
    return _rows(msg, ~np.isin(msg.index, msg.undecoded))


def _in_time_order(msg: DecodedMessage) -> DecodedMessage:
    """*msg* with its frames sorted by time (stable: frames stamped alike keep their order)."""
    ts = msg.timestamp
    return _rows(msg, np.argsort(ts, kind="stable")) if np.any(ts[1:] < ts[:-1]) else msg


def _cell_frames(frames: FrameTable, force: SignalRef, counter: SignalRef | None,
                 undecoded: list[npt.NDArray[np.int64]], *, cell: str, declared: int | None
                 ) -> tuple[DecodedMessage, CellFrames]:
    """One load cell's frames decoded, and as :func:`~evtribo.canlog.counters.streams.count_cells`
    counts them (its counter with its law's width, declared period and names)."""
    names = [force.signal.name] + ([counter.signal.name] if counter is not None
                                   and counter.message is force.message else [])
    msg = _decoded_only(decode_message(frames, force.message, names), undecoded)
    raw = spec = None
    if counter is not None and counter.message is force.message:
        raw = msg.raw[counter.signal.name].astype(np.int64)
        spec = CounterSignal(counter.signal.length, declared, counter.qualified_name,
                             f"{cell}_force_counter_period")
    elif counter is not None:
        emit("counter-elsewhere", counter=counter.qualified_name, message=force.message.name)
    return msg, CellFrames(msg.index, raw, take_rows(frames.data, msg.index), spec)


def _cells(frames: FrameTable, rig: Rig, undecoded: list[npt.NDArray[np.int64]]
           ) -> tuple[FrameTable, list[CellSignals]]:
    """The two load cells in time order and the frames missing from each (counted in the
    order sent, duplicates left out: :func:`~evtribo.canlog.counters.streams.count_cells`,
    as the recorder counts them), once the logger's clock steps are taken out of the whole
    log (the amplifier's frames with them); what was put right is said."""
    roles = [(rig.normal_force, rig.counter("normal"), "normal"),
             (rig.tangential_force, rig.counter("tangential"), "tangential")]
    decoded = [_cell_frames(frames, force, counter, undecoded, cell=cell,
                            declared=rig.counter_period(cell))
               for force, counter, cell in roles]
    times, counts, steps = count_cells(frames.timestamp, [c for _, c in decoded])
    msgs = [m for m, _ in decoded]
    if steps:
        frames = dataclasses.replace(frames, timestamp=times)
        msgs = [dataclasses.replace(m, timestamp=times[m.index]) for m in msgs]
    for c in counts:
        if c.law is not None and c.law.note is not None:
            emit(c.law.note.kind, **c.law.note.mapping)
    t0 = min((float(m.timestamp.min()) for m in msgs if len(m)), default=0.0)
    named = [(f.message.name, None if c is None else c.qualified_name, n.seq)
             for (f, c, _), n in zip(roles, counts, strict=True)]
    sequence.say(steps, named, t0)
    out = []
    for msg, n, (force, _, _) in zip(msgs, counts, roles, strict=True):
        seq, found = n.seq, n.found  # bad samples counted too
        t, value = seq.t[seq.by_time], msg.scaled(force.signal.name)[seq.rows[seq.by_time]]
        bad = bad_samples(t, value, force.signal, t0, force.qualified_name)
        out.append(CellSignals(t[~bad], value[~bad], seq.counter[seq.by_time][~bad]
                               if n.counted and seq.counter is not None else None,
                               found.count, found.method, seq.duplicates,
                               counter_period=n.modulus if n.counted else None))
    for n, (_, _, cell) in zip(counts, roles, strict=True):
        say_lost(cell, n.found.notes)
    return frames, out


def say_lost(cell: str, notes: Iterable[Note]) -> list[WarningRecord]:
    """Say how a load cell's lost frames were counted where the count may be unreliable:
    each note of its :class:`~evtribo.canlog.dropped.DropCount` a warning of its own, each
    sentence once (two pieces of a trial may say the same).

    Parameters
    ----------
    cell : {"normal", "tangential"}
    notes : iterable of Note
        ``DropCount.notes``.

    Returns
    -------
    list of WarningRecord
    """
    said: dict[str, WarningRecord] = {}
    for note in notes:
        values = {**note.mapping, "cell": cell}
        text = kind(note.kind).text(values)
        if text not in said:
            said[text] = emit(note.kind, **values)
    return list(said.values())


def _hold(t_src: Array, values: npt.NDArray[Any], t: Array) -> npt.NDArray[Any]:
    """Values of a stream sampled at *t* by holding the last value (first one before)."""
    idx = np.clip(np.searchsorted(t_src, t, side="right") - 1, 0, max(len(t_src) - 1, 0))
    return values[idx] if len(t_src) else np.zeros(len(t), dtype=values.dtype)


def waveform_names(msg: DecodedMessage, ref: SignalRef) -> npt.NDArray[np.object_]:
    """Names of a waveform signal's codes: its value table's, else :data:`FALLBACK_WAVEFORMS`
    (with a warning naming the signal, ``waveform-codes``); None where a multiplexed frame
    does not carry it.

    Parameters
    ----------
    msg : DecodedMessage
        The decoded frames of the signal's message.
    ref : SignalRef
        The waveform signal.

    Returns
    -------
    ndarray of object
        A name (str) or None per frame.
    """
    codec = msg.codecs[ref.signal.name]
    raw = msg.raw[ref.signal.name]
    if not codec.choices:
        emit("waveform-codes", signal=ref.qualified_name,
             codes=", ".join(f"{k} {v}" for k, v in FALLBACK_WAVEFORMS.items()))
        codec = dataclasses.replace(codec, choices=FALLBACK_WAVEFORMS)
    names = np.full(raw.shape, None, dtype=object)
    present = np.isfinite(raw) if raw.dtype.kind == "f" else np.ones(raw.shape, dtype=bool)
    names[present] = codec.choice_names(raw[present])
    return names


def _excitation(frames: FrameTable, rig: Rig, undecoded: list[npt.NDArray[np.int64]]
                ) -> ExcitationSignals | None:
    """The amplifier's status signals, each held at the times of the first role's message."""
    roles = {r.removeprefix("excitation_"): ref for r, ref in rig.measured_roles.items()
             if r.startswith("excitation_")}
    if not roles:
        return None
    by_msg: dict[str, DecodedMessage] = {}
    for ref in roles.values():
        if ref.message.name not in by_msg:
            names = [r.signal.name for r in roles.values() if r.message is ref.message]
            by_msg[ref.message.name] = _in_time_order(_decoded_only(
                decode_message(frames, ref.message, names), undecoded))
    base = by_msg[next(iter(roles.values())).message.name]

    def role(name: str) -> npt.NDArray[Any] | None:
        ref = roles.get(name)
        if ref is None:
            return None
        msg = by_msg[ref.message.name]
        values: npt.NDArray[Any] = (
            msg.raw[ref.signal.name] != 0 if name == "enabled"
            else waveform_names(msg, ref) if name == "waveform"
            else msg.scaled(ref.signal.name))
        return values if msg is base else _hold(msg.timestamp, values, base.timestamp)

    return ExcitationSignals(t=base.timestamp, enabled=role("enabled"),
                             amplitude=role("amplitude"), frequency=role("frequency"),
                             waveform=role("waveform"))


def _decoded_count(frames: FrameTable, rig: Rig, undecoded: list[npt.NDArray[np.int64]]
                   ) -> int:
    """Frames of the rig's messages decoded: long enough, and not refused by cantools."""
    decoded = np.zeros(len(frames), dtype=bool)
    for ref in rig.measured_roles.values():
        m = ref.message
        decoded |= message_mask(frames, m) & (frames.dlc >= m.length)
    decoded[np.concatenate([np.zeros(0, dtype=np.int64), *undecoded])] = False
    return int(np.count_nonzero(decoded))


def decode_trial(frames: FrameTable, rig: Rig, *, channel: str | None = None) -> TrialSignals:
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
        Its ``warnings`` are what decoding it found to say, each also said as it is found
        (kept by the innermost collector's scope, the trial a worker analyses, when there
        is one: :mod:`evtribo.warning.collect`).

    Raises
    ------
    UserInputError
        *channel* is not one of the log's channels.
    """
    with collecting() as said:
        return dataclasses.replace(_decode_trial(frames, rig, channel), warnings=tuple(said))


def _decode_trial(frames: FrameTable, rig: Rig, channel: str | None) -> TrialSignals:
    """:func:`decode_trial` but for its warnings."""
    total = len(frames) + frames.xl_frames
    frames, chosen = rig_channel(frames, rig, channel)
    kind_mismatches(frames, rig_messages(rig), rig.database)
    drops = frames.reported_drops
    logger_dropped = (sum(drops.values()) if chosen is None or len(frames.channel_names) <= 1
                      else drops.get(chosen, 0))
    with np.errstate(invalid="ignore"):
        finite = np.abs(frames.timestamp) < IMPOSSIBLE_TIMESTAMP  # NaN too: no clock's time
    if not finite.all():
        emit("timestamps-nonfinite", frames=len(frames) - int(np.count_nonzero(finite)))
        frames = frames.take(finite)
    # logs merged or written out of order, clocks that stepped: each cell is put in the
    # order sent on its own, its lost frames counted in that order, the log's clock steps
    # taken out of every frame (the counter the logger checks too: the rig's role, or a
    # *Counter signal of the cell)
    undecoded: list[npt.NDArray[np.int64]] = []
    frames, (normal, tangential) = _cells(frames, rig, undecoded)
    excitation = _excitation(frames, rig, undecoded)
    n = _decoded_count(frames, rig, undecoded)
    return TrialSignals(normal, tangential, excitation, frames=n, ignored_frames=total - n,
                        channel=chosen, logger_dropped=logger_dropped)


__all__ = ["FALLBACK_WAVEFORMS", "CellSignals", "DecodedMessage", "ExcitationSignals",
           "SignalCodec", "TrialProvenance", "TrialSignals", "beyond_length", "decode_message",
           "decode_messages", "decode_trial", "kind_mismatches", "message_mask", "say_lost",
           "waveform_names"]
