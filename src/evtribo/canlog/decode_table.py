"""The table ``evtribo decode`` writes: every decoded signal of a log, one row per frame.

One row per decoded frame, in log order: ``timestamp`` (s), ``message``, ``channel`` (when
asked for), then one column per signal (physical values after DBC scaling, or value-table
names). A signal name used by two messages, or named like a fixed column, becomes
``Message.Signal``. A frame cantools cannot decode (a multiplexer value the DBC does not
know) keeps its row, with empty signals.
"""

from __future__ import annotations

import logging
import os
from collections import Counter
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from itertools import chain
from typing import IO, TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
import pyarrow as pa
import pyarrow.parquet as pq
from cantools.database.can import Database, Message

from evtribo.canlog.decode import decode_message, decode_messages, kind_mismatches, message_mask
from evtribo.canlog.io import FrameStream, FrameTable, ReadReport
from evtribo.canlog.rig import load_dbc
from evtribo.canlog.signal_codec import SignalCodec
from evtribo.errors import LogFormatError, RigConfigError, UserInputError
from evtribo.store.files import atomic_open
from evtribo.warning.collect import collecting
from evtribo.warning.record import Scope

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["Written", "decoded_table", "load_dbc_file", "write_decoded"]

log = logging.getLogger(__name__)


def load_dbc_file(path: str) -> Database:
    """A DBC named on the command line, loaded as the rig loads it.

    Parameters
    ----------
    path : str
        The DBC file.

    Returns
    -------
    cantools.database.can.Database
        One with overlapping signals loads with a warning.

    Raises
    ------
    RigConfigError
        The file is missing or does not parse, naming it.
    """
    try:
        os.stat(path)
    except FileNotFoundError:
        raise RigConfigError("DBC file not found", path=path) from None
    except OSError as err:  # in a folder the user may not enter
        raise RigConfigError(f"cannot read: {err.strerror}", path=path) from None
    return load_dbc(path, source=path)


def decoded_table(frames: FrameTable, db: Database, choices: bool = False,
                  with_channel: bool = False) -> pd.DataFrame:
    """The decoded frames as one DataFrame, one row per decoded frame in log order.

    Parameters
    ----------
    frames : FrameTable
        The log's frames.
    db : cantools.database.can.Database
        The DBC.
    choices : bool
        Write value-table names instead of codes.
    with_channel : bool
        Add the ``channel`` column.

    Returns
    -------
    pandas.DataFrame
        ``timestamp`` (s), ``message``, ``channel`` (with *with_channel*), then one column
        per signal (physical values; ``Message.Signal`` for a name used twice or named like
        a fixed column).
    """
    import pandas as pd  # not imported by a Parquet output streamed by write_decoded

    decoded = decode_messages(frames, db)
    fixed = ["timestamp", "message"] + (["channel"] if with_channel else [])
    # a signal named like a fixed column, or by two messages, is written Message.Signal
    uses = Counter(fixed + [s for m in decoded.values() for s in m.raw])
    index = np.concatenate([m.index for m in decoded.values()]) if decoded else np.zeros(0, int)
    order = np.argsort(index, kind="stable")
    n = len(index)
    columns: dict[str, object] = {
        "timestamp": np.concatenate([m.timestamp for m in decoded.values()])
        if decoded else np.zeros(0),
        "message": pd.Categorical(np.concatenate(
            [np.full(len(m), m.name, dtype=object) for m in decoded.values()])
            if decoded else []),
    }
    if with_channel:
        names = np.array([*frames.channel_names, ""], dtype=object)  # -1: no channel
        columns["channel"] = pd.Categorical(names[frames.channels[index]])
    offset = 0
    for m in decoded.values():
        rows = slice(offset, offset + len(m))
        for name in m.raw:
            col = f"{m.name}.{name}" if uses[name] > 1 else name
            named = choices and m.codecs[name].choices
            full = np.full(n, None if named else np.nan, dtype=object if named else float)
            full[rows] = m.choice_names(name) if named else m.scaled(name)
            columns[col] = full
        offset += len(m)
    table = pd.DataFrame(columns)
    return table.iloc[order].reset_index(drop=True) if n else table


# --- the table written block by block -------------------------------------------------------


class _Replan(Exception):
    """A block holds a message, a channel or a value the planned columns do not cover."""


