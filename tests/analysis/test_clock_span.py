"""A logger whose clock is set forward by a day halfway through a trial, or one line stamped a
million seconds ahead: ``analyze`` of a four-trial study had not finished after 300 s, its
search of a clear phase length (:func:`~evtribo.analysis.friction.drift.clear_phase_s`)
trying every length up to half the clock's span on a 0.1-s grid of it. No step costs more
with the clock's span than with the frames: the jump is said, the trial analysed in its
pieces, F_el as without the jump."""

from __future__ import annotations

import json
import math
import re
import tracemalloc

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from _forked import start
from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_trial
from evtribo.analysis import calibration
from evtribo.analysis.forces.timebase import sample_times
from evtribo.analysis.friction import drift
from evtribo.canlog.decode import decode_trial
from evtribo.canlog.rig import default_rig
from evtribo.cli import main

RIG = default_rig()
DAY_S = 86_400.0


def _grid_search(span_s: float, guard_s: float = 0.15) -> float:
    """The search as it was: every 0.5-s length up to half the span, on a 0.1-s grid."""
    t = np.arange(0.05, span_s, 0.1)
    best = 0.5
    for length in np.arange(0.5, span_s / 2 + 1e-9, 0.5):
        phase = np.floor(t / length)
        edge = np.minimum(t - phase * length, (phase + 1) * length - t)
        keep = edge > guard_s
        group = np.where(phase % 2 == 1, 1.0, np.nan)
        if drift.phase_confounding(t[keep], group[keep]) <= drift.CLEAR:
            best = float(length)
    return best


@settings(deadline=None, max_examples=15)
@given(span=st.floats(1.0, 400.0))
def test_a_clear_phase_up_to_400_s_is_the_grid_search_s(span):
    assert drift.clear_phase_s(span) == _grid_search(span)


def _points_searched(monkeypatch, span_s: float, budget: float = math.inf) -> int:
    """Times the search hands to the confounding, in all (it stops past *budget*)."""
    real, seen = drift.phase_confounding, [0]

    def counted(t, group, weight=None):
        seen[0] += len(t)
        if seen[0] > budget:
            raise RuntimeError(f"{seen[0]} times searched for a span of {span_s:g} s")
        return real(t, group, weight)

    monkeypatch.setattr(drift, "phase_confounding", counted)
    try:
        value = drift.clear_phase_s(span_s)
    finally:
        monkeypatch.setattr(drift, "phase_confounding", real)
    assert 0.5 <= value <= span_s / 2 + 0.5
    return seen[0]


@pytest.mark.parametrize("span_s", [1000.0, DAY_S, 1e6 + 12, 2.0**62])
def test_the_phase_search_costs_no_more_for_a_day_than_for_400_s(monkeypatch, span_s):
    """As many lengths and times as for 400 s (whose guards about each switch leave out
    more of its times: twice its count bounds them)."""
    budget = 2 * _points_searched(monkeypatch, 400.0)
    assert _points_searched(monkeypatch, span_s, budget) <= budget
    # the clear length keeps its share of the span (about a quarter)
    assert drift.clear_phase_s(span_s) / span_s == pytest.approx(
        drift.clear_phase_s(400.0) / 400.0, rel=0.02)


