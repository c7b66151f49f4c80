"""Intervals of the fitted parameters from the bootstrap replicates of the forces."""

from __future__ import annotations

import logging

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.analysis.friction.estimate import estimate_electrostatic
from evtribo.fit.fit import fit_subject
from evtribo.fit.tables import replicate_matrix
from evtribo.model import TABLE_1, electrostatic_force

AMPS = np.array([60.0, 80, 100, 120, 140])
H_L, MU = 8e-6, 0.45


def _shared_reference_points(seed: int, *, n: int = 6, rel: float = 0.02, n_boot: int = 400):
    """Five amplitudes of six ON windows against one whole-OFF reference (30 windows),
    through the real estimator: every point carries the same error in mu."""
    rng = np.random.default_rng(9000 + seed)
    p = TABLE_1.with_values(h_L=H_L, mu=MU)
    fn_off = rng.uniform(0.45, 0.55, n * AMPS.size)
    ft_off = MU * fn_off * (1 + rng.normal(0, rel, fn_off.size))
    fn_on = rng.uniform(0.45, 0.55, (AMPS.size, n))
    fel = electrostatic_force(fn_on, AMPS[:, None], p)
    ft_on = MU * (fn_on + fel) * (1 + rng.normal(0, rel, fn_on.shape))
    e = estimate_electrostatic([fn_off], [ft_off], fn_on.ravel(), ft_on.ravel(),
                               np.zeros(fn_on.size, int), np.repeat(AMPS, n), n_boot=n_boot,
                               seed=seed)
    rows = pd.DataFrame({"subject": "S", "waveform": "square", "amplitude_V": e.groups,
                         "mu": e.mu, "normal_force_on_N": e.normal_on_N,
                         "electrostatic_force_N": e.force_N,
                         "electrostatic_force_ci_low_N": e.ci_low_N,
                         "electrostatic_force_ci_high_N": e.ci_high_N})
    return rows, e.replicates_N


@pytest.mark.slow
def test_air_gap_interval_coverage_with_a_shared_off_reference(caplog):
    # the Jacobian's interval, which takes the points as independent, covered 85.5 % here
    caplog.set_level(logging.ERROR)
    repeats, covered = 120, 0
    for k in range(repeats):
        rows, reps = _shared_reference_points(k)
        fit = fit_subject("S", rows, TABLE_1, ("h_L",), replicates=reps[:100])
        assert fit.interval_method == "bootstrap" and fit.n_replicates == 100
        covered += fit["h_L"].contains(H_L)
    assert covered / repeats >= 0.9


def test_refits_are_the_least_squares_solutions_of_the_replicates():
    rows, reps = _shared_reference_points(3, n_boot=60)
    fit = fit_subject("S", rows, TABLE_1, ("h_L",), replicates=reps)
    assert fit.chi2_reduced <= 1  # no misfit inflation: the percentiles are the refits'
    # refit a few replicates the slow way: each is an ordinary fit of its forces
    direct = [fit_subject("S", rows.assign(electrostatic_force_N=r), TABLE_1,
                          ("h_L",))["h_L"].value for r in reps]
    lo, hi = np.quantile(direct, [0.025, 0.975])
    est = fit["h_L"]
    assert est.ci_low == pytest.approx(lo, rel=1e-5)
    assert est.ci_high == pytest.approx(hi, rel=1e-5)
    assert est.stderr == pytest.approx(np.std(direct, ddof=1), rel=1e-4)
    assert fit.n_replicates == 60


def test_replicate_matrix_aligns_replicates_with_rows():
    rows = pd.DataFrame({"subject": "S", "waveform": ["square", "square", "sine", np.nan],
                         "amplitude_V": [60.0, 140.0, 140.0, 100.0]})
    rng = np.random.default_rng(0)
    n_rep = 30
    boot = pd.DataFrame({
        "subject": "S",
        "waveform": np.repeat(np.array(["sine", None, "square", "square"], dtype=object), n_rep),
        "amplitude_V": np.repeat([140.0, 100.0, 140.0, 60.0], n_rep),
        "replicate": np.tile(np.arange(n_rep), 4),
        "electrostatic_force_N": np.repeat([3.0, 4.0, 2.0, 1.0], n_rep)})
    boot = boot.iloc[rng.permutation(len(boot))]
    mat = replicate_matrix(rows, boot)
    assert mat is not None and mat.shape == (n_rep, 4)
    np.testing.assert_array_equal(mat, np.tile([1.0, 2.0, 3.0, 4.0], (n_rep, 1)))
    assert replicate_matrix(rows, boot, max_replicates=25).shape == (25, 4)
    # a row without replicates, or too few replicates: no matrix
    assert replicate_matrix(rows, boot[boot.amplitude_V != 60.0]) is None
    assert replicate_matrix(rows, boot[boot.replicate < 5]) is None
    assert replicate_matrix(rows, None) is None


