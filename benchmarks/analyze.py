"""Wall time of ``evtribo analyze`` on a simulated study, with a cold and a warm cache.

The study: 4 subjects x 6 trials (5 square-wave amplitudes and one sine) x 30 s, both load
cells at 2 kHz, alternating ON/OFF, 1 % dropped frames. Run: ``python benchmarks/analyze.py
[--jobs N] [--keep DIR]``.

Baseline: decoding alone, the way a script would do it without evtribo, with python-can's
``LogReader`` and cantools' ``decode_message`` frame by frame (timed on one trial in the same
run and scaled by the study's frame count): the whole analysis is compared against it.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import tempfile
import time
from pathlib import Path

import can
import cantools

from evtribo.acquisition.simulator import TrialConfig, default_subjects, simulate_study
from evtribo.analysis.pipeline import analyze_study


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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=None, help="worker processes")
    parser.add_argument("--keep", metavar="DIR", help="write the study here and keep it")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(args.keep) if args.keep else Path(tmp)
        study, cache = base / "study", base / "cache"
        cfg = dataclasses.replace(TrialConfig(), duration_s=30.0, fz_rate_Hz=2000.0,
                                  fx_rate_Hz=2000.0, drop_probability=0.01)
        t = time.perf_counter()
        simulate_study(study, default_subjects(4), amplitudes=(60, 80, 100, 120, 140),
                       config=cfg, force=True)
        sim = time.perf_counter() - t
        logs = sorted(study.glob("*/*.log"))
        size = sum(p.stat().st_size for p in logs) / 1e6
        jobs = args.jobs or os.cpu_count() or 1
        print(f"study: {len(logs)} trials, {size:.0f} MB of candump logs "
              f"(simulated in {sim:.1f} s); {jobs} worker process(es)")
        t = time.perf_counter()
        res = analyze_study(study, base / "out-cold", jobs=jobs, cache_dir=cache, force=True)
        cold = time.perf_counter() - t
        t = time.perf_counter()
        analyze_study(study, base / "out-warm", jobs=jobs, cache_dir=cache, force=True)
        warm = time.perf_counter() - t
        s = res.summary
        frames = int(res.trials["frames"].sum())
        n_one, t_one = baseline_decode(logs[0], study / "rig" / "default.dbc")
        base_total = t_one * frames / n_one
        print(f"analyze, cold cache: {cold:6.2f} s  ({cold / len(logs):.2f} s per trial, "
              f"{frames / cold / 1e6:.2f} M frames/s)")
        print(f"analyze, warm cache: {warm:6.2f} s  ({warm / len(logs):.2f} s per trial); "
              f"warm/cold speed-up {cold / warm:.1f}x")
        print(f"baseline, python-can LogReader + cantools decode_message, decoding only: "
              f"{n_one / t_one / 1e3:.0f} k frames/s on {logs[0].parent.name}/{logs[0].name}, "
              f"{base_total:.1f} s for the study's {frames:,} frames (scaled)")
        print(f"ratio: whole analysis (cold) {base_total / cold:.1f}x faster than the "
              f"baseline's decoding alone; warm {base_total / warm:.1f}x")
        print(f"{s['trials_analysed']} trials analysed, {s['windows_on']} ON and "
              f"{s['windows_off']} OFF windows, {len(s['warnings'])} warning(s)")


if __name__ == "__main__":
    main()
