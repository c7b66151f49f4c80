"""One trial's physics on the grid: who presses how hard, which voltage, which friction.

The normal cell under the screen reads the external force F_n the finger applies (the
electrostatic attraction is internal to the finger-screen pair); the contact carries
W = F_n + F_el while the voltage is on, and the friction is c·W^m times the modulations
(trial, moisture, trend, speed, direction, stroke, texture), through Dahl's pre-sliding.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from . import finger, physics
from .config import StudyConfig


@dataclass
class Subject:
    """One subject's drawn parameters (the truth)."""

    name: str
    mu: float                 # μ at W = f_ref
    c: float                  # prefactor of F_t = c·W^m, N^(1-m)
    asymmetry: float          # forward μ / backward μ - 1
    weak: bool
    h_L_m: float | None = None  # paper model
    k: float | None = None      # power law, N/V^n
    n: float | None = None


@dataclass
class TrialSpec:
    """One trial's settings and draws."""

    subject: Subject
    name: str
    amplitude_V: float
    condition: str            # "alternating", "on" or "off"
    mu_factor: float          # this trial's μ relative to the subject's
    moisture_rise: float
    moisture_tau_s: float


@dataclass
class TrialPhysics:
    """The true signals of one trial on the grid."""

    t: np.ndarray
    on: np.ndarray            # the amplifier's output is on
    contact: np.ndarray       # 0..1
    normal: np.ndarray        # F_n, N
    electrostatic: np.ndarray  # F_el, N
    tangential: np.ndarray    # F_t, N (signed)
    mu_now: np.ndarray        # c_t·W^(m-1): the friction coefficient of the moment
    velocity: np.ndarray
    stroke: np.ndarray


def weak_gap(cfg: StudyConfig, h_L: float, factor: float) -> float:
    """The air gap at which the paper's F_el (0.5 N, 140 V) is ``factor`` of h_L's."""
    e = cfg.electrostatic

    def force(h: float) -> float:
        return float(physics.paper_force(e, h, np.array(140.0), np.array(0.5)))

    goal = factor * force(h_L)
    return float(brentq(lambda h: force(h) - goal, h_L, 1e-3))


def electrostatic(cfg: StudyConfig, s: Subject, amplitude: float, *, on: np.ndarray,
                  normal: np.ndarray, t: np.ndarray) -> np.ndarray:
    """F_el on the grid, N: the instantaneous force, or its mean over a fast sine's cycle."""
    d = cfg.drive
    if d.waveform == "square":
        phases = np.array([0.5 * np.pi])
    elif d.frequency_Hz * cfg.grid_s > 0.05:
        phases = (np.arange(32) + 0.5) * np.pi / 32
    else:
        phases = None

    def model(u: np.ndarray) -> np.ndarray:
        if s.h_L_m is not None:
            return physics.paper_force(cfg.electrostatic, s.h_L_m, u, normal)
        assert s.k is not None and s.n is not None
        return physics.power_force(s.k, s.n, u)

    if phases is None:
        u = amplitude * np.abs(np.sin(2 * np.pi * d.frequency_Hz * t))
        force = model(u)
    else:
        force = np.mean([model(np.full(t.size, amplitude * np.sin(p))) for p in phases], axis=0)
    return np.where(on, force, 0.0)


def _texture(n: int, dt: float, size: float, rng: np.random.Generator) -> np.ndarray:
    """1 + size·(unit-rms noise averaged over 5 ms): the pad's ridges on the glass."""
    if size == 0.0:
        return np.ones(n)
    w = max(1, round(0.005 / dt))
    z = np.convolve(rng.standard_normal(n), np.ones(w) / np.sqrt(w), mode="same")
    return 1.0 + size * z


def simulate(cfg: StudyConfig, spec: TrialSpec, rng: np.random.Generator) -> TrialPhysics:
    """The true forces of one trial."""
    f = cfg.friction
    dt = cfg.grid_s
    t = np.arange(round(cfg.trial_s / dt)) * dt
    tare = cfg.cells.tare_s
    on, pair = finger.schedule(t, cfg.drive, tare, spec.condition, rng)
    mo = finger.motion(t, cfg.strokes, tare, rng)
    normal = finger.press(t, cfg.press, pair, rng).clip(0.02, None) * mo.contact
    fel = electrostatic(cfg, spec.subject, spec.amplitude_V, on=on, normal=normal, t=t) * mo.contact
    load = normal + fel
    since = t - mo.landing_s
    scatter = 1.0 + f.stroke_scatter * rng.standard_normal(mo.stroke.max() + 1)
    coef = (spec.subject.c * spec.mu_factor
            * physics.moisture_factor(since, spec.moisture_rise, spec.moisture_tau_s)
            * (1.0 + f.trend_per_10s * np.clip(since, 0.0, None) / 10.0)
            * physics.speed_factor(mo.velocity, f.speed_exponent, f.v_ref_m_s)
            * (1.0 + 0.5 * spec.subject.asymmetry * mo.direction)
            * scatter[mo.stroke])
    slide = physics.sliding_friction(coef * _texture(t.size, dt, f.texture_noise, rng),
                                     load, f.m)
    tangential = physics.dahl(mo.direction * slide, mo.velocity, dt, f.presliding_m)
    mu_now = coef * np.maximum(load, 1e-6) ** (f.m - 1.0)
    return TrialPhysics(t, on, mo.contact, normal, fel, tangential, mu_now,
                        mo.velocity, mo.stroke)
