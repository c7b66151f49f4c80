"""Which frames of a log are which message of a DBC: the same ID, the same kind of ID
(standard or extended) and the same kind of frame (CAN FD or classic CAN), data frames only;
and, for the frames that have a message's ID number but not its kinds, why they are not
decoded as it.

A standard ``0x0C1`` frame is not the extended message ``0x000000C1``, and a CAN FD frame on
``0x0C1`` is not the classic message ``0x0C1`` (nor the other way round): their payloads are
other data that happen to share a number, and decoding them as the message would mix them
into its samples. Such frames are counted with the frames the DBC does not describe, and
named in a warning.

A message longer than 8 bytes is a CAN FD message whatever its frame format attribute says
(``VFrameFormat``: many DBCs give none, and J1939 ones give 3, which cantools reads as
classic): no classic frame carries more than 8 bytes (:func:`is_fd_message`).

A rig's frames come from one channel (bus): the one named, else the one carrying most of
them, with a warning when its messages arrive on several (:func:`rig_channel`).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from cantools.database.can import Database, Message

from evtribo.canlog.io.ids import id_text
from evtribo.canlog.io.table import FrameTable
from evtribo.canlog.rig import Rig
from evtribo.errors import UserInputError
from evtribo.warning.collect import emitter
from evtribo.warning.record import WarningRecord

emit = emitter(__name__)

__all__ = ["is_fd_message", "kind_mismatches", "message_mask", "rig_channel", "rig_messages"]


def is_fd_message(message: Message) -> bool:
    """Whether *message*'s frames are CAN FD: its frame format says so, or it is longer than
    a classic frame's 8 bytes.

    Parameters
    ----------
    message : cantools.database.can.Message
        The message.

    Returns
    -------
    bool
    """
    return bool(message.is_fd) or int(message.length) > 8


def message_mask(frames: FrameTable, message: Message) -> npt.NDArray[np.bool_]:
    """Frames carrying *message*: same ID, ID kind and CAN FD or classic kind
    (:func:`is_fd_message`), data frames (not error or remote).

    Parameters
    ----------
    frames : FrameTable
        The log's frames.
    message : cantools.database.can.Message
        The message.

    Returns
    -------
    ndarray of bool
        One per frame.
    """
    return ((frames.arbitration_id == np.uint32(message.frame_id))
            & (frames.is_extended == bool(message.is_extended_frame))
            & (frames.is_fd == is_fd_message(message)) & ~frames.is_error & ~frames.is_remote)



def _id_text(frame_id: int, extended: bool) -> str:
    return f"{'extended (29-bit)' if extended else 'standard (11-bit)'} ID 0x" + id_text(
        frame_id, extended)


def kind_mismatches(frames: FrameTable, messages: list[Message], db: Database
                    ) -> list[WarningRecord]:
    """Say why frames with the ID number of one of *messages* are not decoded as it: the ID
    is of the other kind (standard or extended), or the frame is CAN FD where the message is
    a classic CAN one (or the other way round), and *db* has no message of that kind. One
    warning per message and reason (``frames-id-kind``, ``frames-fd-kind``).

    Parameters
    ----------
    frames : FrameTable
        The log's frames.
    messages : list of cantools.database.can.Message
        The messages looked for.
    db : cantools.database.can.Database
        Their DBC.

    Returns
    -------
    list of WarningRecord
        The warnings said.
    """
    known = {(m.frame_id, bool(m.is_extended_frame), is_fd_message(m)) for m in db.messages}
    data = ~frames.is_error & ~frames.is_remote
    out = []
    for m in messages:
        ext, fd = bool(m.is_extended_frame), is_fd_message(m)
        same = data & (frames.arbitration_id == np.uint32(m.frame_id))
        other_id = sum(int(np.count_nonzero(same & (frames.is_extended != ext)
                                            & (frames.is_fd == f)))
                       for f in (False, True) if (m.frame_id, not ext, f) not in known)
        if other_id:
            out.append(emit("frames-id-kind", frames=other_id,
                            id_seen=_id_text(m.frame_id, not ext),
                            id_declared=_id_text(m.frame_id, ext), message=m.name))
        other_fd = 0 if (m.frame_id, ext, not fd) in known else int(np.count_nonzero(
            same & (frames.is_extended == ext) & (frames.is_fd != fd)))
        if other_fd:
            kinds = ("CAN FD", "classic CAN") if fd else ("classic CAN", "CAN FD")
            out.append(emit("frames-fd-kind", frames=other_fd, kind_seen=kinds[1],
                            id_text=_id_text(m.frame_id, ext), kind_declared=kinds[0],
                            message=m.name))
    return out


def rig_messages(rig: Rig) -> list[Message]:
    """The messages of the rig's roles, each once.

    Parameters
    ----------
    rig : Rig

    Returns
    -------
    list of cantools.database.can.Message
    """
    return list({id(r.message): r.message for r in rig.measured_roles.values()}.values())


def _rig_mask(frames: FrameTable, rig: Rig) -> npt.NDArray[np.bool_]:
    mask = np.zeros(len(frames), dtype=bool)
    for m in rig_messages(rig):
        mask |= message_mask(frames, m)
    return mask


def rig_channel(frames: FrameTable, rig: Rig, channel: str | None
                ) -> tuple[FrameTable, str | None]:
    """The frames of the channel the rig is decoded from, and its name.

    Parameters
    ----------
    frames : FrameTable
        The log's frames.
    rig : Rig
    channel : str or None
        The channel asked for (None: the one carrying most of the rig's frames); a warning
        (``channels-several``) when the rig's frames arrive on several.

    Returns
    -------
    (FrameTable, str or None)
        The channel's frames and its name.

    Raises
    ------
    UserInputError
        *channel* is not one of the log's channels.
    """
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
        shared = [m.name for m in rig_messages(rig)
                  if len(frames.channel_counts(message_mask(frames, m))) > 1]
        emit("channels-several",
             counts=", ".join(f"{k}: {v} frames" for k, v in counts.items()),
             shared=f", {', '.join(shared)} on more than one" if shared else "",
             channel=chosen, chosen=" (the channel carrying most of them)"
             if channel is None else "")
    return frames.take(frames.on_channel(chosen)), chosen
