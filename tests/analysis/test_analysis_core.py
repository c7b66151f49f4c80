"""The analysis core on synthetic traces built from F_t = mu * (F_n + F_el)."""

import numpy as np
import pytest

from _analysis_synth import synth_trial
from evtribo.analysis import (
    align_forces,
    condition_from_excitation,
    constant_condition,
    dominant_frequency,
    estimate_electrostatic,
    find_windows,
    fit_power_law,
    friction_coefficient,
)
from evtribo.analysis.forces.conditions import EXCLUDED, OFF, ON
from evtribo.analysis.friction.estimate import small_sample_scale
from evtribo.errors import AnalysisError
from evtribo.util.running import moving_average


def _analyse(s):
    al = align_forces(s.t_normal, s.normal, s.t_tangential, s.tangential)
    cond = condition_from_excitation(al.t, s.t_excitation, s.enabled)
    return al, cond, find_windows(al.t, al.normal, al.tangential, cond)


# --- alignment -------------------------------------------------------------------------------

def test_align_interpolates_between_own_clocks_and_leaves_gaps_empty():
    rng = np.random.default_rng(1)
    tn = np.sort(0.0003 + np.arange(1000) / 500 + rng.normal(0, 2e-5, 1000))
    tt = 0.0011 + np.arange(2000) / 1000.0
    gap = (tn > 0.8) & (tn < 0.9)
    f = lambda t: 1 + 0.5 * np.sin(2 * np.pi * 0.7 * t)  # noqa: E731
    al = align_forces(tn[~gap], f(tn[~gap]), tt, -f(tt))
    assert al.rate_Hz == pytest.approx(1000, rel=1e-3)
    assert al.t[0] >= max(tn[0], tt[0]) and al.t[-1] <= min(tn[-1], tt[-1])
    inside = (al.t > 0.81) & (al.t < 0.89)
    assert np.all(np.isnan(al.normal[inside]))
    ok = np.isfinite(al.normal)
    assert ok.sum() > 0.9 * al.t.size
    np.testing.assert_allclose(al.normal[ok], f(al.t[ok]), atol=1e-4)
    np.testing.assert_allclose(al.tangential, -f(al.t), atol=1e-4)


def test_align_sorts_and_merges_duplicate_timestamps():
    t = np.array([0.0, 0.002, 0.001, 0.001, 0.003, 0.004])
    v = np.array([0.0, 2.0, 1.0, 3.0, 3.0, 4.0])
    al = align_forces(t, v, t, v, rate_Hz=1000)
    np.testing.assert_allclose(al.normal, [0, 2, 2, 3, 4])


def test_align_refuses_channels_that_do_not_overlap():
    with pytest.raises(AnalysisError, match="do not overlap"):
        align_forces([0, 1, 2], [1, 1, 1], [3, 4, 5], [1, 1, 1])
    with pytest.raises(AnalysisError, match="usable sample"):
        align_forces([0], [1], [0, 1], [1, 1])


# --- conditions ------------------------------------------------------------------------------

def test_condition_switch_is_excluded_with_guard():
    grid = np.arange(0, 4, 0.01)
    te = np.arange(0, 3, 0.1)
    on = te >= 1.5  # switches between 1.4 and 1.5
    c = condition_from_excitation(grid, te, on, guard_s=0.2)
    assert np.all(c[(grid > 1.25) & (grid < 1.65)] == EXCLUDED)
    assert np.all(c[grid < 1.15] == OFF)
    assert np.all(c[(grid > 1.75) & (grid < 3.1)] == ON)
    assert np.all(c[grid > 3.3] == EXCLUDED)  # status lost: unknown
    assert np.all(constant_condition(3, "on") == ON)
    with pytest.raises(ValueError, match="alternating"):
        constant_condition(3, "alternating")


# --- windows ---------------------------------------------------------------------------------

