"""The population's statistics: pooling (with tau, I^2 and the prediction interval) and the
subjects far from the others."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

sys.path.insert(0, str(Path(__file__).parent))

from evtribo.population.estimates import population
from evtribo.population.stats import find_outliers, pool, tau_interval
from population_sim import hierarchical_tables


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-3, 3), min_size=3, max_size=12),
       st.floats(-100, 100), st.floats(0.01, 0.5))
def test_pool_moves_with_the_values(values, shift, se):
    """Shifting every subject's value shifts the population's estimate and interval alike;
    the interval holds the estimate and the spread is not negative."""
    y = np.array(values)
    v = np.full(y.size, se**2)
    a, b = pool(y, v), pool(y + shift, v)
    assert b.estimate == pytest.approx(a.estimate + shift, abs=1e-7)
    assert b.ci_low == pytest.approx(a.ci_low + shift, abs=1e-6)
    assert b.ci_high == pytest.approx(a.ci_high + shift, abs=1e-6)
    assert a.ci_low <= a.estimate <= a.ci_high
    assert a.between_sd >= 0 and a.n_subjects == y.size


def test_pool_of_agreeing_subjects_is_their_weighted_mean():
    """Subjects that agree within their errors: no spread between them, the
    inverse-variance mean, and an interval at least as wide as the known errors give."""
    y = np.array([1.00, 1.01, 0.99, 1.005, 0.995])
    v = np.array([0.01, 0.02, 0.01, 0.04, 0.01]) ** 2
    p = pool(y, v)
    assert p.between_sd == 0.0
    assert p.estimate == pytest.approx(float(np.sum(y / v) / np.sum(1 / v)))
    half = 2.776 * math.sqrt(1 / np.sum(1 / v))  # t(4) times the known standard error
    assert p.ci_high - p.estimate >= half * 0.999


def test_pool_refuses_fewer_than_three():
    with pytest.raises(ValueError, match="at least 3"):
        pool([1.0, 2.0], [0.1, 0.1])


def test_an_outlier_is_named_and_the_others_not():
    rng = np.random.default_rng(4)
    y = rng.normal(0.0, 0.3, 8)
    y[5] = 3.0  # ten standard deviations off
    found = find_outliers(y, np.full(8, 0.01), [f"S{i}" for i in range(8)])
    assert [o.subject for o in found] == ["S5"]
    assert not found[0].low <= 3.0 <= found[0].high
    assert find_outliers(y[:4], np.full(4, 0.01), ["a", "b", "c", "d"]) == []  # too few


def test_no_outlier_among_twelve_normal_subjects():
    rng = np.random.default_rng(11)
    y = rng.normal(0.0, 0.5, 12)
    assert find_outliers(y, np.full(12, 0.02**2), [str(i) for i in range(12)]) == []


def test_tau_interval_holds_the_spread_and_i2_follows():
    """Subjects spread by 0.5 with errors of 0.1: tau's Q-profile interval holds 0.5 and
    the estimate; I^2 near 1 with its interval in [0, 1]; the prediction interval is wider
    than the confidence interval and holds most subjects."""
    rng = np.random.default_rng(7)
    y = rng.normal(1.0, 0.5, 10) + rng.normal(0, 0.1, 10)
    p = pool(y, np.full(10, 0.01))
    assert p.tau_low <= p.between_sd <= p.tau_high
    assert p.tau_low < 0.5 < p.tau_high
    assert 0.0 <= p.i2_low <= p.i2 <= p.i2_high <= 1.0 and p.i2 > 0.9
    assert p.pi_low < p.ci_low < p.ci_high < p.pi_high
    assert np.mean((p.pi_low <= y) & (y <= p.pi_high)) >= 0.8


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-2, 2), min_size=3, max_size=10), st.floats(0.01, 0.5))
def test_tau_interval_brackets_the_estimate(values, se):
    """Q-profile: tau's interval holds the Paule-Mandel estimate (both solve the generalised
    Q statistic, at its expectation and at the chi-square quantiles)."""
    y = np.array(values)
    p = pool(y, np.full(y.size, se**2))
    assert p.tau_low <= p.between_sd + 1e-9
    assert p.between_sd <= p.tau_high + 1e-9 or p.tau_high == 0.0
    lo, hi = tau_interval(y, np.full(y.size, se**2))
    assert (lo, hi) == (p.tau_low, p.tau_high)


def test_population_rows_of_a_simulated_population():
    tables, truth = hierarchical_tables(np.random.default_rng(21), 8)
    pop = population(tables)
    primary = pop.primary
    n = primary[primary["quantity"] == "exponent"].iloc[0]
    assert n["ci_low"] <= truth.exponent <= n["ci_high"]
    assert n["n_subjects"] == 8 and n["checks"].startswith("ok")
    forces = primary[primary["quantity"] == "electrostatic_force_N"]
    assert list(forces["amplitude_V"]) == [60.0, 80.0, 100.0, 120.0, 140.0]
    assert (forces["ci_low"] < forces["estimate"]).all()
    assert (forces["estimate"] < forces["ci_high"]).all()
    assert (forces["pi_low"] < forces["ci_low"]).all()
    assert (forces["ci_high"] < forces["pi_high"]).all()
    assert not pop.outliers
