"""Realistic simulated studies analysed in memory, and what their truth says of each result.

A study here is every subject at every amplitude, one alternating trial each, simulated
(:func:`evtribo.acquisition.simulator.simulate_trial`), decoded and analysed trial by trial
(:func:`evtribo.analysis.trial.analyze_signals`), then summarised
(:func:`evtribo.results.aggregate.summarize`), as ``evtribo analyze`` does, without files.
The truth of an electrostatic.csv row is the mean, over the row's own ON windows, of the
simulated electrostatic force over the samples each window spans.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, default_subjects
from evtribo.acquisition.simulator.core import TrialTruth, simulate_trial
from evtribo.acquisition.simulator.realism import human, real_finger, real_logger, realistic_rig
from evtribo.analysis.friction.direction_weights import balanced_weights
from evtribo.analysis.settings import AnalysisSettings
from evtribo.analysis.trial import TrialMeta, analyze_signals
from evtribo.canlog.decode import decode_trial
from evtribo.canlog.rig import Calibration, default_rig
from evtribo.results.aggregate import summarize

AMPLITUDES = (60.0, 80.0, 100.0, 120.0, 140.0)


@dataclass
class StudyRun:
    """A realistic study analysed, with its truth."""

    trials: pd.DataFrame
    windows: pd.DataFrame  # windows.csv plus fel_true_N and steady (fraction)
    electrostatic: pd.DataFrame  # electrostatic.csv plus fel_true_N and mu_true
    exponents: pd.DataFrame  # exponents.csv plus exponent_true
    warnings: list[str]  # texts
    truths: dict[tuple[str, str], TrialTruth]
    study_warnings: list[str] = dataclasses.field(default_factory=list)  # the aggregation's
    records: list[Any] = dataclasses.field(default_factory=list)  # every warning, as said


def window_truth(windows: pd.DataFrame, truth: TrialTruth) -> pd.DataFrame:
    """*windows* (of one trial) with the simulated electrostatic force over each window
    (``fel_true_N``) and the fraction of it in steady sliding of its condition (``steady``)."""
    shift = (truth.first_frame_s or 0.0) - truth.config.latency_s
    fel, mu, steady = [], [], []
    for w in windows.itertuples():
        a, b = w.t_start_s + shift, w.t_end_s + shift
        fel.append(truth.electrostatic_between(a, b))
        mu.append(truth.mu_between(a, b))
        grid = np.linspace(a, b, 200, endpoint=False)
        ok = np.zeros(grid.size, dtype=bool)
        for s0, s1, _, on in truth.steady:
            if on == (w.condition == "on"):
                ok |= (grid >= s0) & (grid < s1)
        steady.append(float(ok.mean()))
    return windows.assign(fel_true_N=fel, mu_true=mu, steady=steady)


def true_exponent(amplitudes: np.ndarray, forces: np.ndarray) -> float:
    """The log-log slope through the true forces (what exponents.csv estimates)."""
    return float(np.polyfit(np.log(amplitudes), np.log(forces), 1)[0])


def attach_truth(el: pd.DataFrame, ex: pd.DataFrame, windows: pd.DataFrame,
                 mu_of: dict[str, float]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """electrostatic.csv and exponents.csv with the truth of each row beside it: the
    simulated electrostatic force and friction coefficient over the row's ON windows,
    averaged as the estimate averages them (each trial by its share, both directions alike:
    :func:`evtribo.analysis.friction.direction_weights.balanced_weights`; the subject's
    coefficient where the simulator did not record it)."""
    on = windows[windows.condition == "on"]
    rows = [on[(on.subject == r.subject) & (on.amplitude_V == r.amplitude_V)
               & (on.waveform == r.waveform)] for r in el.itertuples()]
    weights = [balanced_weights(np.ones((1, len(r))), pd.factorize(r.trial)[0],
                                r.direction.to_numpy(float))[0] for r in rows]
    mu = [float(w @ r.mu_true) if "mu_true" in r and r.mu_true.notna().all() else mu_of[s]
          for r, w, s in zip(rows, weights, el.subject, strict=True)]
    el = el.assign(fel_true_N=[float(w @ r.fel_true_N) for r, w in zip(rows, weights,
                                                                        strict=True)],
                   mu_true=mu)
    expo = []
    for r in ex.itertuples():
        rows = el[(el.subject == r.subject) & (el.waveform == r.waveform)]
        expo.append(true_exponent(rows.amplitude_V.to_numpy(float),
                                  rows.fel_true_N.to_numpy(float)))
    return el, ex.assign(exponent_true=expo)


def run_study(seed: int, *, n_subjects: int = 4, amplitudes=AMPLITUDES,
              duration_s: float = 16.0, realistic: bool = True,
              rig_changes: Callable[[TrialConfig], TrialConfig] | None = None,
              subject_changes: Callable[[SubjectParams], SubjectParams] | None = None,
              calibration: Calibration | None = None,
              settings: AnalysisSettings | None = None, n_boot: int = 1000) -> StudyRun:
    """Simulate and analyse a study of *n_subjects* x *amplitudes* alternating trials.

    With *realistic*, each trial's load cells have their own offsets (+/-50 mN), drift
    (+/-10 mN), 10 mN of 50 Hz hum and a 1.5-s tare stretch, and each subject a person's
    strokes (dwells, lift-offs, a wandering force); both cells run on clocks 300 ppm apart.
    *rig_changes* and *subject_changes* edit each trial's config and each subject after that.
    """
    rig = default_rig()
    settings = settings or AnalysisSettings(n_boot=n_boot)
    rows, wins, warnings, records = [], [], [], []
    truths: dict[tuple[str, str], TrialTruth] = {}
    mu_of = {}
    for si, drawn in enumerate(default_subjects(n_subjects, seed=seed)):
        subject = human(drawn, seed=seed * 100 + si) if realistic else drawn
        if subject_changes is not None:
            subject = subject_changes(subject)
        mu_of[subject.name] = subject.mu
        for ai, amp in enumerate(amplitudes):
            cfg = TrialConfig(duration_s=duration_s, amplitude_V=float(amp), fz_ppm=300.0,
                              fx_ppm=-200.0, seed=seed * 1000 + si * 10 + ai)
            if realistic:
                cfg = realistic_rig(cfg)
            if rig_changes is not None:
                cfg = rig_changes(cfg)
            frames, truth = simulate_trial(subject, cfg)
            name = f"run-{ai + 1:02d}"
            result = analyze_signals(decode_trial(frames, rig), TrialMeta(subject.name, name),
                                     settings=settings, calibration=calibration)
            rows.append(result.row)
            wins.append(window_truth(result.windows, truth))
            warnings += [w.text for w in result.warnings]
            records += result.warnings
            truths[(subject.name, name)] = truth
    trials = pd.DataFrame(rows)
    windows = pd.concat(wins, ignore_index=True)
    el, ex, _, agg_warnings = summarize(windows.drop(columns=["fel_true_N", "mu_true",
                                                              "steady"]), trials,
                                        n_boot=settings.n_boot, seed=settings.seed,
                                        confidence=settings.confidence)
    el, ex = attach_truth(el, ex, windows, mu_of)
    agg_texts = [w.text for w in agg_warnings]
    return StudyRun(trials, windows, el, ex, warnings + agg_texts, truths, agg_texts,
                    records + agg_warnings)


def fel_within(measured: pd.Series, true: pd.Series, rel: float = 0.03,
               absolute: float = 0.003) -> np.ndarray:
    """Whether each force is within max(rel, absolute) of the truth."""
    m, t = measured.to_numpy(float), true.to_numpy(float)
    return np.abs(m - t) <= np.maximum(rel * np.abs(t), absolute)


def offsets_error(trials: pd.DataFrame, truths: dict[tuple[str, str], TrialTruth]
                  ) -> pd.DataFrame:
    """Each trial's offsets removed (trials.csv) less the simulated mean zero, N."""
    out = []
    for r in trials.itertuples():
        cells = truths[(r.subject, r.trial)].cells
        out.append({"subject": r.subject, "trial": r.trial, "tare": r.tare,
                    "normal": _minus(r.normal_offset_N, cells["normal"]["mean_offset_N"]),
                    "tangential": _minus(r.tangential_offset_N,
                                         cells["tangential"]["mean_offset_N"])})
    return pd.DataFrame(out)