@dataclass
class _Facts:
    """What the frames read so far hold that the table's columns depend on."""

    present: set[str] = field(default_factory=set)     # messages with frames: columns
    decoded: set[str] = field(default_factory=set)     # messages with rows: categories
    row_channels: set[str] = field(default_factory=set)  # channels of rows ("": none)
    channels: dict[str, None] = field(default_factory=dict)  # every channel, in order
    short: Counter[str] = field(default_factory=Counter)  # frames too short, by message
    kinds: Counter[str] = field(default_factory=Counter)  # kind-mismatch sentences

    def covers(self, other: _Facts) -> bool:
        """Whether *other* adds nothing to the columns planned from these facts."""
        return (other.present <= self.present and other.decoded <= self.decoded
                and other.row_channels <= self.row_channels
                and other.channels.keys() <= self.channels.keys())

    def add(self, other: _Facts) -> None:
        """Take in the facts of one more block."""
        self.present |= other.present
        self.decoded |= other.decoded
        self.row_channels |= other.row_channels
        self.channels.update(other.channels)
        self.short.update(other.short)
        self.kinds.update(other.kinds)


@dataclass
class _Block:
    """One block's frames (of the channel asked for), the masks of their messages, facts."""

    frames: FrameTable
    masks: dict[str, npt.NDArray[np.bool_]]
    facts: _Facts
    read: int


def _block(frames: FrameTable, db: Database, channel: str | None) -> _Block:
    """The masks and facts of one block of the log."""
    facts = _Facts(channels=dict.fromkeys(frames.channel_names))
    if channel is not None:
        frames = frames.take(frames.on_channel(channel))
    with collecting(Scope(), quiet=True) as found:  # said once for the log: _warn
        kind_mismatches(frames, db.messages, db)
    for record in found:  # "<n> frames have ..."
        n, rest = record.text.split(" ", 1)
        facts.kinds[rest] += int(n)
    masks = {}
    rows = np.zeros(len(frames), dtype=bool)
    for m in db.messages:
        mask = message_mask(frames, m)
        if not mask.any():
            continue
        masks[m.name] = mask
        facts.present.add(m.name)
        full = mask & (frames.dlc >= m.length)
        if short := int(np.count_nonzero(mask)) - int(np.count_nonzero(full)):
            facts.short[m.name] += short
        if full.any():
            facts.decoded.add(m.name)
            rows |= full
    codes = np.bincount(frames.channels[rows].astype(np.int64) + 1,
                        minlength=len(frames.channel_names) + 1)
    names = ["", *frames.channel_names]
    facts.row_channels = {names[k] for k in np.flatnonzero(codes)}
    return _Block(frames, masks, facts, len(frames))


