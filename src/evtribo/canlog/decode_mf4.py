"""``evtribo decode LOG --dbc F -o OUT.mf4``: a log's decoded signals as ASAM MDF 4.

One channel group per message of the DBC that has frames in the log (its name and ID as the
group's acquisition name and comment), holding the message's time (s) as its master
channel and one channel per signal: the physical values (float64, ``raw * scale + offset``
as cantools gives them; NaN where a multiplexed signal is absent or cantools refused the
frame), with the DBC's unit and comment, and its value table as a value-to-text conversion
(keyed by the physical value each code decodes to). The times are the log's; when the
log's clock is a date, they count from the whole second of its first frame, the
measurement's start time in the file's header (each time is exactly the log's less that
second). Written through asammdf (the ``mf4`` extra) a block of the log at a time, and put
in place only once complete.
"""

from __future__ import annotations

import datetime as dt
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from cantools.database.can import Database, Message, Signal

from evtribo.canlog.decode import decode_message, message_mask
from evtribo.canlog.io import FrameStream, FrameTable, ReadReport
from evtribo.errors import UserInputError
from evtribo.store.files import MF4_PROGRAM_ID, atomic_open

__all__ = ["EPOCH_AFTER_S", "MF4_EXTRA", "Mf4Written", "save_mdf",
           "signal_conversion", "write_mf4"]

log = logging.getLogger(__name__)

#: How to install asammdf.
MF4_EXTRA = "pip install 'evtribo[mf4]'"
#: A log's first time above this (s, 1973) is a date: the file's times start from it.
EPOCH_AFTER_S = 1e8


@dataclass
class Mf4Written:
    """What :func:`write_mf4` wrote.

    Attributes
    ----------
    groups : int
        Channel groups (messages with decoded frames).
    rows : int
        Decoded frames, over all groups.
    frames : int
        Frames read (of the channel asked for).
    signals : int
        Signal channels, over all groups.
    start : float
        The log's time of the file's time 0 (s: a whole second; 0 when the log's times are
        not dates).
    report : ReadReport
        The reading of the log.
    """

    groups: int
    rows: int
    frames: int
    signals: int
    start: float
    report: ReadReport


def signal_conversion(signal: Signal) -> dict[str, Any] | None:
    """asammdf's value-to-text conversion of a DBC signal's value table, or None.

    Each code's text is keyed by the physical value it decodes to (``code * scale +
    offset``), the value the channel holds.

    Parameters
    ----------
    signal : cantools.database.can.Signal

    Returns
    -------
    dict or None
        ``{"val_0": ..., "text_0": b"...", ..., "default": b""}`` for
        :func:`asammdf.blocks.conversion_utils.from_dict`.
    """
    if not signal.choices:
        return None
    conv: dict[str, Any] = {}
    for i, (code, name) in enumerate(sorted(signal.choices.items(), key=lambda kv: kv[0])):
        conv[f"val_{i}"] = float(code) * float(signal.scale) + float(signal.offset)
        conv[f"text_{i}"] = str(name).encode("utf-8")
    conv["default"] = b""
    return conv


@dataclass
class _Groups:
    """The file being built: each message's group index, in the order first seen."""

    mdf: Any
    start: float | None = None
    index: dict[str, int] = field(default_factory=dict)
    rows: int = 0
    signals: int = 0

    def add(self, message: Message, frames: FrameTable) -> None:
        """Decode *message*'s frames of a block and append them to its group."""
        mask = message_mask(frames, message)
        if not mask.any():
            return
        decoded = decode_message(frames, message, mask=mask, quiet=True)
        if not len(decoded):
            return
        t = decoded.timestamp - (self.start or 0.0)
        values = [np.asarray(decoded.scaled(s.name), dtype=np.float64)
                  for s in message.signals]
        if message.name in self.index:
            self.mdf.extend(self.index[message.name],
                            [(t, None), *((v, None) for v in values)])
        else:
            self.index[message.name] = self._append(message, t, values)
            self.signals += len(values)
        self.rows += len(decoded)

    def _append(self, message: Message, t: np.ndarray, values: list[np.ndarray]) -> int:
        from asammdf import Signal as Mf4Signal
        from asammdf.blocks.source_utils import Source

        source = Source(name=message.name, path=f"0x{message.frame_id:X}",
                        comment=message.comment or "", source_type=Source.SOURCE_BUS,
                        bus_type=Source.BUS_TYPE_CAN)
        signals = [Mf4Signal(samples=v, timestamps=t, name=s.name, unit=s.unit or "",
                             comment=s.comment or "", conversion=signal_conversion(s),
                             source=source)
                   for s, v in zip(message.signals, values, strict=True)]
        self.mdf.append(signals, acq_name=message.name,
                        comment=f"CAN message {message.name} (0x{message.frame_id:X})",
                        acq_source=source)
        return len(self.mdf.groups) - 1


