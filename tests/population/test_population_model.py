"""The power law across subjects on the linear scale (a nonlinear mixed model): its
likelihood against numerical integration, what it recovers, and checks that say when the
optimisers end apart."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import optimize

sys.path.insert(0, str(Path(__file__).parents[1]))

from evtribo.population import nonlinear_fit
from evtribo.population.convergence import OPTIMISERS, OptimiserRun, checks
from evtribo.population.nonlinear import (
    _Objective,
    _Spec,
    _state,
    _unpack,
    nonlinear_data,
    subject_fits,
)
from evtribo.population.nonlinear_fit import fit_nonlinear

LOG_U = np.log([60.0, 80.0, 100.0, 120.0, 140.0])


def _study(seed: int, k: int, *, error: float = 0.005, sd_a: float = 0.5, sd_n: float = 0.15,
           amps: np.ndarray = LOG_U) -> tuple[list[tuple[np.ndarray, ...]], np.ndarray]:
    """*k* subjects' cells (independent errors of *error* N) and their true (a, n) at 100 V."""
    rng = np.random.default_rng(seed)
    truth = np.column_stack([math.log(0.04) + sd_a * rng.standard_normal(k),
                             2.0 + sd_n * rng.standard_normal(k)])
    cells = []
    for a, n in truth:
        f = np.exp(a + n * (amps - math.log(100.0)))
        cells.append((amps, f + error * rng.standard_normal(amps.size),
                      np.eye(amps.size) * error**2))
    return cells, truth


def test_the_likelihood_is_the_integral_over_the_random_effects():
    """One subject's -2 log-likelihood by adaptive Gauss-Hermite quadrature (9 nodes a
    random effect) equals a fine numerical integral over its two random effects; the
    Laplace approximation is within 0.05 of it."""
    cells, _ = _study(3, 1, error=0.01)
    data = nonlinear_data(["S"], cells, log_u0=math.log(100.0))
    p = np.array([math.log(0.04), 2.0, 0.5, 0.05, 0.2])
    beta, load, _ = _unpack(p, _Spec(2, False))
    grid = np.linspace(-7.0, 7.0, 281)
    v = np.stack(np.meshgrid(grid, grid, indexing="ij"), -1).reshape(-1, 2)
    rep = nonlinear_data(["S"] * len(v), cells * len(v), log_u0=data.log_u0)
    obj = _state(rep, beta, load, 1.0, v)[0]
    top = obj.min()
    step = grid[1] - grid[0]
    integral = np.log(np.sum(np.exp(-0.5 * (obj - top))) * step * step / (2 * math.pi))
    exact = 5 * math.log(2 * math.pi) + float(data.logdet_c[0]) + top - 2 * integral
    quadrature = _Objective(data, _Spec(2, False, reml=False, nodes=9)).pieces(p)[0]
    laplace = _Objective(data, _Spec(2, False, reml=False, nodes=1)).pieces(p)[0]
    assert quadrature == pytest.approx(exact, abs=1e-4)
    assert laplace == pytest.approx(exact, abs=0.05)


@settings(max_examples=25, deadline=None)
@given(st.floats(-5, -1), st.floats(1, 4), st.floats(0.0, 0.9))
def test_a_subject_s_own_fit_recovers_an_exact_power_law(a, n, rho):
    """Forces exactly on a power law, any correlation of their errors: the subject's own
    fit on the linear scale is that law, determined."""
    cov = 1e-6 * (np.eye(5) * (1 - rho) + rho)
    f = np.exp(a + n * (LOG_U - math.log(100.0)))
    data = nonlinear_data(["S"], [(LOG_U, f, cov)], log_u0=math.log(100.0))
    own, _, ok = subject_fits(data, np.array([[a + 0.3, n - 0.4]]))
    assert ok[0]
    assert own[0] == pytest.approx([a, n], abs=1e-6)


