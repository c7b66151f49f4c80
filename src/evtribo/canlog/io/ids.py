"""One way to name a CAN identifier: an integer key per ID and kind, and its text.

A standard ``0x0C1`` and an extended ``0x000000C1`` are different identifiers. Everywhere
evtribo keys frames by identifier (the logger's counts, the rolling-counter checks, the
decoder, ``inspect``), the key is the ID with bit 31 set for a 29-bit ID, as SocketCAN's
``CAN_EFF_FLAG`` and cantools number extended frames; its text is candump's (3 hex digits
for a standard ID, 8 for an extended one).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["EXTENDED_FLAG", "frame_key", "frame_keys", "id_text", "key_id"]

#: Set in a key for a 29-bit (extended) identifier (SocketCAN's ``CAN_EFF_FLAG``).
EXTENDED_FLAG = 0x80000000


def frame_key(arbitration_id: int, is_extended: bool) -> int:
    """The key of one identifier.

    Parameters
    ----------
    arbitration_id : int
        The 11- or 29-bit identifier.
    is_extended : bool
        A 29-bit identifier.

    Returns
    -------
    int
        *arbitration_id*, with :data:`EXTENDED_FLAG` set when *is_extended*.
    """
    return int(arbitration_id) | (EXTENDED_FLAG if is_extended else 0)


def frame_keys(arbitration_id: npt.ArrayLike, is_extended: npt.ArrayLike
               ) -> npt.NDArray[np.int64]:
    """:func:`frame_key` of many frames at once.

    Parameters
    ----------
    arbitration_id : array_like of int
    is_extended : array_like of bool

    Returns
    -------
    ndarray of int64
    """
    ids = np.asarray(arbitration_id, dtype=np.int64)
    return ids | np.where(np.asarray(is_extended, dtype=bool), EXTENDED_FLAG, 0)


def key_id(key: int) -> tuple[int, bool]:
    """The identifier and kind of a key (the inverse of :func:`frame_key`).

    Parameters
    ----------
    key : int

    Returns
    -------
    (int, bool)
        The identifier, and whether it is extended.
    """
    return int(key) & ~EXTENDED_FLAG, bool(int(key) & EXTENDED_FLAG)


def id_text(arbitration_id: int, is_extended: bool) -> str:
    """An identifier as candump writes it.

    Parameters
    ----------
    arbitration_id : int
    is_extended : bool

    Returns
    -------
    str
        ``"0C1"`` for a standard ID, ``"000000C1"`` for an extended one.
    """
    return f"{arbitration_id:08X}" if is_extended else f"{arbitration_id:03X}"
