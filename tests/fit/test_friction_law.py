"""The model's friction as a finger pad has it, F_t = mu W0 (W/W0)^m with W = F_ext + F_el,
and compare fitting with the law analyze measured."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.fit.fit import fit_subject
from evtribo.fit.problem import with_friction_law
from evtribo.model import TABLE_1, electrostatic_force, friction_force

positive = st.floats(0.05, 3.0)


@settings(max_examples=60, deadline=None)
@given(load=positive, w0=positive, m=st.floats(0.5, 1.2))
def test_the_law_is_coulombs_at_m_1_and_mu_w0_at_w0(load, w0, m):
    coulomb = TABLE_1.with_values(W0=w0)
    assert float(coulomb.friction(load)) == pytest.approx(TABLE_1.mu * load, rel=1e-12)
    law = TABLE_1.with_values(m=m, W0=w0)
    assert float(law.friction(w0)) == pytest.approx(TABLE_1.mu * w0, rel=1e-12)
    # its slope in log-log is m
    slope = np.log(float(law.friction(2 * load)) / float(law.friction(load))) / np.log(2)
    assert slope == pytest.approx(m, rel=1e-9)


def test_the_models_friction_loads_the_contact_with_the_electrostatic_force():
    p = TABLE_1.with_values(m=0.75, W0=0.5)
    fel = float(electrostatic_force(0.5, 140.0, p))
    assert float(friction_force(0.5, 140.0, p)) == pytest.approx(
        p.mu * 0.5 * ((0.5 + fel) / 0.5) ** 0.75, rel=1e-12)
    assert float(friction_force(0.5, 0.0, p)) == pytest.approx(p.mu * 0.5, rel=1e-12)


def _subject(m_true, fel_scale=1.0):
    """electrostatic.csv's rows and windows.csv's of a subject whose friction is the
    model's with the exponent *m_true* (the points' forces are the model's own)."""
    truth = TABLE_1.with_values(mu=0.42, h_L=4e-6, m=m_true, W0=0.5)
    amps = np.array([60.0, 80.0, 100.0, 120.0, 140.0])
    fel = fel_scale * np.asarray(electrostatic_force(0.5, amps, truth))
    rows = pd.DataFrame({
        "subject": "S", "waveform": "square", "frequency_Hz": 10000.0, "amplitude_V": amps,
        "normal_force_on_N": 0.5, "electrostatic_force_N": fel,
        "electrostatic_force_ci_low_N": fel - 0.004, "electrostatic_force_ci_high_N": fel + 0.004,
        "mu": 0.42, "friction_exponent": m_true})
    fn = np.tile([0.35, 0.5, 0.65], amps.size)
    amp = np.repeat(amps, 3)
    on = pd.DataFrame({"condition": "on", "amplitude_V": amp, "waveform": "square",
                       "frequency_Hz": 10000.0, "normal_force_N": fn,
                       "friction_force_N": np.asarray(friction_force(fn, amp, truth))})
    off = pd.DataFrame({"condition": "off", "amplitude_V": 0.0, "waveform": "square",
                        "frequency_Hz": 10000.0, "normal_force_N": [0.35, 0.5, 0.65],
                        "friction_force_N": np.asarray(friction_force([0.35, 0.5, 0.65], 0.0,
                                                                      truth))})
    return rows, pd.concat([on, off], ignore_index=True)


def test_compare_fits_mu_with_the_subjects_law():
    rows, windows = _subject(0.75)
    base = with_friction_law(TABLE_1, rows)
    assert (base.m, base.W0) == (0.75, 0.5)
    fit = fit_subject("S", rows, fit=("h_L", "mu"), windows=windows)
    assert fit.params.m == 0.75
    assert fit["mu"].value == pytest.approx(0.42, rel=1e-3)
    assert fit["h_L"].value == pytest.approx(4e-6, rel=1e-2)
    # the same windows read with Coulomb's law: mu is another
    coulomb = fit_subject("S", rows.drop(columns=["friction_exponent"]), fit=("h_L", "mu"),
                          windows=windows)
    assert coulomb.params.m == 1.0
    assert abs(coulomb["mu"].value / 0.42 - 1) > 0.01


def test_without_the_law_in_the_table_the_model_keeps_coulomb():
    rows, _ = _subject(0.8)
    assert with_friction_law(TABLE_1, rows.drop(columns=["friction_exponent"])) == TABLE_1
    rows["friction_exponent"] = np.nan
    assert with_friction_law(TABLE_1, rows) == TABLE_1
