"""Taring (``evtribo.analysis.forces.zero_offsets``) and hum removal
(``evtribo.analysis.forces.hum``) on synthetic load-cell traces made here, independently of the
package's simulator."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.analysis.forces.align import AlignedForces
from evtribo.analysis.forces.hum import find_hum, modulation_lines, remove_hum
from evtribo.analysis.forces.zero_offsets import (
    Tared,
    calibrate,
    find_lifted,
    friction_loop_offset,
    offset_curve,
    removed_offsets,
    tare_lifted,
)
from evtribo.canlog.rig import Calibration

RATE = 1000.0


def trace(*, duration=12.0, press=0.5, mu=0.5, wander=0.1, lifts=((0.0, 1.5),),
          offsets=(0.03, -0.02), drift=(0.002, -0.001), stroke_s=0.9, dwell_s=0.15,
          noise=1e-3, hum=0.0, mains=50.0, seed=0):
    """Forces of a finger on the grid: it presses with a wandering force, slides back and
    forth (friction mu * F_n, resting near zero at each reversal), lifts during *lifts*
    (with 80 ms to leave and to come back); each cell adds an offset, a linear drift over
    the trial, white noise and hum. Returns ``(t, normal, tangential, true_lifted)``."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(duration * RATE)) / RATE
    slow = np.cumsum(rng.standard_normal(t.size)) / np.sqrt(RATE)
    slow = (slow - slow.mean()) / max(slow.std(), 1e-12)
    tremor = np.convolve(rng.standard_normal(t.size), np.ones(50) / 50, mode="same")
    # the press wanders by up to +/- wander (and a tremor of a third of it)
    fn = press * (1 + wander * (np.tanh(slow) + 0.3 * tremor / max(tremor.std(), 1e-12)))
    contact = np.ones(t.size)
    for a, b in lifts:
        ramp = np.clip(np.maximum(a + 0.08 - t, t - (b - 0.08)) / 0.08, 0, 1)
        contact = np.where((t >= a) & (t < b), np.minimum(contact, ramp), contact)
    period = stroke_s + dwell_s + 0.1
    phase = np.mod(t, 2 * period)
    half = np.mod(phase, period)
    direction = np.where(phase < period, 1.0, -1.0)
    level = np.where(half < stroke_s, 1.0, np.where(half < stroke_s + 0.05, 0.5, 0.0))
    level = np.where(half > stroke_s + 0.05 + dwell_s, 0.5, level)
    fn = np.clip(fn, 0.02 * press, None) * contact
    ft = mu * fn * direction * level
    fn_m = fn + offsets[0] + drift[0] * t / duration + noise * rng.standard_normal(t.size)
    ft_m = ft + offsets[1] + drift[1] * t / duration + noise * rng.standard_normal(t.size)
    if hum:
        phase_n, phase_t = rng.uniform(0, 2 * np.pi, 2)
        fn_m += hum * np.sin(2 * np.pi * mains * t + phase_n)
        ft_m += hum * np.sin(2 * np.pi * mains * t + phase_t)
    true = [(max(a + 0.08, 0.0), b - 0.08) for a, b in lifts]
    return t, fn_m, ft_m, true


@settings(deadline=None)
@given(press=st.floats(0.15, 1.5), mu=st.floats(0.2, 1.5), wander=st.floats(0.0, 0.25),
       off_n=st.floats(-0.1, 0.1), off_t=st.floats(-0.1, 0.1), lift_at=st.floats(3.0, 9.0),
       lift_s=st.floats(0.55, 1.5), noise=st.floats(1e-4, 2e-3), seed=st.integers(0, 999))
def test_lifted_stretches_are_found_and_give_the_offsets(*, press, mu, wander, off_n, off_t,
                                                         lift_at, lift_s, noise, seed):
    # a lift-off counts from 0.35 s fully off (0.2 s used, 0.15 s at its ends left out)
    lifts = ((-0.1, 1.5), (lift_at, lift_at + lift_s))
    t, fn, ft, true = trace(press=press, mu=mu, wander=wander, lifts=lifts,
                            offsets=(off_n, off_t), noise=noise, seed=seed)
    found = find_lifted(t, fn, ft)
    assert len(found) == 2
    for stretch, (a, b) in zip(found, true, strict=True):
        assert a <= stretch.t_start and stretch.t_end <= b + 0.01
        assert a <= t[stretch.i_start] and t[stretch.i_stop - 1] <= b  # the part averaged
        mid = stretch.t_mid
        drift_n, drift_t = 0.002 * mid / 12.0, -0.001 * mid / 12.0
        assert stretch.normal_N == pytest.approx(off_n + drift_n, abs=6 * noise / 10 + 1e-4)
        assert stretch.tangential_N == pytest.approx(off_t + drift_t, abs=6 * noise / 10 + 1e-4)


