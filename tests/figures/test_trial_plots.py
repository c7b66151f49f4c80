"""The check of a trial: the windows it draws are those of windows.csv, what it calls excluded
is what the simulator did (a tare stretch, lift-offs, ON/OFF switches), and the figure and
caption show them."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from matplotlib.lines import Line2D

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_study
from evtribo.acquisition.simulator.realism import realistic_rig
from evtribo.errors import StudyError
from evtribo.figures.plots import safe_name
from evtribo.figures.trial_plots import (
    MAX_POINTS,
    draw_trial_check,
    envelope,
    plot_trial,
    trial_caption,
    trial_check_figures,
    trial_stem,
)
from evtribo.results.pipeline import analyze_study
from evtribo.results.trial_view import excluded_stretches, settings_of, view_trial
from evtribo.study import load_study

REFERENCE = Path(__file__).resolve().parents[2] / "data" / "reference-study"
WINDOW_KEYS = ["condition", "amplitude_V", "waveform", "t_start_s", "t_end_s",
               "normal_force_N", "friction_force_N"]


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """A study as a lab records it: load cells with offsets, drift and hum, a tare stretch at
    the start of each trial, a person who rests at reversals and lifts the finger now and
    then; analysed as ``evtribo analyze`` does, with a setting of its own in study.toml."""
    base = tmp_path_factory.mktemp("lab")
    person = SubjectParams(name="P01", h_L=4e-6, lifts_per_min=12.0, lift_s=0.4, dwell_s=0.15,
                           stroke_jitter=0.25, force_drift=0.1)
    config = realistic_rig(TrialConfig(duration_s=10.0, seed=3))
    truth = simulate_study(base / "study", [person], amplitudes=(80.0, 160.0), config=config)
    with (base / "study" / "study.toml").open("a", encoding="utf-8") as fh:
        fh.write("\n[analysis]\nmin_window_s = 0.25\n")
    res = analyze_study(base / "study", base / "out", jobs=1)
    return base / "study", res, truth["P01"]


def _same_windows(check_windows: pd.DataFrame, csv: pd.DataFrame) -> None:
    mine = check_windows.reset_index(drop=True)[WINDOW_KEYS]
    theirs = csv.reset_index(drop=True)[WINDOW_KEYS]
    assert len(mine) == len(theirs) > 0
    assert list(mine.condition) == list(theirs.condition)
    for col in ("amplitude_V", "t_start_s", "t_end_s", "normal_force_N", "friction_force_N"):
        np.testing.assert_allclose(mine[col].to_numpy(float), theirs[col].to_numpy(float),
                                   rtol=1e-9, atol=1e-9, err_msg=col)


def test_the_windows_of_a_check_are_those_of_windows_csv(lab):
    study, res, _ = lab
    assert settings_of(load_study(study), None).min_window_s == 0.25
    for trial in ("run-01", "run-02", "run-03"):
        check = view_trial(study, "P01", trial)
        csv = res.windows[res.windows.trial == trial]
        _same_windows(check.windows, csv)
        # the windows drawn (each piece's, on the log's clock) are the same ones
        drawn = pd.concat([p.windows for p in check.pieces])
        np.testing.assert_allclose(drawn.t_start.to_numpy() - check.t0,
                                   csv.t_start_s.to_numpy(), atol=1e-6)
        assert (drawn.condition.to_numpy() == csv.condition.to_numpy()).all()


def test_the_settings_of_summary_json_give_the_same_windows(lab):
    study, res, _ = lab
    settings = json.loads((res.out_dir / "summary.json").read_text())["settings"]
    assert settings["min_window_s"] == 0.25
    check = view_trial(study, "P01", "run-02", settings=settings)
    _same_windows(check.windows, res.windows[res.windows.trial == "run-02"])
    # and other settings give other windows: the check does use them
    other = view_trial(study, "P01", "run-02", settings={**settings, "min_window_s": 0.9})
    assert len(other.windows) < len(check.windows)


def _overlap(a: tuple[float, float], b: tuple[float, float]) -> float:
    return min(a[1], b[1]) - max(a[0], b[0])


def test_what_is_excluded_is_what_the_simulator_did(lab):
    study, _, truth = lab
    lift_offs = sum(len(t.lifted) for t in truth.values())
    assert lift_offs > len(truth), "the simulated person should lift the finger mid-trial"
    found_mid = 0
    for trial, tt in truth.items():
        check = view_trial(study, "P01", trial)
        stretches = excluded_stretches(check)
        lifted = [(s.t_start, s.t_end) for s in stretches if s.kind == "lifted"]
        # the tare stretch at the start is found, and every stretch found is a real lift
        assert lifted and lifted[0][0] < 0.5 and lifted[0][1] > 1.0
        for span in lifted:
            assert any(_overlap(span, real) > 0 for real in tt.lifted), (trial, span)
        found_mid += len(lifted) - 1
        # every switch of the voltage lies in a guard stretch
        guards = [(s.t_start, s.t_end) for s in stretches if s.kind == "switch"]
        switches = [end for _, end, _ in tt.schedule[:-1]]
        assert len(guards) == len(switches)
        for t_switch, (a, b) in zip(switches, guards, strict=True):
            assert a < t_switch < b
        # no window uses an excluded stretch
        for w in check.windows.itertuples():
            for s in stretches:
                assert _overlap((w.t_start_s, w.t_end_s), (s.t_start, s.t_end)) <= 1e-9
    assert found_mid >= 1, "a lift-off in the middle of a trial should be found"


def _segments(line: Line2D) -> list[tuple[float, float, float]]:
    """``(x0, x1, y)`` of each bar of a line drawn as bars broken by NaN."""
    x = np.asarray(line.get_xdata(), float)
    y = np.asarray(line.get_ydata(), float)
    assert np.isnan(x[2::3]).all() and (y[0::3] == y[1::3]).all()
    return [(x[i], x[i + 1], y[i]) for i in range(0, x.size, 3)]


def test_the_figure_draws_each_window_and_the_stretches(lab):
    study, _, _ = lab
    check = view_trial(study, "P01", "run-02")
    ax = draw_trial_check(check)
    bars = [ln for ln in ax.get_lines() if ln.get_linewidth() > 2]
    on_bars = [ln for ln in bars if ln.get_linestyle() == "-"]
    off_bars = [ln for ln in bars if ln.get_linestyle() != "-"]
    assert len(on_bars) == len(off_bars) == 2  # on the normal force and on the friction
    assert len({ln.get_color() for ln in on_bars}) == len({ln.get_color() for ln in off_bars})\
        == 1 and on_bars[0].get_color() != off_bars[0].get_color()
    drawn = [seg for ln in bars for seg in _segments(ln)]
    assert len(drawn) == 2 * len(check.windows)
    for w in check.windows.itertuples():  # each window's bars, at its means in mN
        mine = [seg for seg in drawn if seg[0] == pytest.approx(w.t_start_s, abs=1e-6)
                and seg[1] == pytest.approx(w.t_end_s, abs=1e-6)]
        heights = sorted(abs(y) for _, _, y in mine)
        assert heights == pytest.approx(sorted([1e3 * w.normal_force_N,
                                                1e3 * w.friction_force_N]), rel=1e-9)
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert {"normal force", "tangential force", "ON window (mean)", "OFF window (mean)",
            "voltage ON", "finger lifted: zero read", "ON/OFF switch (guard)"} <= set(legend)
    assert ax.get_title() == "" and ax.get_ylabel() == "force (mN)"
    traces = [ln for ln in ax.get_lines() if ln.get_linewidth() < 1 and ln.get_gid() != "zero"]
    assert traces and all(ln.get_rasterized() for ln in traces)  # light in SVG and PDF
    normal = check.pieces[0].forces.normal
    assert np.nanmax(traces[0].get_ydata()) == pytest.approx(1e3 * np.nanmax(normal), rel=1e-6)


def test_the_caption_counts_what_the_figure_shows(lab):
    study, res, _ = lab
    check = view_trial(study, "P01", "run-01")
    caption = trial_caption(check)
    w = res.windows[res.windows.trial == "run-01"]
    n_on = int((w.condition == "on").sum())
    assert f"{n_on} ON and {len(w) - n_on} OFF steady-sliding windows" in caption
    assert caption.startswith("Trial P01/run-01 (square 10000 Hz at 80 V)")
    assert "finger lifted (zero read)" in caption and "ON/OFF switch (guard)" in caption


def test_a_figure_per_trial_and_one_saying_why_for_a_trial_not_analysed(lab, tmp_path):
    study, _, _ = lab
    copy = tmp_path / "study"
    shutil.copytree(study, copy)
    # a trial whose log holds no frame of the load cells
    (copy / "P01" / "run-02.log").write_text("(1763700000.000000) vcan0 123#00\n")
    figures = list(trial_check_figures(copy))
    assert [f.stem for f in figures] == ["trial_P01_run-01", "trial_P01_run-02",
                                         "trial_P01_run-03"]
    good, bad = figures[0], figures[1]
    assert len([ln for ln in good.axes.get_lines() if ln.get_linewidth() > 2]) == 4
    assert "not analysed" in bad.caption
    assert any("not analysed" in t.get_text() for t in bad.axes.texts)
    assert bad.error and bad.error in bad.caption  # compare makes a note of it
    subject, trial, axes, caption, error = good  # (subject, trial, axes, caption, error)
    assert (subject, trial) == ("P01", "run-01") and caption == good.caption
    assert error is None
    png = tmp_path / f"{good.stem}.png"
    axes.figure.savefig(png, dpi=60)
    pixels = plt_image(png)
    assert pixels.std() > 0.05  # not blank
    assert list(trial_check_figures(copy, subjects=["P02"])) == []


def plt_image(path: Path) -> np.ndarray:
    import matplotlib.image as mpimg

    return np.asarray(mpimg.imread(path))[..., :3]


def test_unknown_subject_and_trial_name_what_there_is(lab):
    study, _, _ = lab
    with pytest.raises(StudyError, match=r"no subject 'P9'; its subjects: P01"):
        view_trial(study, "P9", "run-01")
    with pytest.raises(StudyError, match=r"no trial 'run-9'; its trials: run-01, run-02"):
        plot_trial(study, "P01", "run-9")


def test_trial_stems_are_safe_names():
    assert trial_stem("P 01", "run.1/x") == "trial_P_01_run_1_x"
    for name in ("P01", "Ä b", "", "../x"):
        assert trial_stem(name, "t") == f"trial_{safe_name(name)}_t"


def test_a_long_trace_is_drawn_as_its_envelope():
    t = np.arange(100_000) / 1000.0
    y = np.sin(t)
    y[50_000] = 5.0  # a spike survives
    y[70_000:70_200] = np.nan  # a hole stays a hole
    tt, yy = envelope(t, y)
    assert tt.size <= MAX_POINTS
    assert np.nanmax(yy) == 5.0 and np.nanmin(yy) == pytest.approx(-1.0, abs=1e-6)
    assert np.isnan(yy).any()
    assert np.all(np.diff(tt) >= 0)
    short = np.arange(10.0)
    assert envelope(short, short)[1] is short


def test_the_recorded_reference_study(tmp_path):
    """Two trials of the recorded study (a square and a sine trial): the check's windows
    are those analyze writes, and the figure draws them."""
    study = tmp_path / "study"
    study.mkdir()
    shutil.copy(REFERENCE / "study.toml", study)
    shutil.copytree(REFERENCE / "rig", study / "rig")
    (study / "P02").mkdir()
    for trial in ("run-03", "run-06"):
        for suffix in (".log.gz", ".json"):
            shutil.copy(REFERENCE / "P02" / f"{trial}{suffix}", study / "P02")
    res = analyze_study(study, tmp_path / "out", jobs=1)
    for trial in ("run-03", "run-06"):
        check = view_trial(study, "P02", trial)
        _same_windows(check.windows, res.windows[res.windows.trial == trial])
        ax = draw_trial_check(check)
        assert len([seg for ln in ax.get_lines() if ln.get_linewidth() > 2
                    for seg in _segments(ln)]) == 2 * len(check.windows)
        kinds = {s.kind for s in excluded_stretches(check)}
        assert "switch" in kinds and "lifted" not in kinds  # no tare stretch recorded
