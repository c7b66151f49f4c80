"""Synthetic load-cell traces from the friction law ``F_t = mu * (F_n + F_el)``.

Independent of the package's simulator: a finger slides back and forth (strokes of
``stroke_s``), the friction ramps through zero at each reversal (stick) and is zero before
sliding starts; each load cell samples at its own rate and clock (offset, drift, jitter);
the amplifier reports its ON/OFF state in status samples.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class SynthTrial:
    t_normal: np.ndarray
    normal: np.ndarray
    t_tangential: np.ndarray
    tangential: np.ndarray
    t_excitation: np.ndarray
    enabled: np.ndarray
    true_mu: float
    true_fel_N: float


def _sample_times(rng, duration_s, rate, offset, drift, *, jitter_s):
    n = int(duration_s * rate)
    t = offset + np.arange(n) / rate * (1 + drift)
    return np.sort(t + rng.normal(0, jitter_s, n))


def _on(t, condition, switch_s, t_switch0):
    if condition == "on":
        return np.ones(t.shape, bool)
    if condition == "off":
        return np.zeros(t.shape, bool)
    return (np.floor((t - t_switch0) / switch_s) % 2 == 1) & (t >= t_switch0)


def synth_trial(*, duration_s=12.0, mu=0.5, normal_N=0.5, fel_N=0.1, condition="alternating",
                waveform="square", frequency_Hz=10.0, rate_normal=1000.0,
                rate_tangential=2000.0, stroke_s=0.9, reversal_s=0.08, startup_s=0.7,
                switch_s=1.7, noise_N=0.002, jitter_s=5e-5, gaps=(), seed=0):
    """One trial. *gaps* is a sequence of ``(channel, t0, t1)`` intervals without samples."""
    rng = np.random.default_rng(seed)
    tn = _sample_times(rng, duration_s, rate_normal, 1000.0003, 2e-5, jitter_s=jitter_s)
    tt = _sample_times(rng, duration_s, rate_tangential, 1000.0011, -3e-5, jitter_s=jitter_s)

    def fn_true(t):
        return normal_N * (1 + 0.15 * np.sin(2 * np.pi * 0.23 * (t - 1000)))

    def fel(t):
        on = _on(t, condition, switch_s, 1000.0 + 0.4)
        if waveform == "sine":
            return on * 2 * fel_N * np.sin(2 * np.pi * frequency_Hz * (t - 1000)) ** 2
        return on * fel_N

    def grip(t):
        s = t - 1000.0 - startup_s
        tau = np.mod(s, stroke_s)
        direction = np.where(np.floor(s / stroke_s) % 2 == 0, 1.0, -1.0)
        return np.where(s < 0, 0.0, direction * np.minimum(1.0, tau / reversal_s))

    f_n = fn_true(tn) + rng.normal(0, noise_N, tn.size)
    f_t = mu * (fn_true(tt) + fel(tt)) * grip(tt) + rng.normal(0, noise_N, tt.size)
    for channel, a, b in gaps:
        if channel == "normal":
            keep = ~((tn >= a) & (tn < b))
            tn, f_n = tn[keep], f_n[keep]
        else:
            keep = ~((tt >= a) & (tt < b))
            tt, f_t = tt[keep], f_t[keep]
    te = 1000.0 + 0.013 + np.arange(int(duration_s * 50)) / 50.0
    return SynthTrial(tn, f_n, tt, f_t, te, _on(te, condition, switch_s, 1000.0 + 0.4),
                      mu, fel_N)