def write_mf4(open_stream: Callable[[bool], FrameStream], db: Database, path: str, *,
              channel: str | None = None) -> Mf4Written:
    """Decode a log block by block into an ASAM MDF 4 file (see the module's notes).

    Parameters
    ----------
    open_stream : callable
        ``open_stream(warn)`` gives the log as a :class:`~evtribo.canlog.io.FrameStream`.
    db : cantools.database.can.Database
        The DBC.
    path : str
        The output, ``.mf4``; written whole or not at all.
    channel : str, optional
        Decode the frames of this channel (bus) only.

    Returns
    -------
    Mf4Written

    Raises
    ------
    UserInputError
        asammdf is not installed, *channel* is not one of the log's channels, or no frame
        of the log is one of the DBC's messages.
    LogFormatError
        As :class:`~evtribo.canlog.io.FrameStream`.
    """
    try:
        from asammdf import MDF
    except ImportError:
        raise UserInputError(f"writing .mf4 needs the optional package asammdf: {MF4_EXTRA}",
                             path=path, key="-o") from None

    stream = open_stream(True)
    groups = _Groups(MDF(version="4.10"))
    try:
        frames = _fill(groups, stream, db, channel)
        start = groups.start or 0.0
        if start:
            groups.mdf.header.start_time = dt.datetime.fromtimestamp(start, dt.UTC)
        save_mdf(groups.mdf, Path(path))
    finally:
        groups.mdf.close()
    return Mf4Written(len(groups.index), groups.rows, frames, groups.signals, start,
                      stream.report)


def _fill(groups: _Groups, stream: FrameStream, db: Database, channel: str | None) -> int:
    """Every block of *stream* into *groups*; the frames read (of *channel*)."""
    frames = 0
    channels: dict[str, None] = {}
    for read in stream:
        channels.update(dict.fromkeys(read.channel_names))
        block = read if channel is None else read.take(read.on_channel(channel))
        frames += len(block)
        if groups.start is None and len(block):
            first = float(block.timestamp[0])  # a whole second: the times stay exact
            groups.start = float(math.floor(first)) if first > EPOCH_AFTER_S else 0.0
        for message in db.messages:
            groups.add(message, block)
    if channel is not None and channel not in channels:
        have = ", ".join(channels) or "none (its format names no channel)"
        raise UserInputError(f"the log has no channel {channel!r}; its channels: {have}",
                             path=str(stream.path), key="--channel")
    if not groups.index:
        raise UserInputError("no frame of the log is a message of the DBC: nothing to write "
                             "(evtribo inspect LOG --dbc DBC shows what decodes)",
                             path=str(stream.path))
    return frames


def save_mdf(mdf: Any, target: Path) -> None:
    """Save an asammdf MDF as *target*, whole or not at all: written into a temporary file
    created exclusively beside it (:func:`~evtribo.store.files.atomic_open`: no name anyone
    could plant a link at, nothing left behind by a killed process), then put in place.

    Parameters
    ----------
    mdf : asammdf.MDF
    target : Path
        The ``.mf4`` to write (its folder created if missing); an existing file is
        replaced.

    Returns
    -------
    None
    """
    mdf.identification.program_identification = MF4_PROGRAM_ID
    target.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(target, "w+b") as fh:
        mdf.save(fh, overwrite=True, compression=2)
