"""Throughput of reading and decoding a candump log: evtribo versus python-can + cantools.

Builds a 1,000,000-frame candump log of the default rig (FzCell and FxCell at 1 kHz each,
HvStatus at 10 Hz) in a temporary directory, then prints:

- evtribo ``read_frames`` + ``decode_trial`` on the whole file, frames/s (best of 3);
- python-can ``LogReader`` + cantools ``decode_message`` per frame, frames/s, timed on the
  first 200,000 frames of the same log (it is linear in the frame count);
- their ratio;
- peak memory of evtribo's read + decode against the raw log's size, in fresh subprocesses:
  numpy's allocations traced by tracemalloc, and the growth of the peak resident set size
  (``VmHWM``, Linux) over what the interpreter and imports already use.

Run: ``python benchmarks/ingest.py [--frames N]``.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import subprocess
import sys
import tempfile
import time

import can
import numpy as np

from evtribo.canlog.decode import decode_trial
from evtribo.canlog.io import FrameTable, read_frames, write_candump
from evtribo.canlog.rig import default_rig

BASELINE_FRAMES = 200_000


def build_log(path: str, n_frames: int) -> None:
    """Write an *n_frames* candump log of the default rig to *path*."""
    t0 = 1763700000.0
    n_hv = n_frames // 201
    n_cell = (n_frames - n_hv) // 2
    n_hv = n_frames - 2 * n_cell
    rng = np.random.default_rng(1)
    k = np.arange(n_cell)
    t_fz = t0 + k * 1e-3 + rng.normal(0, 2e-6, n_cell).clip(-1e-5, 1e-5)
    t_fx = t0 + 0.0004 + k * 1.00001e-3
    t_hv = t0 + 0.0002 + np.arange(n_hv) * 0.1
    ts = np.concatenate([t_fz, t_fx, t_hv])
    ids = np.concatenate([np.full(n_cell, 0xC1), np.full(n_cell, 0xC2), np.full(n_hv, 0x1A0)])
    data = np.zeros((n_frames, 8), dtype=np.uint8)
    fz = np.round((0.5 + 0.05 * np.sin(k * 0.01)) / 1e-5).astype(np.int64)
    fx = np.round((0.25 + 0.05 * np.sin(k * 0.02)) / 1e-5).astype(np.int64)
    for rows, force in ((slice(0, n_cell), fz), (slice(n_cell, 2 * n_cell), fx)):
        raw = force & 0xFFFFFF
        data[rows, 0], data[rows, 1], data[rows, 2] = raw & 255, (raw >> 8) & 255, raw >> 16
        data[rows, 4], data[rows, 5] = 0xC4, 0x09  # 25.00 degC
        data[rows, 7] = k & 255
    hv = slice(2 * n_cell, n_frames)
    on = (np.arange(n_hv) // 10) % 2
    data[hv, 0] = on | (1 << 1)  # square
    amp = 14000  # 140.00 V
    data[hv, 1], data[hv, 2] = amp & 255, amp >> 8
    freq = 1_000_000  # 10 kHz
    data[hv, 3], data[hv, 4], data[hv, 5] = freq & 255, (freq >> 8) & 255, freq >> 16
    order = np.argsort(ts, kind="stable")
    frames = FrameTable(
        timestamp=ts[order], arbitration_id=ids[order].astype(np.uint32),
        is_extended=np.zeros(n_frames, bool), is_remote=np.zeros(n_frames, bool),
        is_error=np.zeros(n_frames, bool), is_fd=np.zeros(n_frames, bool),
        dlc=np.full(n_frames, 8, np.uint8), data=data[order], channel="vcan0")
    write_candump(path, frames)


def evtribo_run(path: str) -> tuple[float, int]:
    """Seconds for read + decode, and frames decoded."""
    rig = default_rig()
    start = time.perf_counter()
    frames, _ = read_frames(path)
    trial = decode_trial(frames, rig)
    elapsed = time.perf_counter() - start
    return elapsed, len(frames) if trial.frames else 0


def baseline_run(path: str) -> tuple[float, int]:
    """Seconds for python-can LogReader + cantools decode_message, and frames."""
    db = default_rig().database
    start = time.perf_counter()
    n = 0
    for msg in can.LogReader(path):
        db.decode_message(msg.arbitration_id, msg.data)
        n += 1
    return time.perf_counter() - start, n


_MEMORY_PROBE = """
import json, sys, tracemalloc
from evtribo.canlog.decode import decode_trial
from evtribo.canlog.io import read_frames
from evtribo.canlog.rig import default_rig

def hwm():  # peak resident set size, bytes (Linux)
    with open("/proc/self/status") as fh:
        return next(int(l.split()[1]) * 1024 for l in fh if l.startswith("VmHWM"))

rig = default_rig()
traced = sys.argv[2] == "tracemalloc"
rss0 = hwm()
if traced:
    tracemalloc.start()
frames, _ = read_frames(sys.argv[1])
trial = decode_trial(frames, rig)
peak = tracemalloc.get_traced_memory()[1] if traced else hwm() - rss0
print(json.dumps(peak))
"""


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=1_000_000)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "trial.log")
        build_log(path, args.frames)
        size = os.path.getsize(path)
        sub = os.path.join(tmp, "subset.log")
        n_base = min(BASELINE_FRAMES, args.frames)
        with open(path, "rb") as src, open(sub, "wb") as dst:
            dst.writelines(itertools.islice(src, n_base))
        print(f"log: {args.frames:,} frames, {size / 1e6:.1f} MB ({path})")
        runs = [evtribo_run(path) for _ in range(3)]
        t_ev = min(r[0] for r in runs)
        ev_rate = runs[0][1] / t_ev
        print(f"evtribo read_frames + decode_trial: {t_ev:.3f} s, {ev_rate / 1e6:.2f} M frames/s"
              " (best of 3)")
        t_b, n_b = baseline_run(sub)
        b_rate = n_b / t_b
        print(f"python-can LogReader + cantools decode_message: {t_b:.2f} s for the first "
              f"{n_b:,} frames, {b_rate / 1e3:.1f} k frames/s")
        print(f"ratio: {ev_rate / b_rate:.1f}x (target >= 30x)")
        mem = {mode: json.loads(subprocess.run(
            [sys.executable, "-c", _MEMORY_PROBE, path, mode], check=True,
            capture_output=True, text=True).stdout) for mode in ("tracemalloc", "rss")}
        print(f"peak memory of read + decode: {mem['tracemalloc'] / 1e6:.1f} MB traced "
              f"(tracemalloc) = {mem['tracemalloc'] / size:.2f}x the raw log; peak RSS growth "
              f"{mem['rss'] / 1e6:.1f} MB = {mem['rss'] / size:.2f}x (target < 3x)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