def _minus(a: float | None, b: float) -> float:
    return float("nan") if a is None or math.isnan(a) else float(a) - b


def replace(obj, **changes):
    """``dataclasses.replace``, for the *_changes callables."""
    return dataclasses.replace(obj, **changes)


# --- what real fingers, rigs and loggers add, one effect at a time (docs/simulator.md) ---

Changes = tuple[Callable[[TrialConfig], TrialConfig] | None,
                Callable[[SubjectParams], SubjectParams] | None]


def _finger(**only: bool) -> Callable[[SubjectParams], SubjectParams]:
    flags = {"moisture": False, "speed": False, "direction": False, "trials": False,
             "load": False, **only}
    return lambda s: real_finger(s, seed=int(s.name[1:]), **flags)


def wandering(change: Callable[[SubjectParams], SubjectParams]
              ) -> Callable[[SubjectParams], SubjectParams]:
    """*change*, then a press wandering over about 0.2-1.0 N (0.6 N +/- 0.2 N, a slow
    Ornstein-Uhlenbeck wander of 3 s)."""
    return lambda s: dataclasses.replace(change(s), normal_force_N=0.6, force_drift=0.33,
                                         drift_time_s=3.0)


def _rig(**changes: object) -> Callable[[TrialConfig], TrialConfig]:
    return lambda c: dataclasses.replace(c, **changes)


def crosstalk(c: TrialConfig) -> TrialConfig:
    """The rig's cross-talk: 3-4 % each way, the same in every trial of a study."""
    rng = np.random.default_rng([c.seed // 1000, 77])
    a, b = rng.uniform(0.03, 0.04, 2) * rng.choice([-1, 1], 2)
    return dataclasses.replace(c, crosstalk=((1.0, float(a)), (float(b), 1.0)))


def everything(c: TrialConfig) -> TrialConfig:
    """Every rig and logger effect at once, 60 Hz hum and a 333 Hz normal cell besides."""
    c = crosstalk(real_logger(c))
    return dataclasses.replace(c, creep=0.01, creep_time_s=3.0, mains_Hz=60.0,
                               spike_rate_Hz=0.5, spike_N=0.3, fz_rate_Hz=333.0)


#: Each effect as (rig changes, subject changes) for :func:`run_study`.
EFFECTS: dict[str, Changes] = {
    "none": (None, None),
    "moisture": (None, _finger(moisture=True, trials=True)),
    "speed": (None, _finger(speed=True, direction=True)),
    "load": (None, _finger(load=True)),
    "load+wander": (None, wandering(_finger(load=True))),
    "crosstalk": (crosstalk, None),
    "timing": (real_logger, None),
    "creep+spikes": (_rig(creep=0.01, creep_time_s=3.0, spike_rate_Hz=0.5, spike_N=0.3),
                     None),
    "all": (everything, _finger(moisture=True, speed=True, direction=True, trials=True)),
}
