"""``evtribo inspect LOG [--dbc FILE]``: what a CAN log holds.

Prints the duration, frame counts by kind, and per identifier: count, mean rate, median and
longest gap between frames, and (with ``--dbc``) which message and signals it decodes to.
"""

from __future__ import annotations

import argparse
import os

import cantools
import numpy as np

from evtribo.errors import RigConfigError
from evtribo.frames import read_frames
from evtribo.rig import load_dbc as rig_load_dbc


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``inspect``."""
    p = subparsers.add_parser("inspect", help="summarise a CAN log (IDs, rates, gaps)",
                              description=__doc__.splitlines()[0])
    p.add_argument("log", help="CAN log (.log, .log.gz, .asc, .blf, .trc, .csv...)")
    p.add_argument("--dbc", help="CAN database: name the messages and signals")
    p.add_argument("--strict", action="store_true", help="a damaged line is an error")
    p.set_defaults(func=run)
    return p


def load_dbc(path: str) -> cantools.database.can.Database:
    """A DBC as the rig loads it (one with overlapping signals loads with a warning), or a
    :class:`RigConfigError` naming the file."""
    if not os.path.isfile(path):
        raise RigConfigError("DBC file not found", path=path)
    return rig_load_dbc(path, source=path)


def run(args: argparse.Namespace) -> int:
    """Print the summary of ``args.log``."""
    db = load_dbc(args.dbc) if args.dbc else None
    frames, report = read_frames(args.log, strict=args.strict)
    n = len(frames)
    print(f"{args.log}: {report.format} log, {n} frames, {report.lines} lines, "
          f"{report.skipped_lines} damaged lines skipped")
    if n == 0:
        return 0
    t = frames.timestamp
    duration = float(t.max() - t.min())
    print(f"duration: {duration:.6f} s (from {t.min():.6f} to {t.max():.6f})")
    print(f"kinds: {int(frames.is_extended.sum())} extended, {int(frames.is_remote.sum())} "
          f"remote, {int(frames.is_error.sum())} error, {int(frames.is_fd.sum())} CAN FD")
    data = ~frames.is_error
    keys = frames.arbitration_id.astype(np.int64) | (frames.is_extended.astype(np.int64) << 32)
    header = f"{'id':>10} {'count':>9} {'rate_Hz':>10} {'median_gap_s':>13} {'max_gap_s':>11}"
    print(header + ("  message: signals" if db else ""))
    for key in np.unique(keys[data]):
        sel = data & (keys == key)
        ext = bool(key >> 32)
        can_id = int(key & 0xFFFFFFFF)
        ts = np.sort(t[sel])
        count = len(ts)
        gaps = np.diff(ts)
        span = float(ts[-1] - ts[0])
        rate = (count - 1) / span if span > 0 else float("nan")
        med = float(np.median(gaps)) if len(gaps) else float("nan")
        mx = float(gaps.max()) if len(gaps) else float("nan")
        ident = f"{can_id:08X}x" if ext else f"{can_id:03X}"
        line = f"{ident:>10} {count:>9} {rate:>10.2f} {med:>13.6f} {mx:>11.6f}"
        if db is not None:
            try:
                msg = db.get_message_by_frame_id(can_id)
            except KeyError:
                msg = None
            if msg is not None and bool(msg.is_extended_frame) == ext:
                line += f"  {msg.name}: " + ", ".join(
                    f"{s.name}" + (f" [{s.unit}]" if s.unit else "") for s in msg.signals)
            else:
                line += "  (not in the DBC)"
        print(line)
    if frames.is_error.any():
        print(f"{'error':>10} {int(frames.is_error.sum()):>9}")
    return 0
