"""A study of eight subjects at one drive frequency, analysed and compared, as a reviewer gets
it: every trial recorded without a finger-lifted stretch (so that each says its normal cell's
zero is unknown; the tangential cell is exact, and the study says so) and short (so that
most cells rest on fewer than five windows of a kind). Two amplitudes and 8-s trials keep it
quick (16 trials)."""

from __future__ import annotations

from pathlib import Path

from evtribo.acquisition.simulator import TrialConfig, simulate_study
from evtribo.acquisition.simulator.study import population_subjects
from evtribo.report.compare import compare
from evtribo.results.pipeline import analyze_study

AMPLITUDES = (80.0, 140.0)


def eight_subject_study(base: Path, *, models: str = "paper,hertz,circuit") -> Path:
    """Simulate, analyse and compare the study under *base*.

    Returns
    -------
    Path
        The result folder (compare's figures at 40 dpi, each trial's check among them).
    """
    study, out = base / "study", base / "out"
    simulate_study(study, population_subjects(8, seed=4), amplitudes=AMPLITUDES,
                   config=TrialConfig(duration_s=8.0, tare_s=0.0, fz_offset_N=0.02,
                                      seed=1), sine_trial=False)
    analyze_study(study, out, jobs=2, cache_dir=base / "cache")
    compare(out, dpi=40, models=models)
    return out
