"""Time per trial of the check figures ``evtribo compare`` makes for every trial
(:func:`evtribo.figures.trial_plots.trial_check_figures`), and of ``evtribo plot trial``.

The study: 2 subjects x 6 trials (5 square-wave amplitudes and one sine) x 30 s, on a real
rig (load-cell offsets, drift, 50 Hz hum, a tare stretch, a person's strokes and
lift-offs), decoded once (a warm cache, as after ``evtribo analyze``). Run: ``python
benchmarks/trial_check.py [--keep DIR]``.

Baseline: the analysis of the same trial alone (:func:`evtribo.analysis.trial.
analyze_signals` on the decoded trial read from the cache, what each worker of ``evtribo
analyze`` does), timed in the same run: a check repeats that analysis, then draws and saves
the figure; the ratio says what the figure adds.
"""

from __future__ import annotations

import argparse
import logging
import tempfile
import time
from pathlib import Path

from matplotlib.figure import Figure

from evtribo.acquisition.simulator import TrialConfig, default_subjects, simulate_study
from evtribo.analysis.trial import analyze_signals
from evtribo.canlog.cache import load_trial
from evtribo.figures.trial_plots import trial_check_figures
from evtribo.results.pipeline import analyze_study
from evtribo.results.trial_view import settings_of
from evtribo.results.workers import trial_meta
from evtribo.study import load_study


def _analysis_only(study_dir: Path, cache: Path) -> float:
    """Seconds to read every trial from the cache and analyse it, no figure."""
    study = load_study(study_dir)
    assert study.rig is not None
    settings = settings_of(study, None)
    t = time.perf_counter()
    for ref in study.trials:
        analyze_signals(load_trial(ref.log_path, study.rig, cache), trial_meta(ref),
                        settings=settings, calibration=study.rig.calibration)
    return time.perf_counter() - t


def _figures(study_dir: Path, cache: Path, out: Path, fmt: str) -> tuple[float, int]:
    """Seconds to make and save every trial's check figure in *fmt*; their count."""
    t = time.perf_counter()
    n = 0
    for fig in trial_check_figures(study_dir, cache_dir=cache):
        figure = fig.axes.figure
        assert isinstance(figure, Figure)
        figure.savefig(out / f"{fig.stem}.{fmt}", dpi=300 if fmt == "png" else "figure")
        n += 1
    return time.perf_counter() - t, n


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--keep", type=Path, help="keep the study and figures here")
    args = parser.parse_args()
    logging.getLogger("evtribo").setLevel(logging.ERROR)
    with tempfile.TemporaryDirectory() as tmp:
        base = args.keep or Path(tmp)
        study, cache, out = base / "study", base / "cache", base / "figures"
        out.mkdir(parents=True, exist_ok=True)
        simulate_study(study, default_subjects(2), config=TrialConfig(duration_s=30.0),
                       realistic=True, force=True)
        analyze_study(study, base / "out", jobs=1, cache_dir=cache, force=True)  # warms it
        n_trials = len(load_study(study).trials)
        base_s = min(_analysis_only(study, cache) for _ in range(2))
        print(f"study: {n_trials} trials of 30 s; baseline, the analysis alone (from the "
              f"cache): {1e3 * base_s / n_trials:.0f} ms per trial")
        for fmt in ("png", "svg", "pdf"):
            total, n = _figures(study, cache, out, fmt)
            print(f"check figures, {fmt}: {1e3 * total / n:.0f} ms per trial "
                  f"({total / base_s:.1f}x the analysis alone; the figure adds "
                  f"{1e3 * (total - base_s) / n:.0f} ms)")


if __name__ == "__main__":
    main()