@settings(deadline=None)
@given(press=st.floats(0.1, 1.5), mu=st.floats(0.2, 1.5), wander=st.floats(0.0, 0.3),
       dwell=st.floats(0.0, 0.6), noise=st.floats(1e-4, 3e-3), seed=st.integers(0, 999))
def test_a_finger_that_never_lifts_gives_no_lifted_stretch(*, press, mu, wander, dwell, noise,
                                                           seed):
    t, fn, ft, _ = trace(press=press, mu=mu, wander=wander, lifts=(), dwell_s=dwell,
                         noise=noise, seed=seed)
    assert find_lifted(t, fn, ft) == []


def test_a_servo_held_force_at_rest_is_no_lift():
    # a rig that holds the normal force constant: the floor is the pressing force itself
    t, fn, ft, _ = trace(press=0.5, wander=0.0, lifts=(), dwell_s=0.8, noise=2e-4)
    assert find_lifted(t, fn, ft) == []


def test_offset_curve_interpolates_and_extends_the_drift():
    t = np.array([0.0, 1.0, 5.0, 9.0, 12.0])
    np.testing.assert_allclose(offset_curve(t, [1.0], [0.02]), 0.02)
    np.testing.assert_allclose(offset_curve(t, [1.0], [0.02], slope=0.001),
                               0.02 + 0.001 * (t - 1.0))
    np.testing.assert_allclose(offset_curve(t, [1.0, 9.0], [0.02, 0.028]),
                               0.02 + 0.001 * (t - 1.0))  # linear beyond both ends too


def test_a_single_tare_stretch_extends_its_own_drift_rate():
    t, fn, ft, _ = trace(lifts=((-0.1, 2.0),), offsets=(0.01, 0.0), drift=(0.012, 0.0),
                         noise=2e-4, seed=3)
    aligned = AlignedForces(t, fn, ft, RATE)
    tared = tare_lifted(calibrate(aligned, None), min_s=0.2)
    assert tared.methods == ["lifted"] and len(tared.lifted) == 1
    removed = tared.residual[0]
    true = 0.01 + 0.012 * t / 12.0
    assert np.max(np.abs(removed - true)) < 1.5e-3  # held, it would be 10 mN off at the end


