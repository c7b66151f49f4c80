"""sine_trace.csv's stretch of a sine trial, and summary.json's provenance."""

import hashlib
import json

import numpy as np
import pytest

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, write_trial
from evtribo.analysis.friction.trace import TRACE_COLUMNS, sine_trace
from evtribo.fit.tables import read_results
from evtribo.results.pipeline import SINE_TRACE_FILE, analyze_study


def _grid(rate=2000.0, duration=10.0):
    t = 100.0 + np.arange(int(duration * rate)) / rate
    return t, 0.5 + 0.01 * np.sin(t), -0.25 * np.ones_like(t)


def test_the_switch_inside_steady_sliding_is_chosen_and_decimated():
    t, fn, ft = _grid()
    rel = t - t[0]
    on = (rel % 4.0) >= 2.0  # OFF 2 s, ON 2 s: switches at 2, 6 s
    steady = ~((rel > 1.6) & (rel < 2.4))  # a reversal around the first switch
    trace = sine_trace(t, fn, ft, on, steady, amplitude_V=120.0, frequency_Hz=10.0,
                       subject="P01", trial="run-01", off_s=0.5, on_s=1.0, rate_Hz=1000.0)
    assert list(trace.columns) == list(TRACE_COLUMNS)
    assert len(trace) == 1500  # 1.5 s at 1 kHz: blocks of two 2 kHz samples
    assert trace.time_s.iloc[0] == pytest.approx(0.00025)
    # the stretch starts 0.5 s before the switch at 6 s
    switch = trace.time_s[trace.amplitude_V > 0].iloc[0]
    assert switch == pytest.approx(0.5, abs=1e-3)
    assert set(trace.amplitude_V) == {0.0, 120.0} and (trace.frequency_Hz == 10.0).all()
    assert (trace.friction_force_N == 0.25).all()  # magnitude
    np.testing.assert_allclose(trace.normal_force_N.iloc[0],
                               np.mean(fn[int(5.5 * 2000):int(5.5 * 2000) + 2]))


def test_the_stretch_stops_short_of_the_fingers_reversals():
    t, fn, _ = _grid()
    rel = t - t[0]
    on = (rel % 4.0) >= 2.0                       # switches at 2 s and 6 s
    ft = np.where(rel < 6.6, -0.25, 0.25)          # the finger reverses 0.6 s after 6 s...
    ft[rel < 1.0] = 0.25                           # ...and 1 s before the switch at 2 s
    steady = np.abs(rel - 6.6) > 0.1               # reversals are not steady sliding
    steady &= np.abs(rel - 1.0) > 0.1
    trace = sine_trace(t, fn, ft, on, steady, amplitude_V=120.0, frequency_Hz=10.0,
                       subject="P01", trial="run-01", off_s=0.5, on_s=1.0, rate_Hz=1000.0)
    # the switch at 2 s has 1 s of steady ON after it and 0.5 s before: it is chosen over
    # the one at 6 s, cut by the reversal at 6.6 s
    start = 100.0 + 1.5
    assert trace.time_s.iloc[-1] == pytest.approx(1.5, abs=2e-3)
    np.testing.assert_allclose(trace.normal_force_N.iloc[0],
                               np.mean(fn[int((start - 100.0) * 2000):][:2]))
    # cut at the reversal when no better switch exists
    late = sine_trace(t[rel > 4.0], fn[rel > 4.0], ft[rel > 4.0], on[rel > 4.0],
                      steady[rel > 4.0], amplitude_V=120.0, frequency_Hz=10.0,
                      subject="P01", trial="run-01", off_s=0.5, on_s=1.0, rate_Hz=1000.0)
    switch = late.time_s[late.amplitude_V > 0].iloc[0]
    assert late.time_s.iloc[-1] - switch == pytest.approx(0.5, abs=2e-3)  # 6.0 to 6.5 s


def test_a_trial_on_from_the_start_and_one_without_on():
    t, fn, ft = _grid(duration=3.0)
    on = np.ones(t.size, bool)
    trace = sine_trace(t, fn, ft, on, on, amplitude_V=100.0, frequency_Hz=10.0,
                       subject="P01", trial="x", off_s=0.5, on_s=1.0)
    assert len(trace) == 1500 and (trace.amplitude_V == 100.0).all()
    assert sine_trace(t, fn, ft, ~on, on, amplitude_V=100.0, frequency_Hz=10.0,
                      subject="P01", trial="x") is None


@pytest.fixture(scope="module")
def small_study(tmp_path_factory):
    root = tmp_path_factory.mktemp("study")
    subject = SubjectParams(name="P07", mu=0.4, h_L=5e-6, normal_force_N=0.7)
    base = TrialConfig(duration_s=6.0, fx_rate_Hz=1000.0, drop_probability=0.01)
    truth = write_trial(root, "sq", subject, base, notes="square")
    write_trial(root, "sn", subject, TrialConfig(duration_s=6.0, fx_rate_Hz=1000.0,
                                                 waveform="sine", frequency_Hz=10.0))
    out = tmp_path_factory.mktemp("out")
    res = analyze_study(root, out, jobs=1, force=True, cache_dir=tmp_path_factory.mktemp("cache"))
    return root, res, truth


def test_summary_records_inputs_rig_software_and_start(small_study):
    root, res, _ = small_study
    summary = json.loads((res.out_dir / "summary.json").read_text(encoding="utf-8"))
    assert summary["study_dir"] == str(root.resolve())
    files = {r["file"]: r for r in summary["inputs"]}
    assert set(files) == {"study.toml", "rig/default.dbc", "P07/sq.log", "P07/sq.json",
                          "P07/sn.log", "P07/sn.json"}
    for name, record in files.items():
        data = (root / name).read_bytes()
        assert record["bytes"] == len(data)
        assert record["sha256"] == hashlib.sha256(data).hexdigest()
    assert {r["role"] for r in summary["inputs"]} == {"study", "dbc", "log", "sidecar"}
    assert summary["rig"]["tangential_force"] == "FxCell.Fx"
    assert summary["rig"]["tangential_force_counter"] == "FxCell.FxCounter"
    assert set(summary["software"]) >= {"evtribo", "python-can", "cantools", "python"}
    assert summary["started"].endswith("Z")
    assert SINE_TRACE_FILE in summary["outputs"]


def test_sine_trace_only_for_sine_trials_and_readable_by_compare(small_study):
    _, res, truth = small_study
    trace = read_results(res.out_dir).sine_trace
    assert trace is not None and set(trace.trial) == {"sn"}
    trials = res.trials.set_index("trial")
    # counters named by the simulated study: counts come from them
    lost = truth.nodes["FzCell"]["dropped"] + truth.nodes["FxCell"]["dropped"]
    assert lost > 0 and lost - 2 <= trials.loc["sq", "dropped_frames"] <= lost
    assert trials.loc["sn", "dropped_frames"] == 0
