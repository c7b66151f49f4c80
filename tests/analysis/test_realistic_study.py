"""The analysis on what real rigs and hands produce: load-cell offsets up to +/-50 mN that
drift by up to +/-10 mN per trial, 10 mN of 50 Hz hum, cross-talk, unsynchronised cells, a
person's irregular strokes with rests at the reversals and lift-offs.

Every result is held against the simulator's truth: the electrostatic force of a row is
the mean of the simulated force over the row's own ON windows (the samples each spans).
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pandas as pd
import pytest

from _realistic import (
    AMPLITUDES,
    attach_truth,
    fel_within,
    offsets_error,
    run_study,
    window_truth,
)
from evtribo.acquisition.simulator import TrialConfig, default_subjects, simulate_study
from evtribo.acquisition.simulator.realism import human
from evtribo.analysis.settings import AnalysisSettings
from evtribo.results.pipeline import analyze_study

CROSSTALK = ((1.0, 0.03), (-0.03, 1.0))
#: [rig.calibration] of the study: a cross-talk matrix measured on the rig, and offsets from
#: a calibration some time ago (the cells have moved since: taring does the rest)
CALIBRATION = {"normal_offset_N": 0.02, "tangential_offset_N": -0.01,
               "matrix": np.linalg.inv(CROSSTALK).tolist()}


@pytest.fixture(scope="module")
def lab_study(tmp_path_factory):
    """4 subjects x 5 amplitudes, alternating, on a real rig with 3 % cross-talk whose
    matrix study.toml gives, analysed by ``analyze_study`` from the files."""
    root = tmp_path_factory.mktemp("lab-study")
    subjects = default_subjects(4, seed=21)
    cfg = TrialConfig(duration_s=16.0, fz_ppm=300.0, fx_ppm=-200.0, crosstalk=CROSSTALK,
                      drop_probability=0.002, foreign_rate_Hz=10.0, seed=21)
    truth = simulate_study(root, subjects, amplitudes=AMPLITUDES, config=cfg,
                           sine_trial=False, realistic=True)
    toml = root / "study.toml"
    matrix = ", ".join(f"[{a!r}, {b!r}]" for a, b in CALIBRATION["matrix"])
    toml.write_text(toml.read_text(encoding="utf-8") + "\n[rig.calibration]\n"
                    f"normal_offset_N = {CALIBRATION['normal_offset_N']}\n"
                    f"tangential_offset_N = {CALIBRATION['tangential_offset_N']}\n"
                    f"matrix = [{matrix}]\n", encoding="utf-8")
    out = tmp_path_factory.mktemp("lab-out")
    res = analyze_study(root, out, jobs=2, settings=AnalysisSettings(n_boot=1000))
    truths = {(s, t): tr for s, runs in truth.items() for t, tr in runs.items()}
    windows = pd.concat([window_truth(w, truths[(s, t)]) for (s, t), w
                         in res.windows.groupby(["subject", "trial"], sort=False)],
                        ignore_index=True)
    mu_of = {s: next(iter(runs.values())).subject.mu for s, runs in truth.items()}
    el, ex = attach_truth(res.electrostatic, res.exponents, windows, mu_of)
    return res, windows, el, ex, truths


def test_the_study_has_what_real_rigs_and_hands_add(lab_study):
    res, _, _, _, truths = lab_study
    cells = [tr.cells[c] for tr in truths.values() for c in ("normal", "tangential")]
    assert max(abs(c["offset_N"]) for c in cells) > 0.03
    assert all(abs(c["offset_N"]) <= 0.05 and c["hum_N"] == 0.01 for c in cells)
    assert sum(len(tr.lifted) > 1 for tr in truths.values()) >= 5  # lift-offs besides tares
    assert all(tr.lifted[0] == pytest.approx((0.0, 1.5)) for tr in truths.values())
    assert all(tr.subject.dwell_s > 0 for tr in truths.values())
    summary = res.summary
    assert summary["calibration"]["matrix"] == CALIBRATION["matrix"]
    assert summary["settings"]["tare"] == "auto"


def test_electrostatic_force_mu_and_exponent_hold_against_the_truth(lab_study):
    _, _, el, ex, _ = lab_study
    assert len(el) == 4 * len(AMPLITUDES)
    ok = fel_within(el.electrostatic_force_N, el.fel_true_N)
    assert ok.all(), el[~ok][["subject", "amplitude_V", "electrostatic_force_N", "fel_true_N"]]
    np.testing.assert_allclose(el.mu, el.mu_true, rtol=0.02)
    assert len(ex) == 4
    np.testing.assert_allclose(ex.exponent, ex.exponent_true, atol=0.1)


def test_every_window_lies_in_steady_sliding_of_its_condition(lab_study):
    _, windows, _, _, _ = lab_study
    assert len(windows) > 200
    assert (windows.steady >= 0.9).all(), windows[windows.steady < 0.9]


def test_trials_csv_reports_the_offsets_removed(lab_study):
    res, _, _, _, truths = lab_study
    trials = pd.read_csv(res.out_dir / "trials.csv")
    assert {"normal_offset_N", "tangential_offset_N", "tare"} <= set(trials.columns)
    assert trials.tare.str.startswith("calibration+lifted").all(), trials.tare
    err = offsets_error(trials, truths)
    assert err.normal.abs().max() < 0.002 and err.tangential.abs().max() < 0.002, err


@pytest.mark.slow
def test_intervals_cover_the_truth_over_repeated_seeds():
    rows = pd.concat([run_study(seed).electrostatic for seed in range(6)], ignore_index=True)
    covered = ((rows.electrostatic_force_ci_low_N <= rows.fel_true_N)
               & (rows.fel_true_N <= rows.electrostatic_force_ci_high_N))
    assert len(rows) == 6 * 4 * len(AMPLITUDES)
    assert covered.mean() >= 0.9, covered.mean()
    assert fel_within(rows.electrostatic_force_N, rows.fel_true_N).mean() >= 0.97


def test_a_tangential_offset_without_lifted_stretch_is_taken_from_the_friction_loop():
    def exact_normal_cell(cfg):  # offsets and drift on the tangential cell only, no tare
        return dataclasses.replace(cfg, tare_s=0.0, fz_offset_N=0.0, fz_drift_N_per_s=0.0,
                                   fz_thermal_N=0.0)

    run = run_study(3, rig_changes=exact_normal_cell,
                    subject_changes=lambda s: dataclasses.replace(s, lifts_per_min=0.0))
    assert (run.trials.tare == "friction-loop").mean() >= 0.9
    assert max(abs(tr.cells["tangential"]["offset_N"]) for tr in run.truths.values()) > 0.03
    el = run.electrostatic
    ok = fel_within(el.electrostatic_force_N, el.fel_true_N)
    assert ok.all(), el[~ok]
    np.testing.assert_allclose(el.mu, el.mu_true, rtol=0.02)
    np.testing.assert_allclose(run.exponents.exponent, run.exponents.exponent_true, atol=0.1)
    # the normal cell's zero was never measured: each trial says so
    unknown = [w for w in run.warnings if "the normal cell's zero is unknown" in w]
    assert len(unknown) == len(run.trials)
    assert unknown[0].startswith("P01/run-01: ") and "[rig.calibration]" in unknown[0]


def test_without_taring_the_same_data_give_wrong_forces():
    """What the taring is for: the realistic study analysed with ``tare = "none"``."""
    run = run_study(0, n_subjects=2, settings=AnalysisSettings(tare="none", n_boot=500))
    el = run.electrostatic
    assert not fel_within(el.electrostatic_force_N, el.fel_true_N).all()
    assert (run.trials.tare == "none").all() and run.trials.normal_offset_N.isna().all()


def test_the_ideal_rig_keeps_its_accuracy():
    run = run_study(5, realistic=False)
    el = run.electrostatic
    np.testing.assert_allclose(el.electrostatic_force_N, el.fel_true_N, rtol=0.01)
    np.testing.assert_allclose(el.mu, el.mu_true, rtol=0.002)
    assert (run.windows.steady == 1.0).all()


def test_a_normal_offset_without_lifted_stretch_or_calibration_is_a_warning(tmp_path):
    subject = dataclasses.replace(human(default_subjects(1, seed=2)[0], seed=2),
                                  lifts_per_min=0.0)
    cfg = TrialConfig(duration_s=10.0, fz_offset_N=0.04, fx_offset_N=-0.02, seed=2)
    simulate_study(tmp_path / "st", [subject], amplitudes=(100.0, 140.0), config=cfg,
                   sine_trial=False)
    res = analyze_study(tmp_path / "st", tmp_path / "out", jobs=1,
                        settings=AnalysisSettings(n_boot=200))
    summary = json.loads((tmp_path / "out" / "summary.json").read_text(encoding="utf-8"))
    texts = [w["text"] for w in summary["warnings"]]
    for trial in ("run-01", "run-02"):
        assert any(w.startswith(f"P01/{trial}: the normal cell's zero is unknown")
                   and "evtribo acquire --tare-s" in w for w in texts)
    trials = res.trials
    assert trials.normal_offset_N.isna().all()  # nothing removed from the normal cell
    assert (trials.tare == "friction-loop").all()
    np.testing.assert_allclose(trials.tangential_offset_N, -0.02, atol=0.002)
