"""The friction's oscillation found in its spectrum: the peak that stands out, not the
highest power (a person's slow force wander has more power than a weak oscillation)."""

import numpy as np
import pytest

from evtribo.analysis.forces.spectra import dominant_frequency

RATE = 2000.0


def _ou(rng, n, sd, tau_s):
    """An Ornstein-Uhlenbeck process (a person's wandering force), exact steps."""
    a = np.exp(-1.0 / (RATE * tau_s))
    x = np.empty(n)
    x[0] = sd * rng.standard_normal()
    noise = sd * np.sqrt(1 - a * a) * rng.standard_normal(n)
    for i in range(1, n):
        x[i] = a * x[i - 1] + noise[i]
    return x


def _windows(rng, *, osc_amp, osc_Hz, wander, n=8, length_s=0.8):
    """Friction in *n* steady windows: a slow wander (sd *wander*, 1.5 s) and a wobble
    (a quarter of it, 0.1 s), white noise of 1 mN, and the oscillation."""
    out = []
    for _ in range(n):
        t = np.arange(int(length_s * RATE)) / RATE
        drift = _ou(rng, t.size, wander, 1.5) + _ou(rng, t.size, wander / 4, 0.1)
        phase = rng.uniform(0, 2 * np.pi)
        out.append(0.3 + drift + osc_amp * np.sin(2 * np.pi * osc_Hz * t + phase)
                   + 1e-3 * rng.standard_normal(t.size))
    return out


@pytest.mark.parametrize("osc_Hz", [20.0, 40.0, 200.0, 600.0])
def test_a_weak_oscillation_under_a_strong_wander_is_found(osc_Hz):
    rng = np.random.default_rng(int(osc_Hz))
    windows = _windows(rng, osc_amp=2e-3, osc_Hz=osc_Hz, wander=0.02)
    # the wander carries far more power at a few Hz than the oscillation does at its own
    assert dominant_frequency(windows, RATE) == pytest.approx(osc_Hz, abs=0.5)


def test_without_an_oscillation_no_frequency_is_made_up():
    rng = np.random.default_rng(1)
    windows = _windows(rng, osc_amp=0.0, osc_Hz=40.0, wander=0.02)
    assert np.isnan(dominant_frequency(windows, RATE))
