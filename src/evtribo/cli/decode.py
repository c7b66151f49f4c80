"""``evtribo decode LOG --dbc FILE -o OUT``: every decoded signal as a table.

One row per decoded frame, in log order: ``timestamp`` (s), ``message``, then one column
per signal (physical values after DBC scaling; ``--choices`` writes value-table names
instead of codes). A signal name used by two messages, or named ``timestamp`` or ``message``,
becomes ``Message.Signal``. A frame cantools cannot decode (a multiplexer value the DBC does
not know) keeps its row, with empty signals. Output format by suffix: ``.parquet`` or
``.csv``. An existing output is kept unless ``--force``.
"""

from __future__ import annotations

import argparse
import os
from collections import Counter

import numpy as np
import pandas as pd

from evtribo.cli.inspect import load_dbc
from evtribo.decode import decode_messages
from evtribo.errors import OutputExistsError, UserInputError
from evtribo.frames import read_frames


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``decode``."""
    p = subparsers.add_parser("decode", help="decode a CAN log's signals to Parquet or CSV",
                              description=__doc__.splitlines()[0])
    p.add_argument("log", help="CAN log (.log, .log.gz, .asc, .blf, .trc, .csv...)")
    p.add_argument("--dbc", required=True, help="CAN database (DBC)")
    p.add_argument("-o", "--output", required=True, help="output table (.parquet or .csv)")
    p.add_argument("--choices", action="store_true",
                   help="write value-table names instead of raw codes")
    p.add_argument("--force", action="store_true", help="overwrite an existing output")
    p.add_argument("--strict", action="store_true", help="a damaged line is an error")
    p.set_defaults(func=run)
    return p


def decoded_table(frames: object, db: object, choices: bool = False) -> pd.DataFrame:
    """The decoded frames as one DataFrame (see the module docstring)."""
    decoded = decode_messages(frames, db)  # type: ignore[arg-type]
    # a signal named like a fixed column, or by two messages, is written Message.Signal
    uses = Counter(["timestamp", "message"] + [s for m in decoded.values() for s in m.raw])
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


def run(args: argparse.Namespace) -> int:
    """Decode ``args.log`` with ``args.dbc`` into ``args.output``."""
    out = args.output
    suffix = os.path.splitext(out)[1].lower()
    if suffix not in (".parquet", ".csv"):
        raise UserInputError(f"output must end in .parquet or .csv, not {suffix or '(none)'!r}",
                             path=out)
    if os.path.exists(out) and not args.force:
        raise OutputExistsError("exists; use --force to overwrite", path=out)
    db = load_dbc(args.dbc)
    frames, report = read_frames(args.log, strict=args.strict)
    table = decoded_table(frames, db, choices=args.choices)
    tmp = f"{out}.tmp-{os.getpid()}"
    try:
        if suffix == ".parquet":
            table.to_parquet(tmp, index=False)
        else:
            table.to_csv(tmp, index=False)
        os.replace(tmp, out)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    print(f"{out}: {len(table)} frames decoded of {len(frames)} "
          f"({report.skipped_lines} damaged lines skipped), {table.shape[1] - 2} signals")
    return 0
