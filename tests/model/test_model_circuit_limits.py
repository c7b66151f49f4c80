"""The circuit's limits approached, not only reached: the force falls steadily to nothing as
the gap's leak grows, and rises steadily to the paper's as the frequency grows."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo import model

P = model.TABLE_1


@settings(deadline=None, max_examples=30)
@given(f=st.floats(1.0, 1e4), r_sc=st.sampled_from([np.inf, 1e3, 50.0]),
       waveform=st.sampled_from(["sine", "square"]))
def test_the_force_falls_to_nothing_as_the_gap_leaks(f, r_sc, waveform):
    r_g = np.geomspace(1e4, 1e-8, 25)
    force = np.array([float(model.electrostatic_force_drive(
        0.5, 120.0, f, waveform, P.with_values(r_g=r, r_sc=r_sc))) for r in r_g])
    assert np.all(np.diff(force) <= 1e-12 * force[0])  # a larger leak, never more force
    assert force[-1] < 1e-6 * float(model.electrostatic_force(0.5, 120.0))


@pytest.mark.parametrize("waveform", ["sine", "square"])
@pytest.mark.parametrize("changes", [{"r_g": 30.0}, {"r_g": 300.0, "r_sc": 1e4}])
def test_the_force_rises_to_the_papers_with_the_frequency(waveform, changes):
    params = P.with_values(changes)
    f = np.geomspace(1.0, 1e8, 41)
    force = np.asarray(model.electrostatic_force_drive(0.5, 120.0, f, waveform, params))
    paper = np.asarray(model.electrostatic_force_drive(0.5, 120.0, f, waveform, P))
    gap = np.abs(force / paper - 1.0)
    assert np.all(np.diff(gap) <= 1e-12)
    assert gap[-1] < 1e-5 and gap[0] > 0.5