def _jumped(frames, shift_s: float):
    out = frames.take(np.arange(len(frames)))
    t = frames.timestamp.copy()
    t[len(t) // 2:] += shift_s
    out.timestamp = t
    return out


def test_a_cell_s_sample_times_cost_no_more_for_a_day_s_jump():
    """The sample times of a stream that jumps a day ahead (as ``evtribo calibrate`` takes
    them, over the whole recording), and the forces aligned on them, take the memory of the
    frames (a line through a day's index asked for a 17,280-knot basis)."""
    frames, _ = simulate_trial(SubjectParams(), TrialConfig(duration_s=12.0, seed=3,
                                                            press_only=True,
                                                            condition="off"))
    plain = decode_trial(frames, RIG)
    jumped = decode_trial(_jumped(frames, DAY_S), RIG)
    peaks = []
    for signals in (plain, jumped):
        tracemalloc.start()
        try:
            times = sample_times(signals.normal.t, signals.normal.counter)
            slope = calibration.pressing_slope(signals)
            peaks.append(tracemalloc.get_traced_memory()[1])
        finally:
            tracemalloc.stop()
        assert np.all(np.diff(times) >= 0)
        steps = np.diff(times)
        assert np.count_nonzero(steps > 1.0) == (signals is jumped)
    assert peaks[1] < 2 * peaks[0] + 20e6, peaks
    assert slope[0] == pytest.approx(calibration.pressing_slope(plain)[0], abs=0.01)


@pytest.fixture(scope="module")
def studies(tmp_path_factory):
    """Four 12-s trials of two subjects as recorded, and the same with the logger's clock
    set forward by a day halfway through every trial and one line of P01/run-01 stamped a
    million seconds ahead of those around it."""
    root = tmp_path_factory.mktemp("clock")
    plain = root / "plain"
    for k, (subject, trial) in enumerate([("P01", "run-01"), ("P01", "run-02"),
                                          ("P02", "run-01"), ("P02", "run-02")]):
        assert main(["simulate", "--study", str(plain), "--subject", subject, "--trial",
                     trial, "--duration", "12", "--seed", str(70 + k)]) == 0
    jumped = root / "jumped"
    jumped.mkdir()
    for path in plain.rglob("*"):
        target = jumped / path.relative_to(plain)
        if path.is_dir():
            target.mkdir(exist_ok=True)
        elif path.suffix == ".log":
            lines = path.read_text().splitlines(keepends=True)
            for i in range(len(lines) // 2, len(lines)):
                lines[i] = _stamped(lines[i], DAY_S)
            if path.parent.name == "P01" and path.stem == "run-01":
                lines[len(lines) // 4] = _stamped(lines[len(lines) // 4], 1e6)
            target.write_text("".join(lines))
        else:
            target.write_bytes(path.read_bytes())
    return plain, jumped


def _stamped(line: str, shift_s: float) -> str:
    stamp, rest = line.split(" ", 1)
    return f"({float(stamp[1:-1]) + shift_s:.6f}) {rest}"


def _run(argv, log) -> str:
    """``evtribo *argv`` in a forked process; a hang fails the test (the limit is far
    beyond any machine's pace: the four trials analyse in seconds)."""
    proc = start(argv, log)
    proc.join(600)
    if proc.is_alive():
        proc.kill()
        proc.join()
        pytest.fail(f"evtribo {' '.join(map(str, argv))} hung: {log.read_text()[-2000:]}")
    text = log.read_text()
    assert proc.exitcode == 0, text
    return text


def test_a_study_whose_clock_jumped_a_day_is_analysed_compared_and_reported(studies,
                                                                            tmp_path):
    plain, jumped = studies
    cache = tmp_path / "cache"
    _run(["analyze", str(plain), "--out", str(tmp_path / "plain-out"), "--jobs", "1",
          "--cache-dir", str(cache)], tmp_path / "plain.txt")
    out = tmp_path / "out"
    console = _run(["analyze", str(jumped), "--out", str(out), "--jobs", "1",
                    "--cache-dir", str(cache)], tmp_path / "analyze.txt")
    _run(["compare", str(out), "--jobs", "1", "--cache-dir", str(cache)],
         tmp_path / "compare.txt")
    _run(["report", str(out)], tmp_path / "report.txt")
    clean = pd.read_csv(tmp_path / "plain-out" / "electrostatic.csv").set_index("subject")
    got = pd.read_csv(out / "electrostatic.csv").set_index("subject")
    for subject in ("P01", "P02"):
        fel = got.electrostatic_force_N[subject]
        assert (clean.electrostatic_force_ci_low_N[subject] <= fel
                <= clean.electrostatic_force_ci_high_N[subject]), (subject, fel)
    trials = pd.read_csv(out / "trials.csv")
    assert trials.duration_s.between(11.0, 12.1).all(), trials.duration_s  # the frames' time
    warnings = [w["text"] for w in json.loads((out / "summary.json").read_text())["warnings"]]
    jumps = [w for w in warnings if "no frame of the load cells for 24.0 h" in w]
    assert len(jumps) == 4 and all(re.search(r"after 6\.0\d\d s", w) for w in jumps), jumps
    gaps = [w for w in warnings if w.startswith("P01/run-01: no frame of the load cells")]
    assert len(gaps) == 2, gaps  # the day, and the line a million seconds ahead
    # the frames after the line far ahead go on from those before it: no step of the clock
    assert not [w for w in warnings if "clock stepped back" in w], warnings
    assert "not classified" not in console, console
    # the note on phases speaks of the trials' own time, not the clock's span
    assert not [w for w in warnings if "with trials of 864" in w], warnings
