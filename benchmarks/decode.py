"""`evtribo decode` end to end against a plain python-can + cantools script, by log size.

Builds candump logs of a rig unlike the default one (load cells at 0x101 and on the extended
ID 0x18FF0102, the second a Motorola signal; an amplifier status; foreign frames of every
length from 0 to 8 bytes, so lines differ in length), of 1, 2 and 4 M frames (``--frames``
to choose), then times in fresh processes, each to a Parquet file:

- ``evtribo decode LOG --dbc DBC -o OUT.parquet`` (the command line, start-up included);
- the baseline: a script that reads the log with python-can's ``LogReader``, decodes each
  frame of the DBC with cantools' ``decode_message`` and writes the rows with pandas.

It prints the seconds, frames/s and peak resident set size of each, their ratios, and how
evtribo's peak memory grows with the log's size. The logs are built in a process of their
own; each peak resident set size is the measured child's (``wait4``'s ``ru_maxrss``). The
baseline is timed on every size up to ``--baseline-max`` frames (default 2 M); above, its
time is scaled from the largest size timed (it is linear in frames) and its memory is not
reported. On the largest log it also prints the limits the figures are measured against:
``cat`` and ``wc -l`` of the log, evtribo's reader in-process on it and on a log of
fixed-width lines, and the start-up of ``python -m evtribo decode``'s imports.

Run: ``python benchmarks/decode.py [--frames 1e6,2e6,4e6] [--large]`` (``--large`` adds a
16 M-frame log: a few minutes more, most of it building the log).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from _measure import run

from evtribo.canlog.io import FrameTable, write_candump

DBC = '''VERSION ""
NS_ :
BS_:
BU_: Cell1 Cell2 Amp
BO_ 257 Cell1: 8 Cell1
 SG_ Fn : 0|24@1- (1e-05,0) [-80|80] "N" Vector__XXX
 SG_ FnCount : 56|8@1+ (1,0) [0|255] "" Vector__XXX
BO_ 2566848770 Cell2: 6 Cell2
 SG_ Ft : 7|16@0- (0.0001,0) [-3|3] "N" Vector__XXX
 SG_ FtCount : 23|8@0+ (1,0) [0|255] "" Vector__XXX
BO_ 416 AmpStatus: 3 Amp
 SG_ On : 0|1@1+ (1,0) [0|1] "" Vector__XXX
 SG_ Volts : 8|16@1+ (0.01,0) [0|655.35] "V" Vector__XXX
'''

BASELINE = r'''
import sys, can, cantools, pandas as pd
db = cantools.database.load_file(sys.argv[2])
known = {(m.frame_id, m.is_extended_frame): m for m in db.messages}
rows = []
for msg in can.LogReader(sys.argv[1]):
    m = known.get((msg.arbitration_id, msg.is_extended_id))
    if m is None or msg.is_error_frame or msg.is_remote_frame or len(msg.data) < m.length:
        continue
    row = m.decode(msg.data, decode_choices=False)
    row["timestamp"] = msg.timestamp
    row["message"] = m.name
    rows.append(row)
pd.DataFrame(rows).to_parquet(sys.argv[3], index=False)
'''


def build_log(path: Path, n_frames: int, seed: int = 1) -> None:
    """A candump log of *n_frames*: two cells at 1 kHz, a 10 Hz status, foreign traffic."""
    rng = np.random.default_rng(seed)
    n_status = max(n_frames // 250, 1)
    n_foreign = n_frames // 5
    n_cell = (n_frames - n_status - n_foreign) // 2
    n_foreign = n_frames - n_status - 2 * n_cell
    t0 = 1763700000.0
    k = np.arange(n_cell)
    t = np.concatenate([t0 + k * 1e-3, t0 + 4e-4 + k * 1.00002e-3,
                        t0 + 2e-4 + np.arange(n_status) * 0.1,
                        np.sort(rng.uniform(t0, t0 + n_cell * 1e-3, n_foreign))])
    ids = np.concatenate([np.full(n_cell, 0x101), np.full(n_cell, 0x18FF0102),
                          np.full(n_status, 0x1A0),
                          rng.choice([0x0F0, 0x3FF, 0x7E8, 0x1ABCDE01], n_foreign)])
    ext = ids > 0x7FF
    dlc = np.concatenate([np.full(n_cell, 8), np.full(n_cell, 6), np.full(n_status, 3),
                          rng.integers(0, 9, n_foreign)]).astype(np.uint8)
    data = rng.integers(0, 256, (n_frames, 8)).astype(np.uint8)
    fn = np.round((0.5 + 0.05 * np.sin(k * 0.01)) / 1e-5).astype(np.int64) & 0xFFFFFF
    data[:n_cell, 0], data[:n_cell, 1], data[:n_cell, 2] = fn & 255, (fn >> 8) & 255, fn >> 16
    data[:n_cell, 7] = k & 255
    ft = np.round((0.2 * np.sign(np.sin(k * 0.003)) + 0.01) / 1e-4).astype(np.int64) & 0xFFFF
    cells2 = slice(n_cell, 2 * n_cell)
    data[cells2, 0], data[cells2, 1], data[cells2, 2] = ft >> 8, ft & 255, k & 255
    order = np.argsort(t, kind="stable")
    frames = FrameTable(
        timestamp=t[order], arbitration_id=ids[order].astype(np.uint32),
        is_extended=ext[order], is_remote=np.zeros(n_frames, bool),
        is_error=np.zeros(n_frames, bool), is_fd=np.zeros(n_frames, bool),
        dlc=dlc[order], data=data[order], channel="can0")
    write_candump(path, frames)


def fixed_width_log(path: Path, n_frames: int) -> None:
    """A log of *n_frames* lines of one length (one ID, 8 bytes): the reader's best case."""
    rng = np.random.default_rng(2)
    write_candump(path, FrameTable(
        timestamp=1763700000.0 + np.arange(n_frames) * 2.5e-4,
        arbitration_id=np.full(n_frames, 0x101, np.uint32),
        is_extended=np.zeros(n_frames, bool), is_remote=np.zeros(n_frames, bool),
        is_error=np.zeros(n_frames, bool), is_fd=np.zeros(n_frames, bool),
        dlc=np.full(n_frames, 8, np.uint8),
        data=rng.integers(0, 256, (n_frames, 8)).astype(np.uint8), channel="can0"))


