"""``evtribo decode LOG --dbc FILE -o OUT``: every decoded signal as a table.

One row per decoded frame, in log order: ``timestamp`` (s), ``message``, ``channel`` (only
when the log holds several channels, or decode one with ``--channel``), then one column per
signal (physical values after DBC scaling; ``--choices`` writes value-table names instead,
as cantools' ``decode_choices`` does: a code the table lacks as its physical value). A signal
name used by two messages, or named like a fixed column, becomes ``Message.Signal``. A frame
cantools cannot decode (a multiplexer value the DBC does not know, a signal beyond the
message's length) keeps its row, with empty signals; so does a multiplexed signal in the
frames that do not carry it. Output format by suffix: ``.parquet``, ``.csv`` or ``.mf4``
(ASAM MDF 4, through asammdf: one channel group per message, the DBC's units, comments and
value tables kept; :mod:`evtribo.canlog.decode_mf4`).
The log is read and written a block at a time (Parquet by row groups), so memory does not
grow with the log.

An existing output is kept unless ``--force``, and ``--force`` replaces only a table
``decode`` wrote, as its folder's manifest shows (:mod:`evtribo.store.owned`); a raw log or
a study's input never is replaced (:mod:`evtribo.guard`): not the log being decoded
(whatever the spelling of its path, symbolic links followed), not any other CAN log, and no
``.csv`` inside a study's subject folder (``evtribo analyze`` would take it for a trial's
log). The output's folder is created if missing.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Any

from evtribo.canlog.decode_mf4 import write_mf4
from evtribo.canlog.decode_table import load_dbc_file, write_decoded
from evtribo.canlog.io import FrameStream
from evtribo.errors import UserInputError
from evtribo.guard import refuse_input
from evtribo.store.owned import check_output, claim


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``decode``."""
    p = subparsers.add_parser("decode",
                              help="decode a CAN log through a DBC into Parquet, CSV or MF4",
                              description=__doc__.splitlines()[0])
    p.add_argument("log", help="CAN log (.log, .log.gz, .asc, .blf, .trc, .csv...)")
    p.add_argument("--dbc", required=True, help="CAN database (DBC)")
    p.add_argument("-o", "--output", required=True, help="output (.parquet, .csv or .mf4)")
    p.add_argument("--choices", action="store_true",
                   help="write value-table names instead of values (a code the table "
                        "lacks: its physical value, as cantools gives it)")
    p.add_argument("--force", action="store_true", help="overwrite an existing output")
    p.add_argument("--strict", action="store_true", help="a damaged line is an error")
    p.add_argument("--channel", help="decode the frames of this channel (bus) only")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Decode ``args.log`` with ``args.dbc`` into ``args.output``, block by block."""
    out = args.output
    suffix = os.path.splitext(out)[1].lower()
    if suffix not in (".parquet", ".csv", ".mf4"):
        raise UserInputError("output must end in .parquet, .csv or .mf4, not "
                             f"{suffix or '(none)'!r}", path=out)
    if suffix == ".mf4" and args.choices:
        raise UserInputError("--choices is for tables: an .mf4 keeps the values and their "
                             "value tables (a reader shows the names)", key="--choices")
    refuse_input(out, command="evtribo decode", source=args.log,  # --force or not
                 source_is="the log being decoded", key="-o")
    check_output(out, "decode", force=args.force, key="-o")  # only its own: --force or not
    FrameStream(args.log)  # the log is checked before the DBC is loaded
    db = load_dbc_file(args.dbc)
    Path(out).parent.mkdir(parents=True, exist_ok=True)

    def open_stream(warn: bool) -> FrameStream:
        return FrameStream(args.log, strict=args.strict, warn=warn)

    if suffix == ".mf4":
        mf4 = write_mf4(open_stream, db, out, channel=args.channel)
        claim(out, "decode")
        print(f"{out}: {mf4.rows} frames decoded of {mf4.frames} "
              f"({mf4.report.skipped_lines} damaged lines skipped), {mf4.signals} signals "
              f"in {mf4.groups} channel groups (one per message)")
        return 0
    done = write_decoded(open_stream, db, out, choices=args.choices, channel=args.channel)
    claim(out, "decode")
    print(f"{out}: {done.rows} frames decoded of {done.frames} "
          f"({done.report.skipped_lines} damaged lines skipped), {done.signals} signals")
    return 0
