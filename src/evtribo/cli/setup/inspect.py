"""``evtribo inspect LOG [--dbc FILE]``: what a CAN log holds.

Prints the duration, frame counts by kind, the frames the recording tool said it dropped
(candump's ``DROPCOUNT``) and CAN XL frames, and per identifier (per channel and identifier
when the log holds several channels): count, mean rate, median and longest gap between
frames, and (with ``--dbc``) which message and signals it decodes to; an identifier whose
number is a DBC message's but whose kind (standard or extended) is not is said so. With
``--dbc``, then per signal: its rate, minimum, mean and maximum, how it behaves (positive and
steady, changing sign, switching, counting) and the rig's role it suggests, so that one sees
at once which identifier carries which force.
"""

from __future__ import annotations

import argparse
import math
from typing import Any

import cantools
import numpy as np

from evtribo.canlog.decode_table import load_dbc_file
from evtribo.canlog.io import FrameTable, ReadReport, read_frames

_TIME_BASES = {"-tz": "candump -tz: times from the first frame",
               "-td": "candump -td: times summed from deltas",
               "-tA": "candump -tA: local times read as UTC"}


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``inspect``."""
    p = subparsers.add_parser("inspect", help="summarise a CAN log (IDs, rates, gaps)",
                              description=__doc__.splitlines()[0])
    p.add_argument("log", help="CAN log (.log, .log.gz, .asc, .blf, .trc, .csv...)")
    p.add_argument("--dbc", help="CAN database: name the messages and signals")
    p.add_argument("--strict", action="store_true", help="a damaged line is an error")
    p.set_defaults(func=run)
    return p


def _header(path: str, report: ReadReport, frames: FrameTable) -> None:
    base = f" ({_TIME_BASES[report.time_base]})" if report.time_base in _TIME_BASES else ""
    print(f"{path}: {report.format} log{base}, {len(frames)} frames, {report.lines} lines, "
          f"{report.skipped_lines} damaged lines skipped")
    if report.dropped_frames:
        by = ", ".join(f"{k or '?'}: {v}" for k, v in frames.reported_drops.items())
        print(f"dropped: {report.dropped_frames} frames the recording tool reported dropping "
              f"({by})")
    if report.xl_frames:
        print(f"CAN XL: {report.xl_frames} frames (counted, not decoded)")


def _describe(db: cantools.database.can.Database, can_id: int, ext: bool) -> str:
    """``  Message: signals`` of a DBC for an identifier, or why there is none."""
    by_key = {(m.frame_id, bool(m.is_extended_frame)): m for m in db.messages}
    msg = by_key.get((can_id, ext))
    if msg is not None:
        return f"  {msg.name}: " + ", ".join(
            f"{s.name}" + (f" [{s.unit}]" if s.unit else "") for s in msg.signals)
    other = by_key.get((can_id, not ext))
    if other is not None:
        kind = "a standard" if ext else "an extended"
        return f"  (not in the DBC: its {other.name} has this number as {kind} ID)"
    return "  (not in the DBC)"


def run(args: argparse.Namespace) -> int:
    """Print the summary of ``args.log``."""
    db = load_dbc_file(args.dbc) if args.dbc else None
    frames, report = read_frames(args.log, strict=args.strict)
    n = len(frames)
    _header(args.log, report, frames)
    if n == 0:
        return 0
    t = frames.timestamp
    duration = float(t.max() - t.min())
    print(f"duration: {duration:.6f} s (from {t.min():.6f} to {t.max():.6f})")
    print(f"kinds: {int(frames.is_extended.sum())} extended, {int(frames.is_remote.sum())} "
          f"remote, {int(frames.is_error.sum())} error, {int(frames.is_fd.sum())} CAN FD")
    data = ~frames.is_error
    several = len(frames.channel_names) > 1
    keys = (frames.arbitration_id.astype(np.int64) | (frames.is_extended.astype(np.int64) << 32)
            | ((frames.channels.astype(np.int64) + 1) << 33 if several else 0))
    names = ["", *frames.channel_names]
    header = f"{'id':>10} {'count':>9} {'rate_Hz':>10} {'median_gap_s':>13} {'max_gap_s':>11}"
    print((f"{'channel':>10} " if several else "") + header
          + ("  message: signals" if db else ""))
    for key in np.unique(keys[data]):
        sel = data & (keys == key)
        ext = bool((key >> 32) & 1)
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
        if several:
            line = f"{names[int(key >> 33)] or '?':>10} " + line
        if db is not None:
            line += _describe(db, can_id, ext)
        print(line)
    if frames.is_error.any():
        print(f"{'error':>10} {int(frames.is_error.sum()):>9}")
    if db is not None:
        _signals(frames, db)
    return 0


def _number(value: float) -> str:
    return "--" if math.isnan(value) else f"{value:.6g}"


def _signals(frames: FrameTable, db: cantools.database.can.Database) -> None:
    """Per signal: rate, min / mean / max, behaviour, and the role it suggests."""
    from evtribo.rigsetup import behaviour_text, guess_roles, signal_stats

    stats = signal_stats(frames, db)
    if not stats:
        return
    roles = {g.name: (role + ("?" if not g.certain else ""))
             for role, g in guess_roles(db, stats).items() if g.name in stats}
    width = max(len(name) for name in stats)
    print("-- per signal:")
    print(f"{'signal':<{width}} {'unit':>5} {'rate_Hz':>9} {'min':>11} {'mean':>11} "
          f"{'max':>11}  behaviour / role")
    for name, st in stats.items():
        role = roles.get(name, "")
        what = behaviour_text(st) + (f"  -> {role}" if role else "")
        print(f"{name:<{width}} {st.unit:>5} {st.rate_Hz:>9.2f} {_number(st.minimum):>11} "
              f"{_number(st.mean):>11} {_number(st.maximum):>11}  {what}")
    if roles:
        print("(roles as `evtribo init --log` would guess them; ? where another signal fits "
              "almost as well)")