READ_ONLY = """
import sys, time
from evtribo.canlog.io import FrameStream
t = time.perf_counter()
n = sum(len(b) for b in FrameStream(sys.argv[1]))
print(n / (time.perf_counter() - t))
"""


def limits(log: Path, tmp: Path, n: int) -> None:
    """How fast this machine reads the log (cat, wc -l), parses it in evtribo's reader
    (in-process, start-up excluded), and parses a log of fixed-width lines of as many
    frames; and what start-up (the interpreter and the imports of decode) costs."""
    size = log.stat().st_size / 1e6
    t_cat, _ = run(["cat", str(log)])  # to /dev/null
    t_wc, _ = run(["wc", "-l", str(log)])
    fixed = tmp / "fixed.log"
    subprocess.run([sys.executable, __file__, "--build-fixed", str(fixed), str(n)], check=True)
    rates = []
    for path in (log, fixed):
        out = subprocess.run([sys.executable, "-c", READ_ONLY, str(path)], check=True,
                             capture_output=True, text=True).stdout
        rates.append(float(out))
    fixed.unlink()
    t_imp, rss_imp = run([sys.executable, "-c", "import evtribo.cli.setup.decode, pyarrow.parquet"])
    print(f"limits on the {n / 1e6:g} M-frame log ({size:.0f} MB): cat {size / t_cat:.0f} MB/s "
          f"({t_cat:.2f} s), wc -l {size / t_wc:.0f} MB/s ({t_wc:.2f} s); evtribo's reader "
          f"in-process {rates[0] / 1e6:.2f} M frames/s ({n / rates[0]:.2f} s), on fixed-width "
          f"lines {rates[1] / 1e6:.2f} M frames/s; start-up and imports of decode "
          f"{t_imp:.2f} s, {rss_imp:.0f} MB", flush=True)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", default="1e6,2e6,4e6",
                        help="log sizes in frames, comma-separated")
    parser.add_argument("--large", action="store_true", help="add a 16 M-frame log")
    parser.add_argument("--baseline-max", type=float, default=2e6)
    args = parser.parse_args()
    sizes = [int(float(s)) for s in args.frames.split(",")] + ([16_000_000] if args.large
                                                               else [])
    evtribo = [sys.executable, "-m", "evtribo", "decode"]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        dbc = Path(tmp) / "rig.dbc"
        dbc.write_text(DBC)
        base_rate = None
        for n in sizes:
            log = Path(tmp) / f"log-{n}.log"
            subprocess.run([sys.executable, __file__, "--build", str(log), str(n)], check=True)
            size_mb = log.stat().st_size / 1e6
            t_ev, rss_ev = run([*evtribo, str(log), "--dbc", str(dbc), "-o",
                                str(Path(tmp) / "ev.parquet"), "--force"])
            if n <= args.baseline_max or base_rate is None:
                t_b, rss_b = run([sys.executable, "-c", BASELINE, str(log), str(dbc),
                                  str(Path(tmp) / "base.parquet")])
                base_rate = n / t_b
                measured = True
            else:
                t_b, rss_b, measured = n / base_rate, float("nan"), False
            rows.append((n, size_mb, t_ev, rss_ev, t_b, rss_b, measured))
            print(f"{n / 1e6:4.1f} M frames ({size_mb:6.1f} MB): evtribo decode {t_ev:6.2f} s "
                  f"({n / t_ev / 1e6:.2f} M frames/s, peak RSS {rss_ev:6.0f} MB); baseline "
                  f"{t_b:6.2f} s{'' if measured else ' (scaled)'} "
                  f"({n / t_b / 1e3:.0f} k frames/s"
                  + (f", peak RSS {rss_b:.0f} MB" if measured else "") + "); "
                  f"ratio {t_b / t_ev:.1f}x (target >= 10x)", flush=True)
            if n == sizes[-1]:
                limits(log, Path(tmp), n)
            log.unlink()
    if len(rows) >= 2:
        (n0, s0, _, r0, *_), (n1, s1, _, r1, *_) = rows[0], rows[-1]
        print(f"peak RSS growth from {n0 / 1e6:g} M to {n1 / 1e6:g} M frames: "
              f"{r1 - r0:.0f} MB for {s1 - s0:.0f} MB more log = {(r1 - r0) / (s1 - s0):.2f}x "
              "the added log size (target < 0.5x, ideally flat)")
    return 0


if __name__ == "__main__":
    if sys.argv[1:2] in (["--build"], ["--build-fixed"]):  # logs built in a process of their own
        (build_log if sys.argv[1] == "--build" else fixed_width_log)(Path(sys.argv[2]),
                                                                     int(sys.argv[3]))
        sys.exit(0)
    sys.exit(main())