def test_moving_average_does_not_reach_into_gaps():
    x = np.ones(20)
    x[10] = np.nan
    m = moving_average(x, 5)
    assert np.all(np.isnan(m[8:13])) and np.all(np.isnan(m[:2]))
    np.testing.assert_allclose(m[2:8], 1.0)
    x = np.arange(20.0)
    x[10] = np.nan
    x[14:16] = np.nan
    m = moving_average(x, 5, min_fraction=0.75)
    assert m[10] == pytest.approx((8 + 9 + 11 + 12) / 4)
    assert np.isnan(m[14]) and np.isnan(m[15])  # 2 of 5 missing


def test_windows_avoid_reversals_startup_gaps_and_switches():
    s = synth_trial(gaps=[("tangential", 1005.0, 1005.4)], switch_s=1.7)
    al, cond, w = _analyse(s)
    assert len(w) >= 8 and set(w.condition) == {"on", "off"}
    rel = w.t_start.to_numpy() - 1000.0, w.t_end.to_numpy() - 1000.0
    # sliding starts at 0.7 s; reversals every 0.9 s after, friction ramps for 0.08 s
    assert rel[0].min() >= 0.7 + 0.08
    phase_start = np.mod(rel[0] - 0.7, 0.9)
    phase_end = np.mod(rel[1] - 0.7, 0.9)
    assert np.all(phase_start >= 0.08) and np.all(phase_end <= 0.9 - 1e-3)
    assert np.all(phase_end >= phase_start)  # no window spans a reversal
    assert not np.any((w.t_end > 1005.0) & (w.t_start < 1005.4))
    for _, row in w.iterrows():
        assert np.all(cond[row.i_start:row.i_stop] == (ON if row.condition == "on" else OFF))
    # each window's direction matches the friction's sign
    for _, row in w.iterrows():
        assert np.sign(np.mean(al.tangential[row.i_start:row.i_stop])) == row.direction


def test_windows_respect_length_limits():
    s = synth_trial(condition="off", stroke_s=3.0)
    al = align_forces(s.t_normal, s.normal, s.t_tangential, s.tangential)
    w = find_windows(al.t, al.normal, al.tangential, constant_condition(al.t.size, "off"),
                     min_window_s=0.3, max_window_s=0.5)
    durations = w.t_end - w.t_start
    assert len(w) >= 15
    assert durations.min() >= 0.3 - 1e-9 and durations.max() <= 0.5 + 1e-3


def test_no_sliding_gives_no_windows():
    t = np.arange(0, 2, 0.001)
    w = find_windows(t, np.full(t.size, 0.5), np.zeros(t.size), np.zeros(t.size, np.int8))
    assert w.empty


# --- estimates -------------------------------------------------------------------------------

@pytest.mark.parametrize("waveform", ["square", "sine"])
@pytest.mark.parametrize(("mu", "normal_N", "fel_N"), [(0.5, 0.5, 0.1), (0.3, 1.5, 0.02)])
def test_recovers_mu_and_electrostatic_force(waveform, mu, normal_N, fel_N):
    s = synth_trial(waveform=waveform, mu=mu, normal_N=normal_N, fel_N=fel_N,
                    gaps=[("normal", 1003.0, 1003.2)], seed=3)
    _, _, w = _analyse(s)
    off, on = w[w.condition == "off"], w[w.condition == "on"]
    assert friction_coefficient(off.normal_force_N, off.friction_force_N) == pytest.approx(
        mu, rel=0.02)
    est = estimate_electrostatic([off.normal_force_N], [off.friction_force_N],
                                 on.normal_force_N, on.friction_force_N,
                                 np.zeros(len(on), int), np.full(len(on), 140.0), n_boot=500)
    assert abs(est.force_N[0] - fel_N) <= max(0.05 * fel_N, 0.003)
    assert est.ci_low_N[0] < est.force_N[0] < est.ci_high_N[0]
    assert est.n_on[0] == len(on) and est.n_off[0] == len(off)