def _refits_one_by_one(model, x0, targets, sigma, lower, *, upper, max_iter=30, tol=1e-6):
    """Gauss-Newton from x0 for each replicate, one after the other, as refit_replicates
    has always refitted them: the oracle its refits are held to."""
    from evtribo.errors import ConfigError
    from evtribo.fit.intervals import RUNAWAY

    def misfit(t, x):
        if not np.all(np.isfinite(x)):
            return np.inf, x, x
        try:
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                m = model(x)
                g = np.empty((m.size, x.size))
                for i in range(x.size):
                    h = 1e-7 * max(abs(x[i]), 1.0)
                    xi = x.copy()
                    xi[i] += h
                    g[:, i] = (model(xi) - m) / h / sigma
        except (ConfigError, FloatingPointError, ValueError, np.linalg.LinAlgError):
            return np.inf, x, x
        if not (np.all(np.isfinite(m)) and np.all(np.isfinite(g))):
            return np.inf, m, g
        return float(np.sum(((t - m) / sigma) ** 2)), m, g

    _, m0, g0 = misfit(np.zeros_like(sigma), x0)
    out = []
    for t in targets:
        if not np.all(np.isfinite(t)):
            continue
        x, m, g = x0, m0, g0
        cost = float(np.sum(((t - m) / sigma) ** 2))
        for _ in range(max_iter):
            step = np.linalg.lstsq(g, (t - m) / sigma, rcond=None)[0]
            if not np.all(np.isfinite(step)):
                break
            if np.all(np.abs(step) <= tol * np.maximum(np.abs(x), 1.0)):
                out.append(np.clip(x + step, lower, upper))
                break
            if np.any(np.abs(x + step) > RUNAWAY * np.maximum(np.abs(x0), 1.0)):
                out.append(np.where(np.abs(x + step) > RUNAWAY, np.inf * np.sign(step), x))
                break
            for _ in range(10):
                x_new = np.clip(x + step, lower, upper)
                cost_new, m_new, g_new = misfit(t, x_new)
                if cost_new <= cost:
                    break
                step = step / 2.0
            else:
                out.append(x)
                break
            x, m, g, cost = x_new, m_new, g_new, cost_new
    return np.asarray(out, dtype=float).reshape(-1, x0.size)


_NAMES = (("h_L",), ("h_L", "E_star"), ("R", "eps_L"), ("h_L", "h_sc", "E_star"))
#: Replicates per example: more than the five whose force is gone, so that some refits
#: converge beside them and others stop or fail along the way.
REPLICATES = 15


@settings(max_examples=40)
@given(names=st.sampled_from(_NAMES), n_sine=st.integers(0, 3),
       spread=st.sampled_from([1e-4, 0.02, 0.3, 3.0]), seed=st.integers(0, 2**16),
       gone=st.booleans())
def test_refits_side_by_side_are_the_refits_one_by_one(names, n_sine, spread, seed, gone):
    """The replicates refitted side by side (the model evaluated for all at once) give each
    refit's numbers as refitting them one after the other does, bit for bit: converged,
    run off to infinity (a replicate whose force is gone), failed, or skipped (NaN)."""
    from evtribo.fit.intervals import refit_replicates
    from evtribo.fit.problem import Points, Problem

    rng = np.random.default_rng(seed)
    n = AMPS.size + n_sine
    p = TABLE_1.with_values(h_L=H_L, mu=MU)
    rows = pd.DataFrame({"subject": "S", "amplitude_V": np.r_[AMPS, AMPS[-n_sine:]][:n]
                         if n_sine else AMPS,
                         "waveform": ["square"] * AMPS.size + ["sine"] * n_sine,
                         "normal_force_on_N": rng.uniform(0.3, 0.7, n), "mu": MU})
    rows["electrostatic_force_N"] = 0.0
    pts = Points.of("S", rows.assign(electrostatic_force_N=1.0,
                                     electrostatic_force_ci_low_N=0.9,
                                     electrostatic_force_ci_high_N=1.1))
    problem = Problem("S", names, p, pts)
    x0 = problem.x0
    clean = problem.model_at(x0)
    reps = clean * (1 + spread * rng.standard_normal((REPLICATES, n)))
    reps[rng.random(REPLICATES) < 0.1] = np.nan  # a replicate with a point missing: skipped
    if gone:
        reps[:5] = 1e-12 * rng.random((5, n))  # no force left: the air gap runs off
    sigma = pts.sigma
    kwargs = {"upper": problem.upper}
    tried = []

    def many(xs):
        tried.append(len(xs))
        return problem.model_many(xs)

    side = refit_replicates(problem.model_at, x0, reps, sigma, problem.lower, many=many,
                            **kwargs)
    each = refit_replicates(problem.model_at, x0, reps, sigma, problem.lower, **kwargs)
    assert tried[0] == 1  # asked at the solution first
    if names == ("h_L",):  # and used: every refit of h_L takes a step at least
        assert len(tried) > 1
    np.testing.assert_array_equal(side, each)
    np.testing.assert_array_equal(each, _refits_one_by_one(
        problem.model_at, x0, reps, sigma, problem.lower, upper=problem.upper))


