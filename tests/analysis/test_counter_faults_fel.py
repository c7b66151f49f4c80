"""The rolling counter sets the load cells' sample times (:mod:`.forces.timebase`): a frame
received twice, two frames received swapped, a counter that restarts at 0 or the
logger's clock stepping back moved F_el by up to 10 % without a word, or left a trial without
windows. With any of them injected, F_el stays within the interval of the undisturbed trial,
trials.csv counts the frames lost and the duplicates as they are, and the warnings say what
happened, naming the trial and the time."""

from __future__ import annotations

import re
from functools import cache

import pandas as pd
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from _counter_faults import inject
from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_trial
from evtribo.analysis.settings import AnalysisSettings
from evtribo.analysis.trial import TrialMeta, analyze_signals
from evtribo.canlog.decode import decode_trial
from evtribo.canlog.rig import default_rig
from evtribo.results.aggregate import summarize

RIG = default_rig()
SETTINGS = AnalysisSettings(n_boot=200)
META = TrialMeta("P01", "run-01")


def _fel(frames):
    result = analyze_signals(decode_trial(frames, RIG), META, settings=SETTINGS)
    est = summarize(result.windows, pd.DataFrame([result.row]), n_boot=200)[0].iloc[0]
    return result, est


@cache
def _undisturbed(seed: int):
    frames, truth = simulate_trial(SubjectParams(), TrialConfig(
        duration_s=16.0, seed=seed, drop_probability=0.005))
    return frames, truth, _fel(frames)[1]


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 1),
       fault=st.sampled_from(["duplicate", "swap", "restart", "clock"]),
       where=st.floats(0.2, 0.8), step=st.floats(-0.9, -0.05))
def test_f_el_stays_within_the_undisturbed_interval_and_the_fault_is_said(seed, fault, where,
                                                                          step):
    frames, truth, clean = _undisturbed(seed)
    faulted = inject(frames, **{
        "duplicate": {"duplicates": [("FzCell", where, 0), ("FxCell", where, 1)]},
        "swap": {"swaps": [("FzCell", where), ("FxCell", where)]},
        "restart": {"restarts": [("FzCell", where)]},
        "clock": {"clock_step": (where, step)}}[fault])
    result, est = _fel(faulted.frames)
    low, high = clean.electrostatic_force_ci_low_N, clean.electrostatic_force_ci_high_N
    assert low <= est.electrostatic_force_N <= high, (est.electrostatic_force_N, low, high)
    row = result.row
    assert row["dropped_frames"] == sum(truth.nodes[n]["dropped"] for n in ("FzCell", "FxCell"))
    assert row["duplicate_frames"] == sum(faulted.duplicates.values())
    said = {"duplicate": "received twice", "swap": None, "restart": "restarted",
            "clock": "clock stepped back"}[fault]
    if said is not None:
        hits = [w.text for w in result.warnings if said in w.text]
        assert hits and all(w.startswith("P01/run-01: ") for w in hits), result.warnings
        at = float(re.search(r"at (\d+\.\d+) s", hits[0]).group(1))
        happened = (faulted.restarts[0][1] if fault == "restart"
                    else faulted.clock_step[0] if fault == "clock" else None)
        if happened is not None:
            assert abs(at - happened) < 0.05, (at, happened)
