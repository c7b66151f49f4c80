"""Faults a logger or a load cell puts into a trial's frames, as real logs show them: a frame
received twice, two frames received swapped, a rolling counter that restarts at 0, the
logger's clock stepping back or ahead. Each is injected into a simulated trial's frame table
(in the log's order), and the truth is kept beside it."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from evtribo.canlog.io.table import FrameTable

#: The default rig's load cells: identifier, message name, the counter's byte.
CELLS = {"FzCell": 0x0C1, "FxCell": 0x0C2}
COUNTER_BYTE = 7


@dataclass
class Faulted:
    """A trial's frames with faults injected, and what was injected."""

    frames: FrameTable
    duplicates: dict[str, int] = field(default_factory=lambda: dict.fromkeys(CELLS, 0))
    restarts: list[tuple[str, float]] = field(default_factory=list)  # (cell, t from start)
    clock_step: tuple[float, float] | None = None                     # (t from start, step)


def _rows_of(frames: FrameTable, name: str) -> np.ndarray:
    return np.flatnonzero(frames.arbitration_id == CELLS[name])


def inject(frames: FrameTable, *, duplicates=(), swaps=(), restarts=(), clock_step=None
           ) -> Faulted:
    """*frames* with faults at given places, each a share (0 to 1) of the trial's length.

    Parameters
    ----------
    duplicates : sequence of (cell, share, later)
        The cell's frame at *share* is received again *later* frames of the log after it
        (0: right after), stamped as the frame it follows.
    swaps : sequence of (cell, share)
        The cell's frame at *share* and its next are received in each other's place.
    restarts : sequence of (cell, share)
        From its frame at *share* on (or the first after it whose counter reads 16 to 200),
        the cell's counter restarts at 0.
    clock_step : (share, step_s), optional
        From the log's frame at *share* on, the logger's clock is *step_s* off.
    """
    t0 = float(frames.timestamp[0])
    data = frames.data.copy()
    stamps = frames.timestamp.copy()
    out = Faulted(frames)
    for name, share in sorted(restarts, key=lambda r: r[1]):  # each later one on top
        rows = _rows_of(frames, name)
        rows = rows[int(share * rows.size):]
        # where the counter would read 16 to 200: a restart at 0 from 255 is no restart,
        # and one from 250 the same, to any clock, as 4 frames lost
        c = data[rows, COUNTER_BYTE].astype(np.int64)
        rows = rows[int(np.argmax((c >= 16) & (c <= 200))):]
        c = data[rows, COUNTER_BYTE].astype(np.int64)
        data[rows, COUNTER_BYTE] = ((c - c[0]) % 256).astype(np.uint8)
        out.restarts.append((name, float(stamps[rows[0]]) - t0))
    for name, share in swaps:
        rows = _rows_of(frames, name)
        a, b = rows[int(share * rows.size)], rows[int(share * rows.size) + 1]
        data[[a, b]] = data[[b, a]]
    if clock_step is not None:
        share, step = clock_step
        r = int(share * len(frames))
        out.clock_step = (float(stamps[r]) - t0, step)
        stamps[r:] += step
    order = list(range(len(frames)))
    copies = []
    for name, share, later in duplicates:
        rows = _rows_of(frames, name)
        r = int(rows[int(share * rows.size)])
        copies.append((min(r + later, len(frames) - 1), r))
        out.duplicates[name] += 1
    for after, r in sorted(copies, reverse=True):
        order.insert(order.index(after) + 1, -1 - r)   # a copy of row r after row *after*
    take = np.array([i if i >= 0 else -1 - i for i in order])
    faulted = frames.take(take)
    faulted.data = data[take]
    stamp = stamps[take]
    is_copy = np.array([i < 0 for i in order])
    # a copy is stamped as the frame it follows in the log
    stamp[is_copy] = stamp[np.flatnonzero(is_copy) - 1]
    faulted.timestamp = stamp
    out.frames = faulted
    return out
