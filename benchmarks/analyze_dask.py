"""``evtribo analyze`` on a Dask cluster against the local process pool, by number of
workers: frames/s with a cold and a warm cache, and what the cluster costs per trial.

The study is the one of ``benchmarks/analyze.py`` (4 subjects x 6 trials x 30 s, both load
cells at 2 kHz, 1 % dropped frames, a real rig). Each configuration is timed best of
``--repeat`` runs, cold (a new, empty cache each run) and warm (the cache of the cold runs):

- local: ``analyze_study(jobs=N)``, the process pool (N worker processes);
- dask: ``analyze_study(scheduler=client)`` on a ``LocalCluster`` of N worker processes of
  one thread each (the cluster's start is timed apart: a real cluster is already running).

Then ``compare``'s bootstrap refits (:func:`~evtribo.fit.fit.fit_study`, every subject's
200 replicates) on the same clusters against the same refits here, best of ``--repeat``.

Baseline (named in every ratio): decoding alone, python-can's ``LogReader`` and cantools'
``decode_message`` frame by frame, as ``benchmarks/analyze.py`` builds it (timed on one trial
in the same run, scaled by the study's frame count). Run: ``python
benchmarks/analyze_dask.py [--workers 1,2] [--repeat 3] [--keep DIR]``; needs the dask extra.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import logging
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from evtribo.acquisition.simulator import TrialConfig, default_subjects, simulate_study
from evtribo.fit.fit import fit_study
from evtribo.fit.tables import read_results
from evtribo.results.pipeline import analyze_study


def _analyze_benchmark() -> Any:
    """benchmarks/analyze.py as a module (its baseline, the same for both benchmarks)."""
    path = Path(__file__).with_name("analyze.py")
    spec = importlib.util.spec_from_file_location("evtribo_bench_analyze", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def timed(repeat: int, run: Callable[[int], object]) -> float:
    """The shortest of *repeat* timings of ``run(i)``, s."""
    best = float("inf")
    for i in range(repeat):
        t = time.perf_counter()
        run(i)
        best = min(best, time.perf_counter() - t)
    return best


def cold_and_warm(base: Path, name: str, repeat: int, **kwargs: Any) -> tuple[float, float]:
    """Best cold and best warm time of ``analyze_study`` with *kwargs*, s."""
    study = base / "study"

    def cold(i: int) -> object:
        return analyze_study(study, base / f"out-{name}", cache_dir=base / f"cache-{name}-{i}",
                             force=True, **kwargs)

    def warm(i: int) -> object:
        return analyze_study(study, base / f"out-{name}", cache_dir=base / f"cache-{name}-0",
                             force=True, **kwargs)

    return timed(repeat, cold), timed(repeat, warm)


def main() -> None:
    import distributed

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", default="1,2", help="worker counts (default 1,2)")
    parser.add_argument("--repeat", type=int, default=3, help="runs per timing (best of)")
    parser.add_argument("--keep", metavar="DIR", help="write the study here and keep it")
    args = parser.parse_args()
    counts = [int(n) for n in args.workers.split(",")]
    logging.basicConfig(level=logging.ERROR)  # the study's warnings are not the point here
    bench = _analyze_benchmark()
    with tempfile.TemporaryDirectory() as tmp:
        base = (Path(args.keep) if args.keep else Path(tmp)).absolute()
        study = base / "study"
        cfg = dataclasses.replace(TrialConfig(), duration_s=30.0, fz_rate_Hz=2000.0,
                                  fx_rate_Hz=2000.0, drop_probability=0.01)
        simulate_study(study, default_subjects(4), amplitudes=(60, 80, 100, 120, 140),
                       config=cfg, force=True, realistic=True)
        logs = sorted(study.glob("*/*.log"))
        res = analyze_study(study, base / "out-check", jobs=1, cache_dir=base / "cache-check",
                            force=True)
        frames = int(res.trials["frames"].sum())
        n_one, t_one = bench.baseline_decode(logs[0], study / "rig" / "default.dbc")
        base_s = t_one * frames / n_one
        print(f"study: {len(logs)} trials, {frames:,} frames, "
              f"{sum(p.stat().st_size for p in logs) / 1e6:.0f} MB of candump logs")
        print(f"baseline, python-can LogReader + cantools decode_message, decoding only: "
              f"{n_one / t_one / 1e3:.0f} k frames/s, {base_s:.1f} s for the study (scaled)")
        tables = read_results(base / "out-check")
        fit_here = timed(args.repeat, lambda i: fit_study(tables))
        fits: list[tuple[int, float]] = []
        rows: list[tuple[str, int, float, float]] = []
        for n in counts:
            rows.append(("local", n, *cold_and_warm(base, f"local{n}", args.repeat, jobs=n)))
            t = time.perf_counter()
            with distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                          dashboard_address=":0") as cluster, \
                    distributed.Client(cluster, set_as_default=False) as client:
                start = time.perf_counter() - t
                rows.append(("dask", n, *cold_and_warm(base, f"dask{n}", args.repeat,
                                                       scheduler=client)))
                fits.append((n, timed(args.repeat,
                                      lambda i, c=client: fit_study(tables, scheduler=c))))
            print(f"LocalCluster of {n} worker(s) started in {start:.2f} s (not counted)")
        report(rows, frames, len(logs), base_s)
        print(f"compare's refits ({len(tables.subjects)} subjects): {fit_here:.3f} s here; "
              + "; ".join(f"{t:.3f} s on {n} Dask worker(s) ({t / fit_here:.2f}x the time)"
                          for n, t in fits))


def report(rows: list[tuple[str, int, float, float]], frames: int, trials: int,
           base_s: float) -> None:
    """Print the table and the cluster's overhead per trial."""
    print(f"{'run':<6} {'workers':>7} {'cold s':>7} {'cold M fr/s':>11} {'x baseline':>10} "
          f"{'warm s':>7} {'warm M fr/s':>11} {'x baseline':>10}")
    for kind, n, cold, warm in rows:
        print(f"{kind:<6} {n:>7} {cold:>7.2f} {frames / cold / 1e6:>11.2f} "
              f"{base_s / cold:>10.1f} {warm:>7.2f} {frames / warm / 1e6:>11.2f} "
              f"{base_s / warm:>10.1f}")
    times = {(kind, n): (cold, warm) for kind, n, cold, warm in rows}
    for n in sorted({n for _, n, _, _ in rows}):
        (lc, lw), (dc, dw) = times[("local", n)], times[("dask", n)]
        print(f"{n} worker(s): dask/local time cold {dc / lc:.2f}, warm {dw / lw:.2f}; "
              f"cluster overhead per trial cold {1e3 * (dc - lc) / trials:+.0f} ms, "
              f"warm {1e3 * (dw - lw) / trials:+.0f} ms")
    ns = sorted({n for _, n, _, _ in rows})
    if len(ns) > 1:
        for kind in ("local", "dask"):
            a, b = times[(kind, ns[0])], times[(kind, ns[-1])]
            print(f"{kind}: {ns[-1]} workers against {ns[0]}: {a[0] / b[0]:.2f}x cold, "
                  f"{a[1] / b[1]:.2f}x warm")


if __name__ == "__main__":
    main()