def _windows(rng, *, n=24, mu=0.5, b_on=0.08, offset=(0.02, 0.001), both_ways=True):
    rows = []
    for i in range(n):
        d = (1 if i % 2 else -1) if both_ways else (1 if i % 4 < 2 else -1)
        on = (i // 4) % 2 == 1
        if not both_ways:  # strokes in step with the conditions: one direction each
            d = 1 if on else -1
        fn = 0.5 + 0.1 * rng.standard_normal()
        c = 0.5 * i
        ft = d * (mu * fn + (b_on if on else 0.0)) + offset[0] + offset[1] * c
        rows.append((i * 100, i * 100 + 50, d, "on" if on else "off", c, fn, ft))
    w = pd.DataFrame(rows, columns=["i_start", "i_stop", "direction", "condition", "c", "fn",
                                    "ft"])
    t = np.zeros(n * 100 + 50)
    fn = np.full(t.size, np.nan)
    ft = np.full(t.size, np.nan)
    for r in w.itertuples():
        t[r.i_start:r.i_stop] = np.linspace(r.c - 0.1, r.c + 0.1, 50)
        fn[r.i_start:r.i_stop] = r.fn
        ft[r.i_start:r.i_stop] = r.ft
    return t, fn, ft, w


@settings(deadline=None)
@given(c0=st.floats(-0.1, 0.1), c1=st.floats(-0.002, 0.002), mu=st.floats(0.2, 1.2),
       b_on=st.floats(0.0, 0.3), seed=st.integers(0, 999))
def test_the_friction_loop_gives_the_tangential_offset(c0, c1, mu, b_on, seed):
    rng = np.random.default_rng(seed)
    t, fn, ft, w = _windows(rng, mu=mu, b_on=b_on, offset=(c0, c1))
    groups = [140.0 if c == "on" else None for c in w.condition]
    loop = friction_loop_offset(t, fn, ft, w, groups)
    assert loop is not None
    centres = w.c.to_numpy()
    np.testing.assert_allclose(loop(centres), c0 + c1 * centres, atol=1e-9)


def test_the_friction_loop_cannot_tell_the_offset_from_strokes_in_step_with_the_conditions():
    rng = np.random.default_rng(1)
    t, fn, ft, w = _windows(rng, both_ways=False)
    groups = [140.0 if c == "on" else None for c in w.condition]
    assert friction_loop_offset(t, fn, ft, w, groups) is None
    assert friction_loop_offset(t, fn, ft, w.iloc[:3], groups[:3]) is None


def test_removed_offsets_are_in_the_cells_own_units():
    t = np.arange(1000) / RATE
    fn = np.full(t.size, 0.5)
    ft = np.full(t.size, 0.2)
    cal = Calibration(normal_offset_N=0.01, tangential_offset_N=-0.02,
                      matrix=((1.0, 0.05), (0.02, 1.0)))
    tared = calibrate(AlignedForces(t, fn, ft, RATE), cal)
    np.testing.assert_allclose(tared.forces.normal, 0.49 + 0.05 * 0.22)
    np.testing.assert_allclose(tared.forces.tangential, 0.02 * 0.49 + 0.22)
    tared.residual = np.vstack([np.full(t.size, 0.003), np.full(t.size, -0.001)])
    normal, tangential = removed_offsets(tared, cal)
    back = np.linalg.solve(np.asarray(cal.matrix), [0.003, -0.001])
    assert normal == pytest.approx(0.01 + back[0])
    assert tangential == pytest.approx(-0.02 + back[1])
    # a cell that reads compression negative: flipped, and its offset reported as read
    flipped = calibrate(AlignedForces(t, -fn, ft, RATE), None)
    assert flipped.flipped and np.all(flipped.forces.normal > 0)
    flipped.residual = np.vstack([np.full(t.size, 0.004), np.zeros(t.size)])
    flipped.methods.append("lifted")
    assert removed_offsets(flipped, None)[0] == pytest.approx(-0.004)
    assert removed_offsets(Tared(forces=tared.forces), None) == (None, None)


@pytest.mark.parametrize("mains", [50.0, 60.0])
def test_hum_is_found_at_the_mains_and_notched_out(mains):
    t, fn, _ft, _ = trace(hum=0.01, mains=mains, noise=1e-3, seed=5)
    hum = find_hum(fn, RATE)
    assert hum is not None and hum.mains_Hz == mains
    assert hum.amplitude == pytest.approx(0.01, rel=0.25)
    clean = remove_hum(fn, RATE, hum)
    _, fn0, _, _ = trace(hum=0.0, noise=1e-3, seed=5)

    def line(x):
        return abs(np.mean(x * np.exp(-2j * np.pi * mains * t)))

    assert line(clean) < 0.03 * line(fn)
    # the rest of the signal, steps included, is left as it was (the edges aside)
    core = slice(int(2 * RATE), int(10 * RATE))
    assert np.std(clean[core] - fn0[core]) < 0.0015
    assert find_hum(fn0, RATE) is None


def test_a_hum_line_where_the_friction_oscillates_is_left_in():
    _t, _fn, ft, _ = trace(hum=0.01, mains=50.0, seed=6)
    avoid = modulation_lines("sine", 25.0, RATE)  # the friction oscillates at 50 Hz
    assert avoid[:3] == [50.0, 100.0, 150.0] and modulation_lines(None, 25.0, RATE) == []
    assert modulation_lines("square", 25.0, RATE)[:2] == [50.0, 100.0]  # pulses, if leaky
    hum = find_hum(ft, RATE, avoid_Hz=avoid)
    assert hum is not None and hum.kept_Hz == (50.0,) and 50.0 not in hum.lines_Hz
    np.testing.assert_array_equal(remove_hum(ft, RATE, hum), ft)


def test_levels_of_means_that_fall_between_the_10ms_samples_are_none():
    # usable 0.1-s means everywhere but on the 10-ms grid the levels are read from: no
    # levels (there is nothing to read them from), not an IndexError (found by the fuzzer)
    from evtribo.analysis.forces.lifted import _levels

    n, m = 2000, 100
    idx = np.arange(n)
    fn = np.where(idx % 200 < 100, 0.5, 0.0)
    ft = np.where(idx % 400 < 200, 0.2, -0.2)
    ok = idx % 10 != 0
    assert _levels(fn, ft, ok, m) is None
    assert _levels(fn, ft, np.ones(n, bool), m) is not None