@dataclass
class _Layout:
    """The table's columns: planned from the facts of the log (or of its first block)."""

    messages: list[Message]
    categories: list[str]
    channels: list[str] | None  # None: no channel column
    columns: list[tuple[str, Message, SignalCodec, bool]]  # name, message, codec, as names
    facts: _Facts
    #: frames cantools refused, by message: [count, first frame, its reason]
    refused: dict[str, list[Any]] = field(default_factory=dict)

    @classmethod
    def plan(cls, facts: _Facts, db: Database, choices: bool, channel: str | None) -> _Layout:
        """The columns :func:`decoded_table` would give the frames *facts* describe."""
        messages = [m for m in db.messages if m.name in facts.present]
        with_channel = channel is not None or len(facts.channels) > 1
        fixed = ["timestamp", "message"] + (["channel"] if with_channel else [])
        uses = Counter(fixed + [s.name for m in messages for s in m.signals])
        columns = []
        for m in messages:
            for sig in m.signals:
                codec = SignalCodec.from_signal(sig)
                name = f"{m.name}.{sig.name}" if uses[sig.name] > 1 else sig.name
                columns.append((name, m, codec, bool(choices and codec.choices)))
        return cls(messages, sorted(facts.decoded),
                   sorted(facts.row_channels) if with_channel else None, columns, facts)

    def schema(self) -> pa.Schema:
        """The Parquet schema of the table."""
        # as pandas writes them: no category (a table without rows) is a dictionary of
        # nulls; value-table names of a message without rows are nulls
        def cat(names: list[str]) -> pa.DataType:
            return pa.dictionary(pa.int32(), pa.string() if names else pa.null())

        fields = [pa.field("timestamp", pa.float64()), pa.field("message", cat(self.categories))]
        if self.channels is not None:
            fields.append(pa.field("channel", cat(self.channels)))
        fields += [pa.field(name, pa.float64() if not named else pa.string()
                            if m.name in self.categories else pa.null())
                   for name, m, _c, named in self.columns]
        return pa.schema(fields)

    def rows(self, block: _Block, offset: int) -> dict[str, npt.NDArray[Any]]:
        """The block's rows, column by column (``message`` and ``channel`` as codes); the
        block starts at frame *offset* of the log."""
        frames = block.frames
        decoded = {m.name: decode_message(frames, m, mask=block.masks[m.name], quiet=True)
                   for m in self.messages if m.name in block.masks}
        for d in decoded.values():  # refused frames keep their row, their signals empty
            if d.undecoded.size:
                seen = self.refused.setdefault(
                    d.name, [0, offset + int(d.undecoded[0]), d.undecoded_reason])
                seen[0] += d.undecoded.size
        taken = np.zeros(len(frames), dtype=bool)
        for d in decoded.values():
            taken[d.index] = True
        at = np.cumsum(taken) - 1  # a decoded frame's row
        n = int(np.count_nonzero(taken))
        out: dict[str, npt.NDArray[Any]] = {"timestamp": frames.timestamp[taken]}
        message = np.zeros(n, dtype=np.int32)
        for d in decoded.values():
            if len(d):
                message[at[d.index]] = self.categories.index(d.name)
        out["message"] = message
        if self.channels is not None:
            names = [*frames.channel_names, ""]
            remap = np.array([self.channels.index(c) if c in self.channels else -1
                              for c in names], dtype=np.int32)
            out["channel"] = remap[frames.channels[taken].astype(np.int64)]
        for name, m, codec, named in self.columns:
            col = np.full(n, None if named else np.nan, dtype=object if named else float)
            got = decoded.get(m.name)
            if got is not None and len(got):
                raw = got.raw[codec.name]
                col[at[got.index]] = codec.choice_names(raw) if named else codec.raw_to_scaled(raw)
            out[name] = col
        return out


class _ParquetSink:
    """Row groups of a Parquet file, one per block."""

    def __init__(self, fh: IO[bytes], layout: _Layout) -> None:
        self.layout = layout
        self.schema = layout.schema()
        # the writer closes its file: its own descriptor, the atomic file stays open
        self.file = os.fdopen(os.dup(fh.fileno()), "wb")
        self.writer = pq.ParquetWriter(self.file, self.schema, use_dictionary=[
            f.name for f in self.schema if not pa.types.is_floating(f.type)])
        self.dictionaries = {name: pa.array(values, self.schema.field(name).type.value_type)
                             for name, values in (("message", layout.categories),
                                                  ("channel", layout.channels or []))
                             if name in self.schema.names}

    def write(self, rows: dict[str, npt.NDArray[Any]]) -> None:
        arrays = []
        for f in self.schema:
            col = rows[f.name]
            if pa.types.is_dictionary(f.type):
                arrays.append(pa.DictionaryArray.from_arrays(
                    pa.array(col, pa.int32(), mask=col < 0), self.dictionaries[f.name]))
            else:  # NaN is written as null, as pandas writes it
                arrays.append(pa.array(col, f.type, from_pandas=True))
        self.writer.write_table(pa.Table.from_arrays(arrays, schema=self.schema))

    def close(self) -> None:
        try:
            self.writer.close()
        finally:
            self.file.close()


class _CsvSink:
    """A CSV file, written a block at a time (the header with the first)."""

    def __init__(self, fh: IO[bytes], layout: _Layout) -> None:
        self.fh = fh
        self.layout = layout
        self.header = True

    def write(self, rows: dict[str, npt.NDArray[Any]]) -> None:
        import pandas as pd

        cats = {"message": self.layout.categories, "channel": self.layout.channels or []}
        table = pd.DataFrame({k: pd.Categorical.from_codes(v, dtype=pd.CategoricalDtype(
            cats[k])) if k in cats else v for k, v in rows.items()})
        table.to_csv(self.fh, index=False, header=self.header)
        self.header = False

    def close(self) -> None:
        pass


@dataclass
class Written:
    """What :func:`write_decoded` wrote.

    Attributes
    ----------
    rows : int
        Rows (decoded frames).
    frames : int
        Frames read (of the channel asked for).
    signals : int
        Signal columns.
    report : ReadReport
        The reading of the log.
    passes : int
        Readings of the log: 2 when a message or channel first seen after the first block
        changed the columns (the first reading then only gathers them).
    """

    rows: int
    frames: int
    signals: int
    report: ReadReport
    passes: int = 1


