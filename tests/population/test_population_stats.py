"""The population's statistics: pooling, outliers, and the power law across subjects."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import optimize

sys.path.insert(0, str(Path(__file__).parent))

from evtribo.population.data import subject_data
from evtribo.population.estimates import population
from evtribo.population.model import (
    SubjectCells,
    _batches,
    _deviance,
    _theta_of,
    _whiten,
    fit_power_law,
)
from evtribo.population.stats import find_outliers, pool
from population_sim import hierarchical_tables

LOG_U = np.log([60.0, 80.0, 100.0, 120.0, 140.0])


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


@settings(max_examples=30, deadline=None)
@given(st.floats(-5, 0), st.floats(1, 4), st.floats(0.005, 0.2), st.floats(0.0, 0.95))
def test_own_fit_recovers_an_exact_line(a, n, se, rho):
    """A subject's own weighted power law of forces exactly on a line is that line,
    whatever the cells' covariance (here: correlated by *rho*, each its own size)."""
    sizes = se * np.linspace(1.0, 3.0, 5)
    cov = np.outer(sizes, sizes) * (np.eye(5) * (1 - rho) + rho)
    cells = SubjectCells("S", LOG_U, a + n * (LOG_U - 4.6), cov)
    (a_hat, n_hat), _ = cells.own_fit(4.6)
    assert a_hat == pytest.approx(a, abs=1e-9)
    assert n_hat == pytest.approx(n, abs=1e-9)


def _cells(seed: int, k: int, **kw: float) -> list[SubjectCells]:
    tables, _ = hierarchical_tables(np.random.default_rng(seed), k, **kw)
    notes: list[str] = []
    out = []
    for name in tables.subjects:
        data = subject_data(tables, name, notes)
        assert data is not None
        out.append(data.condition(("square", 10_000.0)))
    return out


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_mixedlm_reaches_the_reml_optimum(seed):
    """MixedLM's estimate (statsmodels, Powell's method) is the REML optimum: no start of
    an independent minimiser of the same deviance finds a lower one."""
    cells = _cells(seed, [5, 8, 12, 6][seed])
    fit = fit_power_law(cells)
    batches = _batches(_whiten(cells, fit.log_u0, True))
    at_fit = _deviance(_theta_of(fit.scale, fit.cov_re), batches)
    best = min(optimize.minimize(_deviance, start, args=(batches,), method="Nelder-Mead",
                                 options={"maxiter": 4000, "xatol": 1e-7,
                                          "fatol": 1e-9}).fun
               for start in ([1, 0.3, 0, 0.1], [1, 0.05, 0, 0.01], [1, 1, 0, 1]))
    assert at_fit <= best + 0.02


def test_random_slopes_only_where_the_data_support_them():
    cells = _cells(5, 6)
    assert fit_power_law(cells).random_slopes
    two = [SubjectCells(c.subject, c.log_u[[0, 4]], c.log_f[[0, 4]],
                        c.cov[np.ix_([0, 4], [0, 4])]) for c in cells]
    fit = fit_power_law(two)  # two amplitudes each: the exponent's spread is not separable
    assert not fit.random_slopes
    assert math.isnan(fit.between_sd[1])  # not estimated
    assert "random intercept by subject" in fit.method


def test_satterthwaite_degrees_of_freedom_follow_what_dominates():
    """About k - 1 for the level, which the subjects' spread dominates; more for an
    exponent that all subjects share and the cells measure well."""
    fit = fit_power_law(_cells(7, 8, sd_exponent=0.0, sd_log_f=0.6))
    level = fit.at(fit.log_u0)
    assert 5.0 <= level.df <= 9.0
    assert fit.estimate([0.0, 1.0]).df > level.df


def test_fewer_than_three_subjects_no_power_law():
    with pytest.raises(ValueError, match="at least 3"):
        fit_power_law(_cells(0, 2))


def test_population_rows_of_a_simulated_population():
    tables, truth = hierarchical_tables(np.random.default_rng(21), 8)
    pop = population(tables)
    n = pop.table[pop.table["quantity"] == "exponent"].iloc[0]
    assert n["ci_low"] <= truth.exponent <= n["ci_high"]
    assert n["n_subjects"] == 8
    forces = pop.table[pop.table["quantity"] == "electrostatic_force_N"]
    assert list(forces["amplitude_V"]) == [60.0, 80.0, 100.0, 120.0, 140.0]
    assert (forces["ci_low"] < forces["estimate"]).all()
    assert (forces["estimate"] < forces["ci_high"]).all()
    assert not pop.outliers
