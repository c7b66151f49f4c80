"""The friction an ON window is compared with: the OFF windows' coefficient at the window's own
time, direction and stroke rate (:mod:`evtribo.analysis.friction.reference`)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.analysis.friction.estimate import estimate_electrostatic
from evtribo.analysis.friction.laws import LAWS, fit_subject_law
from evtribo.analysis.friction.reference import fit_mu_model, fit_trial_model
from evtribo.analysis.friction.window_facts import WindowFacts


def _facts(t, direction, rate=None, cluster=None):
    n = len(t)
    return WindowFacts(np.asarray(t, float), np.asarray(direction, float),
                       np.full(n, np.nan) if rate is None else np.asarray(rate, float),
                       np.arange(n) if cluster is None else np.asarray(cluster),
                       np.zeros(n, dtype=np.int64))


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(st.floats(0.2, 2.0), st.floats(0.05, 1.5)), min_size=1,
                max_size=30))
def test_with_nothing_known_the_model_is_the_ratio_of_means(pairs):
    fn = np.array([p[0] for p in pairs])
    ft = np.array([p[0] * p[1] for p in pairs])
    model = fit_mu_model(fn, ft, WindowFacts.plain(fn.size), time_trend=True)
    assert model.degree == 0 and not model.direction and not model.rate
    np.testing.assert_allclose(model.at(WindowFacts.plain(3)), ft.sum() / fn.sum(),
                               rtol=1e-10)


def _alternating_trial(seed, *, rise=0.3, tau=6.0, asym=0.05, fel_share=0.2, noise=0.005):
    """Windows of a 20-s alternating trial (OFF then ON every 2 s) with a friction that
    rises as the skin moistens and differs between directions."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.4, 20.0, 0.5)
    on = (t // 2) % 2 == 1
    d = np.where(np.arange(t.size) % 4 < 2, 1.0, -1.0)
    mu = 0.5 * (1 + rise * (1 - np.exp(-t / tau))) * (1 + asym * d)
    fn = rng.uniform(0.45, 0.55, t.size)
    ft = mu * fn * (1 + fel_share * on) * (1 + rng.normal(0, noise, t.size))
    facts = _facts(t, d, cluster=np.arange(t.size) // 2)
    return t, on, d, mu, fn, ft, facts


def test_a_trial_model_follows_a_moistening_finger_at_every_on_window():
    _t, on, _, mu, fn, ft, facts = _alternating_trial(0)
    model = fit_trial_model((fn[~on], ft[~on], facts.take(~on)),
                            (fn[on], ft[on], facts.take(on), np.zeros(on.sum())))
    assert model.trend and model.direction and model.log
    got = model.at(facts.take(on))
    np.testing.assert_allclose(got, mu[on], rtol=0.01)
    # one mu for the trial (the OFF windows' ratio of means) is off by up to 15 % here
    flat = ft[~on].sum() / fn[~on].sum()
    assert np.max(np.abs(flat / mu[on] - 1)) > 0.1


def test_the_electrostatic_force_of_a_moistening_finger_is_unbiased():
    forces = []
    for seed in range(8):
        _t, on, _, _, fn, ft, facts = _alternating_trial(seed)
        est = estimate_electrostatic([fn[~on]], [ft[~on]], fn[on], ft[on],
                                     np.zeros(on.sum(), int), np.full(on.sum(), 100.0),
                                     n_boot=200, seed=seed, off_facts=[facts.take(~on)],
                                     on_facts=facts.take(on), time_trend=[True],
                                     friction_law="amontons")
        truth = np.mean(0.2 * fn[on])  # F_t/mu - F_n, the voltage's share of the load
        forces.append(est.force_N[0] / truth - 1)
        assert est.ci_low_N[0] < est.force_N[0] < est.ci_high_N[0]
    assert abs(np.mean(forces)) < 0.02, forces


def _coverage(*, trend: bool, repeats: int = 150) -> float:
    """Share of repeats whose 95 % interval of the force holds the truth."""
    covered = 0
    for seed in range(repeats):
        _t, on, _, _, fn, ft, facts = _alternating_trial(
            1000 + seed, rise=0.3 if trend else 0.0, noise=0.03)
        est = estimate_electrostatic([fn[~on]], [ft[~on]], fn[on], ft[on],
                                     np.zeros(on.sum(), int), np.full(on.sum(), 1.0),
                                     n_boot=300, seed=seed, off_facts=[facts.take(~on)],
                                     on_facts=facts.take(on), time_trend=[True])
        truth = np.mean(0.2 * fn[on])
        covered += est.ci_low_N[0] <= truth <= est.ci_high_N[0]
    return covered / repeats


@pytest.mark.slow
def test_intervals_cover_with_and_without_a_trend():
    for trend in (False, True):
        assert 0.9 <= _coverage(trend=trend) <= 0.995


def test_a_stroke_rate_that_sets_the_friction_is_taken_into_account():
    rng = np.random.default_rng(4)
    n = 60
    rate = rng.uniform(-0.6, 0.6, n)  # log stroke rate: strokes 3x apart in speed
    mu = 0.5 * np.exp(0.15 * rate)
    fn = rng.uniform(0.4, 0.6, n)
    ft = mu * fn * (1 + rng.normal(0, 0.004, n))
    facts = _facts(np.arange(n, dtype=float), np.where(np.arange(n) % 2, 1.0, -1.0), rate)
    facts = WindowFacts(facts.t_s, facts.direction, facts.rate, facts.cluster,
                        np.arange(n) // 20)  # three trials
    law = fit_subject_law([(fn, ft, facts, np.full(n, np.nan))])
    slope, se = law.rate_slope, law.rate_se
    assert slope == pytest.approx(0.15, abs=3 * se) and se < 0.02
    model = fit_mu_model(fn, ft, facts, time_trend=False, rate_slope=slope)
    assert model.rate
    np.testing.assert_allclose(model.at(facts), mu, rtol=0.01)
    # without the rate, one coefficient for all: off by up to 9 %
    flat = fit_mu_model(fn, ft, facts, time_trend=False)
    assert np.max(np.abs(flat.at(facts) / mu - 1)) > 0.07


@settings(max_examples=25, deadline=None)
@given(m=st.sampled_from([0.67, 0.75, 0.9, 1.0, 1.0, 1.0]), seed=st.integers(0, 10_000),
       noise=st.floats(0.01, 0.06))
def test_auto_uses_the_fitted_exponent_only_where_its_interval_excludes_one(m, seed, noise):
    # OFF windows of a press wandering by +/- 20 %, friction c W^m with the scatter of a
    # person's strokes: "auto" keeps m = 1 wherever the interval holds it, so that a pad
    # of m = 1 gives Amontons' forces; elsewhere it uses the m it found
    rng = np.random.default_rng(seed)
    n = 60
    fn = 0.5 * np.exp(rng.normal(0, 0.2, n))
    ft = 0.3 * fn ** m * np.exp(rng.normal(0, noise, n))
    facts = WindowFacts(np.arange(n, dtype=float), np.where(np.arange(n) % 2, 1.0, -1.0),
                        np.full(n, np.nan), np.arange(n), np.arange(n) // 20)
    fitted = fit_subject_law([(fn, ft, facts, np.full(n, np.nan))])
    law = LAWS["auto"].choose(fitted)
    low, high = fitted.interval
    assert fitted.told  # the wandering press tells m
    assert fitted.holds_amontons == (low <= 1.0 <= high)
    if fitted.holds_amontons:
        assert law.label == "amontons" and law.exponent == 1.0 and law.draw_exponent
    else:
        assert law.label == "power" and law.exponent == fitted.estimate
        assert law.draw_exponent and law.exponent_source
    assert law.sensitivity is None  # the presses tell m: no sensitivity at 0.75
    if m <= 0.75:  # far from 1: told apart at this scatter
        assert law.label == "power" and abs(fitted.estimate - m) < 0.15  # 4 SE at most
