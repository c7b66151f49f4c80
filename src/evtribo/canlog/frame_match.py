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
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from cantools.database.can import Database, Message

from evtribo.canlog.io.ids import id_text
from evtribo.canlog.io.table import FrameTable

__all__ = ["is_fd_message", "kind_mismatches", "message_mask"]


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


def kind_mismatches(frames: FrameTable, messages: list[Message], db: Database) -> list[str]:
    """Why frames with the ID number of one of *messages* are not decoded as it: the ID is of
    the other kind (standard or extended), or the frame is CAN FD where the message is a
    classic CAN one (or the other way round), and *db* has no message of that kind. One
    sentence per message and reason, beginning with the number of frames.

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
    list of str
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
            out.append(f"{other_id} frames have the {_id_text(m.frame_id, not ext)}, but the "
                       f"DBC's message {m.name} has the {_id_text(m.frame_id, ext)}: not "
                       f"decoded as {m.name} (the kind of ID is part of it)")
        other_fd = 0 if (m.frame_id, ext, not fd) in known else int(np.count_nonzero(
            same & (frames.is_extended == ext) & (frames.is_fd != fd)))
        if other_fd:
            kinds = ("CAN FD", "classic CAN") if fd else ("classic CAN", "CAN FD")
            out.append(f"{other_fd} {kinds[1]} frames have the {_id_text(m.frame_id, ext)} "
                       f"of the DBC's {kinds[0]} message {m.name}: not decoded as {m.name}, "
                       f"counted with the frames the DBC does not describe (a CAN FD frame "
                       f"is only an FD message, a classic frame only a classic one)")
    return out
