"""Trials of different drive frequencies at one amplitude are different rows of
electrostatic.csv (they were merged into one), and power laws are per frequency."""

import numpy as np
import pandas as pd
import pytest

from evtribo.results.aggregate import (
    BOOTSTRAP_COLUMNS,
    ELECTROSTATIC_COLUMNS,
    EXPONENT_COLUMNS,
    summarize,
)


def _study(freqs_by_trial, gain_by_freq, amps=(60.0, 100.0, 140.0), seed=0):
    """Windows of alternating trials: one per (frequency, amplitude); the electrostatic
    force is 1e-5 U^2 times the frequency's gain."""
    rng = np.random.default_rng(seed)
    rows, trials = [], []
    k = 0
    for nominal, reported in freqs_by_trial:
        for amp in amps:
            k += 1
            trial = f"run-{k:02d}"
            trials.append({"subject": "P01", "trial": trial, "condition": "alternating",
                           "frequency_Hz": reported, "waveform": "square"})
            fel = 1e-5 * amp**2 * gain_by_freq[nominal]
            for cond in ("off", "on") * 6:
                fn = 0.5 + 0.02 * rng.standard_normal()
                ft = 0.4 * (fn + (fel if cond == "on" else 0.0)) + 1e-4 * rng.standard_normal()
                rows.append(("P01", trial, cond, amp if cond == "on" else 0.0, "square", fn,
                             ft))
    windows = pd.DataFrame(rows, columns=["subject", "trial", "condition", "amplitude_V",
                                          "waveform", "normal_force_N", "friction_force_N"])
    return windows, pd.DataFrame(trials)


def test_each_frequency_is_its_own_row_and_power_law():
    gains = {20.0: 0.3, 10000.0: 1.0}
    windows, trials = _study([(20.0, 20.0), (10000.0, 10000.0)], gains)
    el, ex, boot, _ = summarize(windows, trials, n_boot=200, n_saved=50)
    assert list(el.columns) == list(ELECTROSTATIC_COLUMNS)
    assert list(ex.columns) == list(EXPONENT_COLUMNS)
    assert list(boot.columns) == list(BOOTSTRAP_COLUMNS)
    assert len(el) == 6 and sorted(set(el.frequency_Hz)) == [20.0, 10000.0]
    for row in el.itertuples():
        assert row.electrostatic_force_N == pytest.approx(
            1e-5 * row.amplitude_V**2 * gains[row.frequency_Hz], rel=0.02)
    assert sorted(ex.frequency_Hz) == [20.0, 10000.0]
    np.testing.assert_allclose(ex.exponent, 2.0, atol=0.02)
    # each row's replicates are its own: 50 per (frequency, amplitude)
    assert boot.groupby(["frequency_Hz", "amplitude_V"]).size().tolist() == [50] * 6


def test_frequencies_an_amplifier_reports_alike_are_one_drive():
    windows, trials = _study([(10000.0, 9999.8), (10000.0, 10000.2)], {10000.0: 1.0})
    el, ex, _, _ = summarize(windows, trials, n_boot=200)
    assert len(el) == 3 and el.frequency_Hz.tolist() == [10000.0] * 3
    assert (el.n_on == 12).all()  # both trials of each amplitude
    assert len(ex) == 1
