"""A small simulated study for the tests of what a lab plugs in (a friction law, a population
model): three subjects at three amplitudes, short alternating trials, no sine trial, with
extra tables appended to its study.toml before it is analysed."""

from __future__ import annotations

from pathlib import Path

from evtribo.acquisition.simulator import TrialConfig, default_subjects, simulate_study
from evtribo.cli import main

AMPLITUDES = (60.0, 100.0, 140.0)


def small_study(root: Path, toml: str = "") -> Path:
    """Simulate the study in *root*, *toml* appended to its study.toml.

    Parameters
    ----------
    root : Path
    toml : str
        Tables for study.toml (``[analysis]``, ``[population]``).

    Returns
    -------
    Path
        *root*.
    """
    simulate_study(root, default_subjects(3, seed=4), AMPLITUDES,
                   config=TrialConfig(duration_s=12.0, seed=4), sine_trial=False)
    if toml:
        with (root / "study.toml").open("a", encoding="utf-8") as f:
            f.write("\n" + toml)
    return root


def analyse(study: Path, out: Path, *options: str) -> Path:
    """``evtribo analyze STUDY --out OUT --jobs 1`` in this process (a law registered here
    is seen), *options* added.

    Parameters
    ----------
    study, out : Path
    *options : str

    Returns
    -------
    Path
        *out*.
    """
    assert main(["analyze", str(study), "--out", str(out), "--jobs", "1", *options]) == 0
    return out