def test_a_model_that_takes_one_value_at_a_time_is_refitted_one_by_one():
    """A force function that cannot take the parameters side by side (a scalar's math):
    the refits are made one by one, the same as without the side-by-side model."""
    import math

    from evtribo.fit.intervals import refit_replicates
    from evtribo.fit.problem import Points, Problem

    def scalar_force(fn, u, params):
        return electrostatic_force(fn, u, params) * math.sqrt(params.h_L / H_L)

    rows, reps = _shared_reference_points(5, n_boot=20)
    pts = Points.of("S", rows)
    problem = Problem("S", ("h_L",), TABLE_1, pts, force=scalar_force)
    with pytest.raises(TypeError):
        problem.model_many(np.array([[1.0], [1.1]]))
    tried = []

    def many(xs):
        tried.append(len(xs))
        return problem.model_many(xs)

    got = refit_replicates(problem.model_at, problem.x0, reps, pts.sigma, problem.lower,
                           many=many)
    assert tried == [1]  # asked once, at the solution, and not used
    np.testing.assert_array_equal(got, _refits_one_by_one(
        problem.model_at, problem.x0, reps, pts.sigma, problem.lower, upper=problem.upper))
    assert len(got) == len(reps)


def test_a_leaky_gap_with_the_drive_s_frequency_is_refitted_one_by_one():
    """With a finite resistance and the points' drive frequencies, the amplitude the gap sees
    depends on the fitted parameters: the refits are made one by one (side by side they
    took the start's amplitude for every replicate), and the side-by-side model refuses."""
    from evtribo.fit.fit import fit_subject
    from evtribo.fit.intervals import refit_replicates
    from evtribo.fit.model_points import (
        mean_electrostatic_force,
        mean_electrostatic_force_many,
    )
    from evtribo.fit.problem import Points, Problem

    rng = np.random.default_rng(3)
    fn, freq = rng.uniform(0.4, 0.6, 5), np.array([2.0, 5.0, 10.0, 20.0, 50.0])
    base = TABLE_1.with_values(r_g=2e3, mu=MU)
    force = mean_electrostatic_force(fn, AMPS, "square", base, frequency=freq)
    rows = pd.DataFrame({"subject": "S", "waveform": "square", "amplitude_V": AMPS,
                         "frequency_Hz": freq, "normal_force_on_N": fn, "mu": MU,
                         "electrostatic_force_N": force,  # the start fits them exactly
                         "electrostatic_force_ci_low_N": force * 0.9,
                         "electrostatic_force_ci_high_N": force * 1.1})
    reps = force * (1 + 0.1 * rng.standard_normal((100, 5)))
    problem = Problem("S", ("h_L",), base, Points.of("S", rows))
    assert not problem.side_by_side
    with pytest.raises(ValueError, match="one row at a time"):
        mean_electrostatic_force_many(fn, AMPS, "square", base, {"h_L": [5e-6, 6e-6]},
                                      frequency=freq)
    got = fit_subject("S", rows, base, ("h_L",), replicates=reps)["h_L"]
    refits = refit_replicates(problem.model_at, problem.x0, reps, problem.pts.sigma,
                              problem.lower, upper=problem.upper)  # one by one, by hand
    lo, hi = np.quantile(problem.to_values(refits)[:, 0], [0.025, 0.975])
    assert (got.ci_low, got.ci_high) == pytest.approx((lo, hi), rel=1e-9)


def test_only_eq_11_without_a_leak_is_refitted_side_by_side():
    """Side by side only where the model takes arrays of parameter values and the gap's
    amplitude does not vary with them: not with a caller's force function (which may
    test a value with ``if``), a finite resistance, or a fitted one."""
    from evtribo.fit.model_points import mean_electrostatic_force_many
    from evtribo.fit.problem import Points, Problem

    rows, _ = _shared_reference_points(1, n_boot=5)
    pts = Points.of("S", rows)
    assert Problem("S", ("h_L",), TABLE_1, pts).side_by_side
    assert Problem("S", ("h_L", "E_star"), TABLE_1, pts).side_by_side
    assert not Problem("S", ("h_L",), TABLE_1, pts, force=electrostatic_force).side_by_side
    assert not Problem("S", ("h_L",), TABLE_1.with_values(r_sc=1e3), pts).side_by_side
    with pytest.raises(ValueError, match="one-dimensional"):
        mean_electrostatic_force_many(np.ones((2, 2)), np.full((2, 2), 100.0), "square",
                                      TABLE_1, {"h_L": [5e-6]})
