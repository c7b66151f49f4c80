"""Wall time of ``evtribo analyze`` on a simulated study, with a cold and a warm cache, and what
taring costs.

The study: 4 subjects x 6 trials (5 square-wave amplitudes and one sine) x 30 s, both load
cells at 2 kHz, alternating ON/OFF, 1 % dropped frames, on a real rig (load-cell offsets,
drift, 50 Hz hum, a tare stretch, a person's strokes and lift-offs). Run: ``python
benchmarks/analyze.py [--jobs N] [--keep DIR]``.

Baseline: decoding alone, the way a script would do it without evtribo, with python-can's
``LogReader`` and cantools' ``decode_message`` frame by frame (timed on one trial in the same
run and scaled by the study's frame count): the whole analysis is compared against it.

Taring (hum removal, calibration, the finger-lifted stretches, the friction loop and the
second search for windows it needs) is timed against the same analysis with ``tare =
"none"`` and ``hum = "keep"``: over the whole study with a warm cache, and trial by
trial in one process (the decoded trials in memory, best of three).
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import os
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import can
import cantools

from evtribo.acquisition.simulator import TrialConfig, default_subjects, simulate_study
from evtribo.analysis.pipeline import analyze_study
from evtribo.analysis.settings import AnalysisSettings
from evtribo.analysis.trial import TrialMeta, analyze_signals
from evtribo.cache import load_trial
from evtribo.study import load_study

NO_TARE = {"tare": "none", "hum": "keep"}


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
    logging.basicConfig(level=logging.ERROR)  # the study's warnings are not the point here
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(args.keep) if args.keep else Path(tmp)
        study, cache = base / "study", base / "cache"
        cfg = dataclasses.replace(TrialConfig(), duration_s=30.0, fz_rate_Hz=2000.0,
                                  fx_rate_Hz=2000.0, drop_probability=0.01)
        t = time.perf_counter()
        simulate_study(study, default_subjects(4), amplitudes=(60, 80, 100, 120, 140),
                       config=cfg, force=True, realistic=True)
        sim = time.perf_counter() - t
        logs = sorted(study.glob("*/*.log"))
        size = sum(p.stat().st_size for p in logs) / 1e6
        jobs = args.jobs or os.cpu_count() or 1
        print(f"study: {len(logs)} trials, {size:.0f} MB of candump logs "
              f"(simulated in {sim:.1f} s); {jobs} worker process(es)")
        t = time.perf_counter()
        res = analyze_study(study, base / "out-cold", jobs=jobs, cache_dir=cache, force=True)
        cold = time.perf_counter() - t
        warm = best_of(3, lambda: analyze_study(study, base / "out-warm", jobs=jobs,
                                                cache_dir=cache, force=True))
        untared = best_of(3, lambda: analyze_study(study, base / "out-untared", jobs=jobs,
                                                   cache_dir=cache, force=True,
                                                   overrides=NO_TARE))
        per_trial = per_trial_times(study, cache)
        s = res.summary
        frames = int(res.trials["frames"].sum())
        n_one, t_one = baseline_decode(logs[0], study / "rig" / "default.dbc")
        base_total = t_one * frames / n_one
        print(f"analyze, cold cache: {cold:6.2f} s  ({cold / len(logs):.2f} s per trial, "
              f"{frames / cold / 1e6:.2f} M frames/s)")
        print(f"analyze, warm cache: {warm:6.2f} s  ({warm / len(logs):.2f} s per trial, best of "
              "3); "
              f"warm/cold speed-up {cold / warm:.1f}x")
        print(f"baseline, python-can LogReader + cantools decode_message, decoding only: "
              f"{n_one / t_one / 1e3:.0f} k frames/s on {logs[0].parent.name}/{logs[0].name}, "
              f"{base_total:.1f} s for the study's {frames:,} frames (scaled)")
        print(f"ratio: whole analysis (cold) {base_total / cold:.1f}x faster than the "
              f"baseline's decoding alone; warm {base_total / warm:.1f}x")
        print(f"{s['trials_analysed']} trials analysed, {s['windows_on']} ON and "
              f"{s['windows_off']} OFF windows, {len(s['warnings'])} warning(s)")
        print(f"taring, whole analysis (warm): {warm:.2f} s with it, {untared:.2f} s without "
              f"(tare = none, hum = keep): {100 * (warm - untared) / warm:.0f} % of "
              "the analysis time")
        auto, none = per_trial
        print(f"taring, per trial in one process: {1e3 * auto:.1f} ms with it, "
              f"{1e3 * none:.1f} ms without: {100 * (auto - none) / auto:.0f} % of the "
              "trial's analysis")


def best_of(n: int, run: Callable[[], object]) -> float:
    """The shortest of *n* timings of *run*, s."""
    best = float("inf")
    for _ in range(n):
        t = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - t)
    return best


def per_trial_times(study: Path, cache: Path) -> tuple[float, float]:
    """Mean time to analyse one decoded trial (best of three passes over the study), with
    taring and without, s."""
    st = load_study(study)
    decoded = [(load_trial(ref.log_path, st.rig, cache), TrialMeta(ref.subject, ref.name))
               for ref in st.trials]
    out = []
    for settings in (AnalysisSettings(), AnalysisSettings(**NO_TARE)):
        best = float("inf")
        for _ in range(3):
            t = time.perf_counter()
            for signals, meta in decoded:
                analyze_signals(signals, meta, settings=settings, calibration=st.rig.calibration)
            best = min(best, time.perf_counter() - t)
        out.append(best / len(decoded))
    return out[0], out[1]


if __name__ == "__main__":
    main()
