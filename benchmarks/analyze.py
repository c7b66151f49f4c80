"""``evtribo analyze`` against the size of the study: seconds, frames/s and peak memory, cold
and warm cache, each as a ratio to a python-can + cantools decoding of the same study.

The studies: 4 subjects x 6 trials (5 square-wave amplitudes and one sine), both load cells
at 2 kHz, alternating ON/OFF, 1 % dropped frames, on a real rig (load-cell offsets, drift,
50 Hz hum, a tare stretch, a person's strokes and lift-offs); the trials last as long as it
takes to hold 1 and 4 M frames in all (``--large`` adds 16 M; ``--frames`` to choose). Each
study is simulated in this process; ``evtribo analyze`` runs in a fresh process (start-up
included), first with an empty cache (cold), then again (warm); its peak resident set size
is the child's own (``wait4``'s ``ru_maxrss``), so the simulation is not counted.

Four runs of each study, one after the other with one cache folder: *cold* (an empty
cache: every log read, decoded and analysed), *warm* (nothing changed: the last results
written again, :mod:`evtribo.results.unchanged`), *trials kept* (the study's analysis
forgotten, as a file added to the study folder does: each trial's outcome taken from the
cache, :mod:`evtribo.results.reuse`) and *recompute* (``--recompute``, what a changed
setting costs: every trial analysed again from its decoded signals in the cache).

Baseline: decoding alone, the way a script would do it without evtribo, with python-can's
``LogReader`` and cantools' ``decode_message`` frame by frame, timed on the study's first
trial in the same run and scaled by the study's frame count; the whole analysis is compared
against it. The machine's speed drifts (a shared machine): cold, warm and the baseline are
measured ``--repeat`` times (3 by default), in turn, so that each sees the same stretches of
it, and their medians are compared (with the range of the runs). Run:
``python benchmarks/analyze.py [--jobs N] [--large] [--repeat N]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

import can
import cantools
from _measure import run

from evtribo.acquisition.simulator import TrialConfig, default_subjects, simulate_study
from evtribo.results.unchanged import ENTRIES

#: Frames per second of trial: two load cells at 2 kHz.
FRAMES_PER_S = 4000
TRIALS = 24


def baseline_decode(log: Path, dbc: Path) -> tuple[int, float]:
    """Frames of *log* and the seconds python-can + cantools take to read and decode them."""
    db = cantools.database.load_file(str(dbc))
    ids = {m.frame_id for m in db.messages}
    t = time.perf_counter()
    n = 0
    for msg in can.LogReader(log):
        n += 1
        if msg.arbitration_id in ids:
            db.decode_message(msg.arbitration_id, msg.data)
    return n, time.perf_counter() - t


def study_of(root: Path, frames: int) -> tuple[Path, int, float]:
    """Simulate a study of about *frames* frames; its folder, frame count and MB of logs."""
    duration = frames / TRIALS / FRAMES_PER_S
    cfg = dataclasses.replace(TrialConfig(), duration_s=duration, fz_rate_Hz=2000.0,
                              fx_rate_Hz=2000.0, drop_probability=0.01)
    study = root / "study"
    simulate_study(study, default_subjects(4), amplitudes=(60, 80, 100, 120, 140),
                   config=cfg, force=True, realistic=True)
    logs = sorted(study.glob("*/*.log"))
    lines = 0
    for log in logs:
        with open(log, "rb") as fh:
            lines += sum(chunk.count(b"\n") for chunk in iter(lambda f=fh: f.read(1 << 20), b""))
    return study, lines, sum(p.stat().st_size for p in logs) / 1e6


def _spread(values: list[float]) -> str:
    """The runs' range, or that there was one run."""
    if len(values) == 1:
        return "one run"
    return f"{len(values)} runs {min(values):.2f}-{max(values):.2f} s"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", default="1e6,4e6", help="study sizes in frames")
    parser.add_argument("--large", action="store_true", help="add a 16 M-frame study")
    parser.add_argument("--jobs", type=int, default=None, help="worker processes")
    parser.add_argument("--repeat", type=int, default=3,
                        help="cold, warm and baseline runs, in turn (medians compared)")
    args = parser.parse_args()
    logging.basicConfig(level=logging.ERROR)  # the studies' warnings are not the point here
    sizes = [int(float(s)) for s in args.frames.split(",")] + ([16_000_000] if args.large
                                                               else [])
    jobs = args.jobs or os.cpu_count() or 1
    print(f"{TRIALS} trials per study, {jobs} worker process(es); evtribo analyze in a fresh "
          "process each time (start-up included)")
    for n in sizes:
        with tempfile.TemporaryDirectory() as tmp:
            root = Path(tmp)
            study, frames, size = study_of(root, n)
            cmd = [sys.executable, "-m", "evtribo", "analyze", str(study), "--jobs", str(jobs),
                   "--cache-dir", str(root / "cache"), "--force"]
            first = sorted(study.glob("*/*.log"))[0]
            dbc = study / "rig" / "default.dbc"
            colds, warms, bases = [], [], []
            for _ in range(max(1, args.repeat)):  # in turn: the three share the machine's drifts
                shutil.rmtree(root / "cache", ignore_errors=True)
                colds.append(run([*cmd, "--out", str(root / "out-cold")]))
                warms.append(run([*cmd, "--out", str(root / "out-warm")]))
                n_one, t_one = baseline_decode(first, dbc)
                bases.append(t_one * frames / n_one)
            # what a change outside the trials costs (a file added to the study folder, the
            # analysis of the study forgotten): every trial's outcome reused
            shutil.rmtree(root / "cache" / ENTRIES)
            kept = run([*cmd, "--out", str(root / "out-kept")])
            again = run([*cmd, "--out", str(root / "out-again"), "--recompute"])
            base = statistics.median(bases)
            print(f"{frames / 1e6:5.2f} M frames ({size:6.0f} MB of logs); baseline decoding "
                  f"{base:6.1f} s ({frames / base / 1e3:.0f} k frames/s, timed on one trial; "
                  f"{_spread(bases)})")
            for name, runs, target in (("cold", colds, " (target >= 25x)"),
                                       ("warm", warms, " (target >= 40x)"),
                                       ("trials kept", [kept], ""), ("recompute", [again], "")):
                secs = statistics.median(r[0] for r in runs)
                rss = max(r[1] for r in runs)
                spread = f"; {_spread([r[0] for r in runs])}" if len(runs) > 1 else ""
                print(f"  {name:11s} {secs:6.2f} s ({frames / secs / 1e6:5.2f} M frames/s, "
                      f"peak RSS {rss:4.0f} MB{spread}): {base / secs:5.1f}x the baseline"
                      f"{target}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
