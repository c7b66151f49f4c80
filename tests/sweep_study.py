"""A simulated frequency sweep, analysed: three subjects, each with a gap that leaks (its
corner between 20 and 300 Hz), square drives at 100 V from 20 Hz to 10 kHz, through the
simulated rig and ``analyze_study`` (the chain ``simulate -> analyze`` of the command line)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from evtribo.acquisition.simulator import TrialConfig, default_subjects, write_trial
from evtribo.results.pipeline import analyze_study
from sweep_data import r_g_for_corner

SWEEP_HZ = (20.0, 50.0, 100.0, 200.0, 500.0, 1000.0, 3000.0, 10000.0)
CORNERS_HZ = (30.0, 100.0, 250.0)
AMPLITUDE_V = 100.0


def sweep_study(base: Path, *, duration_s: float = 10.0, seed: int = 0
                ) -> tuple[Path, dict[str, dict[str, float]]]:
    """Simulate and analyse the sweep under *base*; return the result folder and the
    truth (``{subject: {"h_L": ..., "r_g": ...}}``)."""
    study, out = base / "study", base / "out"
    truth = {}
    template = TrialConfig(duration_s=duration_s, amplitude_V=AMPLITUDE_V, waveform="square")
    for si, (person, corner) in enumerate(zip(default_subjects(3, seed=seed), CORNERS_HZ,
                                              strict=True)):
        r_g = r_g_for_corner(corner, person.h_L)
        subject = dataclasses.replace(person, model={"r_g": r_g})
        truth[subject.name] = {"h_L": subject.h_L, "r_g": r_g}
        for ti, f in enumerate(SWEEP_HZ):
            cfg = dataclasses.replace(template, frequency_Hz=f,
                                      seed=seed * 100_003 + si * 1000 + ti,
                                      start_time=template.start_time + 3600 * si + 120 * ti)
            write_trial(study, f"f-{ti + 1:02d}", subject, cfg, study_name="sweep")
    analyze_study(study, out, jobs=1, cache_dir=base / "cache")
    return out, truth
