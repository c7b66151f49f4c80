"""compare --fit h_L,r_g on a frequency sweep: every point at its own frequency, the
resistance fitted in log space, bootstrap replicates matched by frequency, intervals that
hold the truth; end to end from the simulated rig."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from evtribo.errors import AnalysisError
from evtribo.fit.fit import fit_subject
from evtribo.fit.model_points import mean_electrostatic_force
from evtribo.fit.tables import replicate_matrix
from evtribo.model import TABLE_1, electrostatic_force_drive
from sweep_data import sweep_rows


def _replicates(rows: pd.DataFrame, noise: float, seed: int, n: int = 200) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rows["electrostatic_force_N"].to_numpy() * np.exp(
        noise * rng.standard_normal((n, len(rows))))


def test_a_sweep_gives_back_the_gap_and_its_leak():
    """Six subjects (two sweeps): every estimate within 10 % (h_L) and 20 % (r_g), and the
    95 % intervals hold the truth (at least 5 of 6 per parameter: a 95 % interval misses
    one time in twenty)."""
    held = {"h_L": 0, "r_g": 0}
    for seed in (0, 1):
        rows, truth = sweep_rows("circuit", seed, noise=0.03)
        for subject, true in truth.items():
            mine = rows[rows["subject"] == subject].reset_index(drop=True)
            fit = fit_subject(subject, mine, fit=("h_L", "r_g"),
                              replicates=_replicates(mine, 0.03, seed))
            assert fit.interval_method == "bootstrap"
            for name, tol in (("h_L", 0.10), ("r_g", 0.20)):
                est = fit[name]
                assert est.value == pytest.approx(true[name], rel=tol), name
                assert est.ci_low > 0 and math.isfinite(est.ci_high)
                held[name] += est.contains(true[name])
    assert held["h_L"] >= 5 and held["r_g"] >= 5, held


def test_resistances_span_decades_and_are_found_from_any_start():
    """Corners from 20 to 300 Hz are r_g over more than a decade; the start is a grid's
    best, so a leak ten times larger than the Jacobian's first step is still found."""
    rows, truth = sweep_rows("circuit", 4, noise=0.01)
    values = sorted(t["r_g"] for t in truth.values())
    for subject, true in truth.items():
        fit = fit_subject(subject, rows[rows["subject"] == subject], fit=("h_L", "r_g"))
        assert fit["r_g"].value == pytest.approx(true["r_g"], rel=0.05)
        assert fit.interval_method == "jacobian"
        assert fit["r_g"].ci_low < true["r_g"] < fit["r_g"].ci_high
    assert values[-1] / values[0] > 2


def test_without_a_leak_the_resistance_is_open_above():
    rows, truth = sweep_rows("paper", 2, subjects=1)
    fit = fit_subject("P01", rows, fit=("h_L", "r_g"))
    assert fit["h_L"].value == pytest.approx(truth["P01"]["h_L"], rel=0.02)
    assert fit["r_g"].ci_high == math.inf  # the data cannot tell it from no leak at all


def test_the_points_are_the_circuit_model_at_their_frequency_and_waveform():
    p = TABLE_1.with_values(r_g=60.0, r_sc=2e3)
    fn = np.array([0.3, 0.5, 0.5, 0.7])
    amp = np.array([100.0, 80.0, 120.0, 100.0])
    freq = np.array([20.0, 200.0, 2000.0, 20.0])
    wave = np.array(["square", "sine", "square", "sine"], dtype=object)
    got = mean_electrostatic_force(fn, amp, wave, p, frequency=freq)
    want = [float(electrostatic_force_drive(fn[i], amp[i], freq[i], wave[i], p))
            for i in range(4)]
    # (the sines: two 64-phase quadratures of the period, which agree to 1e-7)
    np.testing.assert_allclose(got, want, rtol=1e-6)
    # the paper's resistances: no frequency dependence at all
    paper = mean_electrostatic_force(fn, amp, wave, TABLE_1, frequency=freq)
    np.testing.assert_array_equal(paper, mean_electrostatic_force(fn, amp, wave, TABLE_1))


def test_fitting_a_resistance_needs_the_frequencies():
    rows, _ = sweep_rows("circuit", 0, subjects=1)
    with pytest.raises(AnalysisError, match="frequency_Hz"):
        fit_subject("P01", rows.assign(frequency_Hz=np.nan), fit=("h_L", "r_g"))


def test_replicates_are_matched_by_frequency_as_well_as_amplitude():
    rows = pd.DataFrame({"subject": "P01", "waveform": "square",
                         "frequency_Hz": [20.0, 1000.0, 20.0],
                         "amplitude_V": [100.0, 100.0, 140.0]})
    boot = pd.DataFrame([{"subject": "P01", "waveform": "square", "frequency_Hz": f,
                          "amplitude_V": a, "replicate": r,
                          "electrostatic_force_N": f + a / 1000 + r / 1e6}
                         for f, a in ((1000.0, 100.0), (20.0, 140.0), (20.0, 100.0))
                         for r in range(60)])
    mat = replicate_matrix(rows, boot)
    assert mat is not None and mat.shape == (60, 3)
    np.testing.assert_allclose(mat[:, 0], 20.1 + np.arange(60) / 1e6)
    np.testing.assert_allclose(mat[:, 1], 1000.1 + np.arange(60) / 1e6)
    np.testing.assert_allclose(mat[:, 2], 20.14 + np.arange(60) / 1e6)
    assert replicate_matrix(rows.assign(frequency_Hz=[20.0, 500.0, 20.0]), boot) is None


