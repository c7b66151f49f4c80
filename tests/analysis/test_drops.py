"""Counting a load cell's missing frames: counters first, timing robust to jitter."""

import numpy as np
import pytest

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_trial
from evtribo.dropped import coherence, count_dropped, estimate_period, missing_frames
from evtribo.dropped import count_by_steps as step_heuristic


def _stream(*, rate_hz=2000.0, duration_s=10.0, drop=0.03, jitter_s=2e-4, seed=0, ppm=-25.0):
    """Reception times and 8-bit counters of a cell; returns (t, counter, truly missing)."""
    rng = np.random.default_rng(seed)
    period = 1 / (rate_hz * (1 + ppm * 1e-6))
    k = np.arange(int(duration_s / period))
    keep = rng.random(k.size) >= drop
    keep[[0, -1]] = True  # frames lost before the first or after the last are invisible
    t = 1_763_700_000.0 + 3e-4 + k * period + rng.exponential(jitter_s, k.size)
    t = np.maximum.accumulate(t)  # frames arrive in order
    return t[keep], (k % 256)[keep], int((~keep).sum()), period


@pytest.mark.parametrize("jitter_s", [5e-5, 2e-4, 5e-4])
def test_jitter_does_not_inflate_the_count_without_a_counter(jitter_s):
    t, _, lost, period = _stream(rate_hz=1000.0, jitter_s=jitter_s)
    assert estimate_period(t) == pytest.approx(period, rel=1e-5)
    got = missing_frames(t)
    assert got.method == "timing" and got.note is None
    assert abs(got.count - lost) <= 2, (got.count, lost)


def test_the_case_that_overcounted_sixfold():
    # 2 kHz cell, 0.2 ms of jitter: counting every step > 1.5 periods gives thousands
    t, counter, lost, _ = _stream(rate_hz=2000.0, jitter_s=2e-4, drop=0.03)
    assert step_heuristic(t) > 3 * lost  # what a per-step gap count reports
    assert abs(count_dropped(t) - lost) <= 2
    assert count_dropped(t, counter, 256) == lost


def test_the_counter_decides_even_when_timing_is_hopeless():
    t, counter, lost, _ = _stream(rate_hz=1000.0, jitter_s=1e-3, drop=0.03)
    got = missing_frames(t, counter, 256)
    assert got.count == lost and got.method == "counter" and got.note is None
    assert missing_frames(t).note is not None  # no counter: said to be unreliable
    # a long pause in such a stream: timing cannot say whether a counter period is hidden
    paused = t + np.where(t > t[5000], 0.2, 0.0)
    got = missing_frames(paused, counter, 256)
    assert got.count == lost and got.method == "counter"
    assert got.note is not None and "irregular" in got.note


def test_an_outage_longer_than_the_counter_period_is_added_from_the_timing():
    t, counter, _, period = _stream(rate_hz=1000.0, jitter_s=1e-4, drop=0.0)
    cut = (t > t[3000]) & (t <= t[3000] + 600 * period)  # 600 frames gone at once
    t2, c2 = t[~cut], counter[~cut]
    by_counter = int(((np.diff(c2) - 1) % 256).sum())
    assert by_counter == 600 - 512  # the counter alone sees 88
    got = missing_frames(t2, c2, 256)
    assert got.method == "counter+timing" and got.count == 600


def test_a_logger_stall_then_a_burst_adds_nothing():
    # software timestamps: frames queued for 0.3 s, then stamped together on release
    t, counter, lost, _ = _stream(rate_hz=1000.0, jitter_s=5e-5, drop=0.01, seed=3)
    stall = (t > t[4000]) & (t < t[4000] + 0.3)
    t = t.copy()
    t[stall] = t[4000] + 0.3 + np.arange(stall.sum()) * 1e-6
    got = missing_frames(t, counter, 256)
    assert got.count == lost and got.method == "counter"
    assert abs(count_dropped(t) - lost) <= 2


def test_frames_stamped_together_when_the_logger_starts_are_not_counted_missing():
    t, _, lost, _ = _stream(rate_hz=1000.0, jitter_s=5e-5, drop=0.005, seed=5)
    t = t.copy()
    t[:12] = t[11]  # the first dozen frames waited in a queue for the logger
    assert abs(count_dropped(t) - lost) <= 1


def test_short_and_degenerate_streams():
    assert count_dropped(np.array([])) == 0
    assert count_dropped(np.array([1.0])) == 0
    assert count_dropped(np.array([0.0, 0.001, 0.003, 0.004])) == 1
    assert count_dropped(np.array([0.0, 1e-3, 2e-3]), np.array([254, 255, 1]), 256) == 1
    assert np.isnan(estimate_period(np.array([2.0, 2.0])))
    t = np.arange(1000) * 1e-3
    assert coherence(t, 1e-3) == pytest.approx(1.0)
    assert coherence(np.random.default_rng(0).uniform(0, 1, 1000), 1e-3) < 0.1


def test_simulated_trial_counts_match_the_simulator():
    frames, truth = simulate_trial(SubjectParams(), TrialConfig(
        duration_s=5.0, fx_rate_Hz=2000.0, jitter_s=2e-4, drop_probability=0.02))
    for frame_id, name in ((0x0C1, "FzCell"), (0x0C2, "FxCell")):
        sel = frames.arbitration_id == frame_id
        t, counter = frames.timestamp[sel], frames.data[sel, 7]
        dropped = truth.nodes[name]["dropped"]
        assert dropped - 2 <= count_dropped(t, counter, 256) <= dropped
        assert abs(count_dropped(t) - dropped) <= 3


def test_the_decoders_count_is_carried_into_the_analysis_not_recounted(monkeypatch):
    from types import SimpleNamespace

    from evtribo.analysis import trial
    from evtribo.decode import CellSignals

    def recount(*_a, **_k):
        raise AssertionError("counted again")

    monkeypatch.setattr(trial, "missing_frames", recount)
    t = np.arange(10.0)
    signals = SimpleNamespace(
        normal=CellSignals(t, np.zeros(10), None, 600, "counter+timing"),
        tangential=CellSignals(t, np.zeros(10), None, 3, "timing",
                               "timestamps too irregular to count missing frames reliably"))
    warnings = []
    assert trial._dropped(signals, None, warnings.append) == 603
    assert any("whole counter periods" in w for w in warnings)
    assert any("too irregular" in w for w in warnings)