def test_bootstrap_interval_is_seeded_and_carries_mu_uncertainty():
    rng = np.random.default_rng(0)
    fn_off = rng.uniform(0.4, 0.6, 30)
    ft_off = 0.5 * fn_off * (1 + rng.normal(0, 0.05, 30))
    fn_on = rng.uniform(0.4, 0.6, 30)
    ft_on = 0.5 * (fn_on + 0.1)
    args = ([fn_off], [ft_off], fn_on, ft_on, np.zeros(30, int), np.full(30, 100.0))
    a = estimate_electrostatic(*args, seed=7)
    b = estimate_electrostatic(*args, seed=7)
    np.testing.assert_array_equal(a.replicates_N, b.replicates_N)
    # ON windows are noise-free: all the interval's width comes from mu's uncertainty
    assert a.ci_high_N[0] - a.ci_low_N[0] > 0.01


def _coverage(n_on, n_off, repeats, *, mu=0.4, fel=0.05, sd=0.005, n_boot=300):
    """Share of repeated experiments whose 95 % interval holds the true force."""
    covered = 0
    for k in range(repeats):
        rng = np.random.default_rng(1000 + k)
        fn_off, fn_on = rng.uniform(0.45, 0.55, n_off), rng.uniform(0.45, 0.55, n_on)
        ft_off = mu * fn_off + rng.normal(0, sd, n_off)
        ft_on = mu * (fn_on + fel) + rng.normal(0, sd, n_on)
        e = estimate_electrostatic([fn_off], [ft_off], fn_on, ft_on, np.zeros(n_on, int),
                                   np.full(n_on, 1.0), n_boot=n_boot, seed=k)
        covered += e.ci_low_N[0] <= fel <= e.ci_high_N[0]
    return covered / repeats


def test_interval_coverage_with_six_windows_per_group():
    # the counts a trial gives: the plain percentile bootstrap covered 88 % here
    assert _coverage(6, 6, 400) >= 0.92
    # a shared OFF reference with many windows, few ON windows
    assert _coverage(6, 30, 200) >= 0.91


def test_interval_not_needlessly_wide_with_many_windows():
    cov = _coverage(25, 25, 300)
    assert 0.92 <= cov <= 0.99


def test_small_sample_scale_is_student_t_for_one_mean():
    from scipy import stats

    c, dof = small_sample_scale([1.0], [6])
    assert dof == pytest.approx(5.0)
    assert c == pytest.approx(np.sqrt(6 / 5) * stats.t.ppf(0.975, 5) / stats.norm.ppf(0.975))
    # two equal sources of 6 windows each: Welch's 10 degrees of freedom
    assert small_sample_scale([1.0, 1.0], [6, 6])[1] == pytest.approx(10.0)
    # a source with many windows hardly stretches the interval
    assert small_sample_scale([1.0], [1000])[0] == pytest.approx(1.0, abs=0.01)
    assert small_sample_scale([0.0], [6]) == (1.0, float("inf"))


def test_estimate_pools_references_and_amplitudes():
    # two alternating trials with different mu, two amplitudes
    off_n = [np.full(5, 0.5), np.full(5, 0.5)]
    off_t = [np.full(5, 0.25), np.full(5, 0.2)]  # mu 0.5 and 0.4
    on_n = np.full(8, 0.5)
    ref = np.array([0, 0, 1, 1, 0, 0, 1, 1])
    amp = np.array([60, 60, 60, 60, 120, 120, 120, 120.0])
    fel = np.where(amp == 60, 0.02, 0.08)
    on_t = np.where(ref == 0, 0.5, 0.4) * (on_n + fel)
    e = estimate_electrostatic(off_n, off_t, on_n, on_t, ref, amp, n_boot=200)
    np.testing.assert_allclose(e.groups, [60, 120])
    np.testing.assert_allclose(e.force_N, [0.02, 0.08])
    np.testing.assert_allclose(e.mu, 0.45)
    np.testing.assert_allclose(e.n_off, 10)
    with pytest.raises(AnalysisError, match="ON windows"):
        estimate_electrostatic(off_n, off_t, [], [], [], [])


# --- power law -------------------------------------------------------------------------------