def test_exact_subjects_give_their_mean():
    """Every subject's cells on its own power law with tiny errors (0.1 mN on forces of
    tens of mN): the population's level and exponent are the subjects' means, and every
    check passes."""
    cells, truth = _study(5, 7, error=1e-4)
    fit = fit_nonlinear(nonlinear_data([f"S{i}" for i in range(7)], cells,
                                       log_u0=math.log(100.0)))
    assert fit.beta == pytest.approx(truth.mean(axis=0), abs=5e-3)
    assert fit.convergence.ok, fit.convergence.summary()
    assert fit.between_sd == pytest.approx(truth.std(axis=0, ddof=1), rel=0.05)


def test_cells_below_zero_count():
    """A weak subject whose forces are all below their noise (some negative) is in the fit
    and pulls the population down: without it, the level is higher."""
    cells, _ = _study(8, 6)
    weak = (LOG_U, np.array([-0.004, 0.002, -0.001, 0.006, 0.003]), np.eye(5) * 0.005**2)
    names = [f"S{i}" for i in range(7)]
    data = nonlinear_data(names, [*cells, weak], log_u0=math.log(100.0))
    fit = fit_nonlinear(data)
    assert fit.subjects == tuple(names)
    assert fit.modes[-1, 0] < fit.beta[0]
    assert fit_nonlinear(data.without("S6")).beta[0] > fit.beta[0]


def test_satterthwaite_degrees_of_freedom_follow_what_dominates():
    """About k - 1 for the level, which the subjects' spread dominates; more for an
    exponent that all subjects share and the cells measure well."""
    cells, _ = _study(7, 8, error=0.001, sd_a=0.6, sd_n=0.0)
    fit = fit_nonlinear(nonlinear_data([f"S{i}" for i in range(8)], cells))
    level = fit.at(fit.log_u0)
    assert 5.0 <= level.df <= 9.5
    assert fit.estimate([0.0, 1.0]).df > level.df


def test_random_levels_only_say_so():
    cells, _ = _study(9, 6)
    fit = fit_nonlinear(nonlinear_data([f"S{i}" for i in range(6)], cells),
                        random_slopes=False)
    assert not fit.random_slopes and math.isnan(fit.between_sd[1])
    assert "random intercept by subject" in fit.method


def test_an_optimiser_that_ends_elsewhere_is_said(monkeypatch):
    """Powell made to stop one standard error of the exponent away: the fit keeps the best
    optimum and its checks name Powell, its exponent and deviance."""
    real = optimize.minimize

    def stopped_short(fun, x0, method=None, **kw):
        res = real(fun, x0, method=method, **kw)
        if method == "Powell":
            res.x = np.array(res.x, dtype=float)
            res.x[1] += 0.3
        return res

    monkeypatch.setattr(nonlinear_fit.optimize, "minimize", stopped_short)
    cells, _ = _study(11, 6)
    fit = fit_nonlinear(nonlinear_data([f"S{i}" for i in range(6)], cells))
    assert not fit.convergence.agree and not fit.convergence.ok
    assert fit.convergence.runs[0].method == "L-BFGS-B"
    text = fit.convergence.summary()
    assert text.startswith("the optimisers disagree: Powell ended at n = ")
    assert fit.beta[1] == pytest.approx(min(fit.convergence.runs,
                                            key=lambda r: r.deviance).beta[1])


def test_a_deviance_that_is_not_finite_fails_the_checks():
    runs = [OptimiserRun(m, math.inf, (0.0, 2.0), True) for m in OPTIMISERS]
    check = checks(math.inf, np.eye(5), runs, runs[0], cov_beta=np.eye(2), singular="")
    assert not check.finite and not check.ok
    assert check.summary().startswith("the log-likelihood or the estimates' covariance is "
                                      "not finite")
    saddle = checks(0.0, np.diag([1.0, 1.0, -1.0, 1.0, 1.0]), runs, runs[0],
                    cov_beta=np.eye(2), singular="")
    assert not saddle.hessian_pd and "not positive-definite" in saddle.summary()
