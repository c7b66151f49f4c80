"""The table ``evtribo decode`` writes: every decoded signal of a log, one row per frame.

One row per decoded frame, in log order: ``timestamp`` (s), ``message``, ``channel`` (when
asked for), then one column per signal (physical values after DBC scaling, or value-table
names). A signal name used by two messages, or named like a fixed column, becomes
``Message.Signal``. A frame cantools cannot decode (a multiplexer value the DBC does not
know) keeps its row, with empty signals.
"""

from __future__ import annotations

import os
from collections import Counter

import numpy as np
import pandas as pd
from cantools.database.can import Database

from evtribo.decode import decode_messages
from evtribo.errors import RigConfigError
from evtribo.frames import FrameTable
from evtribo.rig import load_dbc

__all__ = ["decoded_table", "load_dbc_file"]


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
    if not os.path.isfile(path):
        raise RigConfigError("DBC file not found", path=path)
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
