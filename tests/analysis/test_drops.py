"""Counting a load cell's missing frames: counters first, timing robust to jitter."""

import numpy as np
import pytest

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_trial
from evtribo.canlog.dropped import coherence, count_dropped, estimate_period, missing_frames
from evtribo.canlog.dropped import count_by_steps as step_heuristic
from evtribo.warning.collect import collecting


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
    assert got.method == "timing" and not got.notes
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
    assert got.count == lost and got.method == "counter" and not got.notes
    assert missing_frames(t).notes  # no counter: said to be unreliable
    # a long pause in such a stream where the counter steps by one: nothing hides in it
    assert counter[5001] == (counter[5000] + 1) % 256
    paused = t + np.where(t > t[5000], 0.2, 0.0)
    got = missing_frames(paused, counter, 256)
    assert (got.count, got.method, got.notes) == (lost, "counter", ())


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
    from evtribo.analysis import trial
    from evtribo.canlog import dropped
    from evtribo.canlog.signals import CellSignals, TrialSignals

    def recount(*_a, **_k):
        raise AssertionError("counted again")

    for name in ("missing_frames", "count_dropped"):
        monkeypatch.setattr(dropped, name, recount)
    t = np.arange(10.0)
    signals = TrialSignals(
        normal=CellSignals(t, np.zeros(10), None, 600, "counter+timing"),
        tangential=CellSignals(t, np.zeros(10), None, 3, "timing"),
        excitation=None, frames=20, ignored_frames=0)
    with collecting(quiet=True) as warnings:
        assert trial._dropped(signals) == 603
    assert [(w.kind, w.value("cell"), w.value("frames")) for w in warnings] == [
        ("frames-lost-periods", "normal", 600)]
    assert "whole counter periods" in warnings[0].text


def test_the_logger_s_dropcount_and_decoder_warnings_reach_trials_csv_cold_and_warm(tmp_path):
    """A candump DROPCOUNT notice on the decoded channel is part of the trial's lost frames,
    and what the decoder warned about is said again when the trial comes from the cache."""
    import json

    from evtribo.acquisition.simulator import simulate_study
    from evtribo.results.pipeline import analyze_study

    study = tmp_path / "study"
    simulate_study(study, [SubjectParams(name="P01")], amplitudes=(120.0,),
                   config=TrialConfig(duration_s=6.0, tare_s=1.0), sine_trial=False)
    log = sorted(study.rglob("*.log"))[0]
    lines = log.read_text(encoding="ascii").splitlines(keepends=True)
    channel = lines[10].split()[1]
    t_mid = lines[len(lines) // 2].split()[0]
    lines.insert(len(lines) // 2,
                 f"DROPCOUNT: dropped 250 CAN frames on '{channel}' socket (total drops 250)\n")
    # the rig's load cell also heard once on another bus: the decoder says which it used
    lines.append(f"{t_mid} can7 0C1#0000000000000000\n")
    log.write_text("".join(lines), encoding="ascii")
    cache = tmp_path / "cache"
    for out in ("cold", "warm"):
        res = analyze_study(study, tmp_path / out, jobs=1, cache_dir=cache)
        row = res.trials.set_index("trial").loc[log.stem]
        assert row.dropped_frames == 250, out
        summary = json.loads((tmp_path / out / "summary.json").read_text(encoding="utf-8"))
        said = json.dumps(summary)
        assert "DROPCOUNT" in said and "can7" in said, out


@pytest.mark.parametrize("jump_s", [-3 * 3600.0, -5.0, 2 * 86400.0])
def test_a_clock_jump_inside_a_trial_invents_no_lost_frames(jump_s):
    """A logger's clock stepping back hours halfway through: counted in the order the frames
    came in, the counter sees exactly the frames lost, not the interleaving of the halves."""
    from evtribo.canlog.decode import decode_trial
    from evtribo.canlog.dropped import missing_frames_received
    from evtribo.canlog.rig import default_rig

    t, counter, lost, _ = _stream(rate_hz=1000.0, jitter_s=1e-4, drop=0.01, seed=3)
    half = t.size // 2
    jumped = t.copy()
    jumped[half:] += jump_s
    got = missing_frames_received(jumped, counter, 256)
    assert got.count == lost
    if jump_s < 0:
        assert got.notes[-1].mapping["jumped"] == "jumped back"
    else:
        assert got.notes[-1].mapping["jumped"] == "jumped ahead or paused"
    # a frame lost right at the jump is counted too
    cut = np.delete(np.arange(t.size), half)
    assert missing_frames_received(jumped[cut], counter[cut], 256).count == lost + 1
    # frames merely swapped (a merged log) are put back in order, not cut
    order = np.arange(t.size)
    order[[100, 101]] = order[[101, 100]]
    assert missing_frames_received(t[order], counter[order], 256).count == lost

    frames, truth = simulate_trial(SubjectParams(), TrialConfig(duration_s=6.0, seed=1,
                                                                drop_probability=0.01))
    ts = frames.timestamp.copy()
    ts[len(ts) // 2:] += jump_s
    frames.timestamp = ts
    trial = decode_trial(frames, default_rig())
    for cell, name in ((trial.normal, "FzCell"), (trial.tangential, "FxCell")):
        assert cell.dropped == truth.nodes[name]["dropped"]
        assert np.all(np.diff(cell.t) >= 0)
