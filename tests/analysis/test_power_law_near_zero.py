"""A subject's power law F_el = k U^n on the log scale uses the cells whose force's interval
lies above zero: a cell within its error of zero (a drive of a volt beside the noise) has no
logarithm the data determine, and is left out, said (its exponent would be the noise's)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.analysis.friction.powerlaw import fit_power_law
from evtribo.results.aggregate import summarize_study


def _windows(amps: tuple[float, ...], noise_N: float, seed: int
             ) -> tuple[pd.DataFrame, pd.DataFrame]:
    """One subject's alternating trials, one per amplitude: F_el = 1e-5 U^2, the friction
    scattered by *noise_N*."""
    rng = np.random.default_rng(seed)
    rows, trials = [], []
    for k, amp in enumerate(amps, 1):
        trial = f"run-{k:02d}"
        trials.append({"subject": "P01", "trial": trial, "condition": "alternating",
                       "frequency_Hz": 10000.0, "waveform": "square"})
        for cond in ("off", "on") * 6:
            fn = 0.5 + 0.02 * rng.standard_normal()
            fel = 1e-5 * amp**2 if cond == "on" else 0.0
            ft = 0.4 * (fn + fel) + noise_N * rng.standard_normal()
            rows.append(("P01", trial, cond, amp if cond == "on" else 0.0, "square", fn, ft))
    windows = pd.DataFrame(rows, columns=["subject", "trial", "condition", "amplitude_V",
                                          "waveform", "normal_force_N", "friction_force_N"])
    return windows, pd.DataFrame(trials)


@settings(max_examples=20)
@given(amps=st.sampled_from([(1.0, 60.0, 140.0), (1.0, 140.0), (1.0, 2.0, 3.0),
                             (2.0, 5.0, 100.0, 140.0)]),
       noise=st.sampled_from([1e-4, 1e-3, 3e-3]), seed=st.integers(0, 2**32 - 1))
def test_the_power_law_uses_the_cells_above_zero_and_names_the_others(amps, noise, seed):
    windows, trials = _windows(amps, noise, seed)
    out = summarize_study(windows, trials, n_boot=200)
    es = out.electrostatic
    texts = [w.text for w in out.warnings]
    kept = es[es["electrostatic_force_ci_low_N"] > 0]
    for row in es[~(es["electrostatic_force_ci_low_N"] > 0)].itertuples():
        assert any(w.startswith(f"P01 (square, 10000 Hz) at {row.amplitude_V:g} V: left out "
                                "of the power law") for w in texts), texts
    if len(kept) >= 2:
        expected = fit_power_law(kept["amplitude_V"], kept["electrostatic_force_N"])
        assert out.exponents["exponent"].tolist() == pytest.approx([expected.exponent])
    else:
        assert out.exponents.empty
        assert "P01 (square, 10000 Hz): no power law: fewer than two amplitudes whose " \
               "F_el's interval lies above zero" in texts or len(es) < 2