def _write(path: str, stream: FrameStream, blocks: Iterator[_Block], layout: _Layout, *,
           facts: _Facts | None, check: Callable[[], None]) -> Written:
    """Write every block with *layout* (gathering *facts* when given); raise _Replan at the
    first block it does not cover; *check* runs before the output is in place."""
    rows = frames = 0
    # a block is written in a thread while the next one is read (pyarrow's writer and most
    # of numpy's parsing let go of the GIL): at most two blocks are held at a time
    with atomic_open(path, "wb") as fh, ThreadPoolExecutor(1) as pool:
        sink = (_ParquetSink if path.lower().endswith(".parquet") else _CsvSink)(fh, layout)
        pending: Future[None] | None = None
        try:
            for block in blocks:
                if facts is not None:
                    facts.add(block.facts)
                if not layout.facts.covers(block.facts):
                    raise _Replan
                table = layout.rows(block, frames)
                if pending is not None:
                    pending.result()
                pending = pool.submit(sink.write, table)
                rows += len(table["timestamp"])
                frames += block.read
            if pending is not None:
                pending.result()
            check()
        finally:
            if pending is not None:
                pending.exception()  # the write under way ends before the file closes
            sink.close()
    return Written(rows, frames, len(layout.columns), stream.report)


def write_decoded(open_stream: Callable[[bool], FrameStream], db: Database, path: str, *,
                  choices: bool = False, channel: str | None = None) -> Written:
    """Decode a log block by block into a Parquet (by row groups) or CSV table.

    The table is :func:`decoded_table`'s, row for row and column for column, but memory
    follows a block of the log, not the log. The columns are planned from the first block;
    a message or channel first seen later means reading the log a second time.

    Parameters
    ----------
    open_stream : callable
        ``open_stream(warn)`` gives the log as a :class:`~evtribo.canlog.io.FrameStream`
        (*warn*: whether it warns of damaged lines; False on a second reading).
    db : cantools.database.can.Database
        The DBC.
    path : str
        The output; ``.parquet`` or ``.csv``. Written whole or not at all.
    choices : bool
        Write value-table names instead of codes.
    channel : str, optional
        Decode the frames of this channel only (and write the ``channel`` column).

    Returns
    -------
    Written

    Raises
    ------
    UserInputError
        *channel* is not one of the log's channels.
    LogFormatError
        As :class:`~evtribo.canlog.io.FrameStream`, or the log changed between two readings.
    """
    stream = open_stream(True)
    blocks = (_block(frames, db, channel) for frames in stream)
    first = next(blocks, None)
    facts = _Facts() if first is None else first.facts
    layout = _Layout.plan(facts, db, choices, channel)
    seen = _Facts()

    def check() -> None:
        _check_channel(seen, channel, stream.path)

    try:
        written = _write(path, stream, chain([first] if first else [], blocks), layout,
                         facts=seen, check=check)
    except _Replan:
        for block in blocks:
            seen.add(block.facts)
        check()
        stream = open_stream(False)
        layout = _Layout.plan(seen, db, choices, channel)
        try:
            written = _write(path, stream, (_block(f, db, channel) for f in stream), layout,
                             facts=None, check=check)
        except _Replan:
            raise LogFormatError("changed while it was decoded (a recording in progress?)",
                                 path=stream.path) from None
        written.passes = 2
    _warn(seen, layout, db)
    return written


def _check_channel(facts: _Facts, channel: str | None, log_path: object) -> None:
    if channel is not None and channel not in facts.channels:
        have = ", ".join(facts.channels) or "none (its format names no channel)"
        raise UserInputError(f"the log has no channel {channel!r}; its channels: {have}",
                             path=str(log_path), key="--channel")


def _warn(facts: _Facts, layout: _Layout, db: Database) -> None:
    """The decoder's warnings, once for the whole log."""
    for rest, n in facts.kinds.items():
        log.warning("%d %s", n, rest)
    for m in db.messages:
        if facts.short[m.name]:
            log.warning("%d frames of %s (0x%X) are shorter than its %d bytes: not decoded",
                        facts.short[m.name], m.name, m.frame_id, m.length)
        if m.name in layout.refused:
            n, first, reason = layout.refused[m.name]
            log.warning("%d frames of %s (0x%X) could not be decoded (first, frame %d: %s): "
                        "their signals are NaN", n, m.name, m.frame_id, first, reason)
