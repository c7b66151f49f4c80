"""Fitting the air gap to a subject whose forces are near zero or below it (a drive of a
volt or two beside the noise): the fit never crashes, never writes a negative length or an
arbitrary value; where its points see no force, the value is absent and the interval is
what the points exclude."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.analysis.friction.estimate import estimate_electrostatic
from evtribo.fit.fit import fit_subject, interval_notes
from evtribo.model import TABLE_1, electrostatic_force

H_L, MU = 5e-6, 0.5


def _points(amps: np.ndarray, seed: int, rel: float, n: int = 6
            ) -> tuple[pd.DataFrame, np.ndarray]:
    """A subject's cells at *amps* V through the real estimator: ON windows against one
    whole-OFF reference, the friction scattered by *rel*."""
    rng = np.random.default_rng(seed)
    p = TABLE_1.with_values(h_L=H_L, mu=MU)
    fn_off = rng.uniform(0.45, 0.55, n * amps.size)
    ft_off = MU * fn_off * (1 + rng.normal(0, rel, fn_off.size))
    fn_on = rng.uniform(0.45, 0.55, (amps.size, n))
    ft_on = MU * (fn_on + electrostatic_force(fn_on, amps[:, None], p)) * (
        1 + rng.normal(0, rel, fn_on.shape))
    e = estimate_electrostatic([fn_off], [ft_off], fn_on.ravel(), ft_on.ravel(),
                               np.zeros(fn_on.size, int), np.repeat(amps, n), n_boot=200,
                               seed=seed)
    rows = pd.DataFrame({"subject": "S", "waveform": "square", "amplitude_V": e.groups,
                         "mu": e.mu, "normal_force_on_N": e.normal_on_N,
                         "electrostatic_force_N": e.force_N,
                         "electrostatic_force_ci_low_N": e.ci_low_N,
                         "electrostatic_force_ci_high_N": e.ci_high_N})
    return rows, e.replicates_N


@settings(max_examples=40)
@given(amps=st.sampled_from([(1.0,), (1.0, 2.0), (1.0, 140.0), (2.0, 5.0, 10.0),
                             (1.0, 2.0, 3.0)]),
       seed=st.integers(0, 2**32 - 1), rel=st.sampled_from([0.005, 0.02, 0.05]))
def test_the_air_gap_is_a_length_or_absent(amps, seed, rel):
    rows, reps = _points(np.array(amps), seed, rel)
    fit = fit_subject("S", rows, TABLE_1, ("h_L",), replicates=reps)
    e = fit["h_L"]
    assert 0.0 <= e.ci_low <= e.ci_high  # never a negative length
    if math.isnan(e.value):  # the points saw no force: what they exclude, open above
        assert fit.interval_method == "profile"
        assert e.ci_low < math.inf and e.ci_high == math.inf  # ci_low 0: none excluded
        assert "do not differ from zero" in fit.interval_note
        [said] = interval_notes([fit], has_bootstrap=True)
        assert said.kind == "intervals-profile" and said.scope.subject == "S"
        assert said.text.startswith("S: h_L is not determined by these data: its forces do "
                                    "not differ from zero")
    else:
        assert 0.0 <= e.value <= 0.1 and e.ci_low <= e.value <= e.ci_high


def test_points_at_or_below_zero_give_no_value_and_a_lower_bound():
    rows = pd.DataFrame({"subject": "S", "waveform": "square", "amplitude_V": [1.0, 2.0],
                         "mu": MU, "normal_force_on_N": 0.5,
                         "electrostatic_force_N": [-1.2e-4, -1.6e-4],
                         "electrostatic_force_ci_low_N": [-4.3e-4, -5.2e-4],
                         "electrostatic_force_ci_high_N": [1.9e-4, 1.7e-4]})
    fit = fit_subject("S", rows, TABLE_1, ("h_L",))
    e = fit["h_L"]
    assert math.isnan(e.value) and e.ci_high == math.inf
    # the gap whose force at 2 V the points would have seen is excluded
    at = TABLE_1.with_values(h_L=e.ci_low, mu=MU)
    assert electrostatic_force(0.5, 2.0, at) > 1.7e-4
    assert electrostatic_force(0.5, 2.0, TABLE_1.with_values(h_L=2 * e.ci_low, mu=MU)) \
        < electrostatic_force(0.5, 2.0, at)