def test_power_law_recovers_square_law_from_synthetic_trials():
    amps = np.array([60.0, 80, 100, 120, 140])
    k_true = 0.1 / 140**2
    forces = []
    for j, u in enumerate(amps):
        s = synth_trial(fel_N=k_true * u**2, seed=20 + j, duration_s=8.0)
        _, _, w = _analyse(s)
        off, on = w[w.condition == "off"], w[w.condition == "on"]
        mu = friction_coefficient(off.normal_force_N, off.friction_force_N)
        forces.append(np.mean(on.friction_force_N / mu - on.normal_force_N))
    fit = fit_power_law(amps, forces)
    assert fit.exponent == pytest.approx(2.0, abs=0.05)
    assert fit.exponent_ci_low < 2.0 < fit.exponent_ci_high
    assert fit.prefactor_N == pytest.approx(k_true, rel=0.3)


def test_power_law_interval_from_replicates_with_two_amplitudes():
    rng = np.random.default_rng(2)
    reps = np.column_stack([rng.normal(0.02, 0.001, 300), rng.normal(0.08, 0.002, 300)])
    fit = fit_power_law([50, 100], [0.02, 0.08], replicates_N=reps)
    assert fit.exponent == pytest.approx(2.0)
    assert 1.8 < fit.exponent_ci_low < 2.0 < fit.exponent_ci_high < 2.2
    nan_ci = fit_power_law([50, 100], [0.02, 0.08])
    assert np.isnan(nan_ci.exponent_ci_low)
    with pytest.raises(AnalysisError, match="two amplitudes"):
        fit_power_law([50, 100], [0.02, -0.01])


def _exponent_coverage(shared, repeats=300, *, n=6, sd=0.005, n_boot=300):
    """Share of repeated five-amplitude studies whose exponent interval holds 2."""
    amps = np.array([60.0, 80, 100, 120, 140])
    k = 0.3 / 140**2
    covered = 0
    for r in range(repeats):
        rng = np.random.default_rng(5000 + r)
        off_n, off_t, on_n, on_t, ref, amp = [], [], [], [], [], []
        for _ in range(1 if shared else amps.size):
            fn = rng.uniform(0.45, 0.55, n)
            off_n.append(fn)
            off_t.append(0.4 * fn + rng.normal(0, sd, n))
        for j, u in enumerate(amps):
            fn = rng.uniform(0.45, 0.55, n)
            on_n += list(fn)
            on_t += list(0.4 * (fn + k * u**2) + rng.normal(0, sd, n))
            ref += [0 if shared else j] * n
            amp += [u] * n
        e = estimate_electrostatic(off_n, off_t, on_n, on_t, ref, amp, n_boot=n_boot, seed=r)
        fit = fit_power_law(e.groups, e.force_N, replicates_N=e.replicates_N)
        covered += fit.exponent_ci_low <= 2.0 <= fit.exponent_ci_high
    return covered / repeats


@pytest.mark.parametrize("shared", [False, True], ids=["reference-per-amplitude",
                                                       "shared-reference"])
def test_exponent_interval_coverage(shared):
    assert _exponent_coverage(shared) >= 0.92


def test_replicate_with_a_non_positive_force_is_refitted_without_it():
    from evtribo.analysis.friction.powerlaw import _replicate_slopes

    x = np.log([50.0, 100.0, 200.0])
    reps = np.array([[-0.001, 0.04, 0.16], [0.01, 0.04, 0.16], [-1.0, -1.0, 0.16]])
    slopes = _replicate_slopes(x, reps, np.ones(3, bool))
    # the first is fitted over its last two points, the third (one point left) is dropped
    np.testing.assert_allclose(slopes, [2.0, 2.0])


# --- spectra ---------------------------------------------------------------------------------

@pytest.mark.parametrize("drive_Hz", [7.0, 10.0, 33.0])
def test_sine_drive_modulates_friction_at_twice_its_frequency(drive_Hz):
    s = synth_trial(waveform="sine", frequency_Hz=drive_Hz, seed=5, duration_s=8.0)
    al, _, w = _analyse(s)
    on = w[w.condition == "on"]
    segs = [np.abs(al.tangential[a:b]) for a, b in zip(on.i_start, on.i_stop, strict=True)]
    f = dominant_frequency(segs, al.rate_Hz)
    assert f == pytest.approx(2 * drive_Hz, rel=0.02)


def test_dominant_frequency_without_data_is_nan():
    assert np.isnan(dominant_frequency([np.ones(5)], 1000.0))