@pytest.mark.slow
def test_simulate_analyze_compare_recovers_each_subjects_gap_and_leak(tmp_path):
    """Three subjects, square drives at 100 V from 20 Hz to 10 kHz, each with a leaky gap
    (corners 30, 100 and 250 Hz), through the simulated rig, analyze and compare: h_L and
    r_g recovered, and the circuit the model of lowest AIC for each subject."""
    from evtribo.cli import main
    from sweep_study import sweep_study

    out, truth = sweep_study(tmp_path)
    assert main(["compare", str(out), "--fit", "h_L,r_g", "--dpi", "40",
                 "--models", "paper,hertz,maugis,circuit"]) == 0
    models = pd.read_csv(out / "models.csv")
    assert list(models.groupby("subject")["model"].first()) == ["circuit"] * 3
    fit = pd.read_csv(out / "fit.csv")
    for subject, true in truth.items():
        for name, tol in (("h_L", 0.10), ("r_g", 0.20)):
            row = fit[(fit["subject"] == subject) & (fit["parameter"] == name)].iloc[0]
            assert row["value"] == pytest.approx(true[name], rel=tol), (subject, name)
            assert row["ci_low"] <= true[name] <= row["ci_high"], (subject, name, row)


def test_windows_are_evaluated_at_their_trials_frequency():
    """With mu fitted the windows join the residuals: ON at the trial's drive frequency
    (from trials.csv), OFF without voltage whatever the frequency."""
    from evtribo.fit.fit import _with_frequency
    from evtribo.fit.model_points import mean_friction_force
    from evtribo.model import effective_voltage, friction_force

    p = TABLE_1.with_values(r_g=60.0)
    windows = pd.DataFrame({"subject": ["P01"] * 3, "trial": ["f-01", "f-02", "f-02"],
                            "condition": ["on", "on", "off"], "amplitude_V": [100.0] * 3,
                            "waveform": ["square"] * 3, "normal_force_N": [0.5] * 3})
    trials = pd.DataFrame({"subject": ["P01", "P01"], "trial": ["f-01", "f-02"],
                           "frequency_Hz": [20.0, 5000.0]})
    got = _with_frequency(windows, trials)
    assert list(got["frequency_Hz"]) == [20.0, 5000.0, 5000.0]
    amp = np.array([100.0, 100.0, 0.0])
    model = mean_friction_force(0.5, amp, "square", p, frequency=got["frequency_Hz"])
    u_eff = [float(effective_voltage(100.0, f, "square", p)) for f in (20.0, 5000.0)]
    np.testing.assert_allclose(model, [float(friction_force(0.5, u_eff[0], p)),
                                       float(friction_force(0.5, u_eff[1], p)),
                                       float(friction_force(0.5, 0.0, p))], rtol=1e-12)
    assert u_eff[0] < 0.5 * u_eff[1]


def test_a_conducting_stratum_corneum_is_fitted_too():
    """--fit h_L,r_sc: a skin whose corner is 30 Hz raises the force at low frequency by a
    few per cent only (Table 1's layers), so r_sc comes with a wide interval that holds
    the truth and excludes the paper's insulator."""
    from evtribo.model import layer_elastances

    s_sc, s_g, s_i = (float(s) for s in layer_elastances(TABLE_1))
    r_sc = 1 / (2 * np.pi * 30.0 * (1 / s_sc + 1 / (s_g + s_i)))
    p = TABLE_1.with_values(h_L=5e-6, r_sc=r_sc)
    f, u = (a.ravel() for a in np.meshgrid(np.geomspace(1.0, 1e4, 12), (40., 70., 100., 140.)))
    fn = np.full(f.size, 0.5)
    rng = np.random.default_rng(0)
    meas = mean_electrostatic_force(fn, u, "square", p, frequency=f) * np.exp(
        0.02 * rng.standard_normal(f.size))
    rows = pd.DataFrame({"subject": "P01", "waveform": "square", "frequency_Hz": f,
                         "amplitude_V": u, "mu": 0.5, "normal_force_on_N": fn,
                         "electrostatic_force_N": meas,
                         "electrostatic_force_ci_low_N": meas * (1 - 1.96 * 0.02),
                         "electrostatic_force_ci_high_N": meas * (1 + 1.96 * 0.02)})
    fit = fit_subject("P01", rows, fit=("h_L", "r_sc"))
    assert fit["h_L"].value == pytest.approx(5e-6, rel=0.01)
    assert fit["r_sc"].contains(r_sc)
    assert math.isfinite(fit["r_sc"].ci_high) and fit["r_sc"].ci_low > 0
