"""What the participant and the amplifier do over a trial, on the physics' time grid.

- The amplifier's ON/OFF schedule: alternating phases after the tare stretch.
- The finger's contact: lifted for the tare stretch, a landing, optional lift-offs.
- The strokes: back and forth, each of its own duration and travel, with raised-cosine
  speed-up and slow-down, a dwell at each reversal and a slow wobble of the speed.
- The pressing force: tracked in a band (an Ornstein-Uhlenbeck error), wandering (a
  reflected random walk), swept, or held at protocol targets, one per ON/OFF pair.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from .config import Drive, Press, Strokes

LANDING_S = 0.25   # the finger's landing after the tare stretch
SETTLE_S = 0.3     # pressing before the first stroke
SMOOTH_S = 0.05    # the pressing force's smoothness


@dataclass
class Motion:
    """The finger's kinematics and contact on the grid."""

    velocity: np.ndarray    # m/s, signed
    direction: np.ndarray   # +1 / -1: the current (or last) stroke's direction
    stroke: np.ndarray      # stroke number (0 before the first)
    contact: np.ndarray     # 0..1: the finger's contact envelope
    landing_s: float        # when the finger first touched down


def schedule(t: np.ndarray, drive: Drive, start_s: float, condition: str,
             rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(on, pair): the amplifier's state per sample and the ON/OFF pair each sample is in.

    ``condition`` "alternating" starts with an OFF phase at ``start_s``; "on" and "off"
    hold one state over the whole trial.
    """
    pair = np.zeros(t.size, dtype=np.int64)
    if condition != "alternating":
        return np.full(t.size, condition == "on"), pair
    on = np.zeros(t.size, dtype=bool)
    edge, state, k = start_s, False, 0
    while edge < t[-1]:
        length = drive.phase_s * (1.0 + drive.phase_jitter * rng.uniform(-1.0, 1.0))
        sel = (t >= edge) & (t < edge + length)
        on[sel] = state
        pair[sel] = k // 2
        edge += length
        state = not state
        k += 1
    return on, pair


def _ramp(x: np.ndarray) -> np.ndarray:
    """Raised cosine from 0 (x ≤ 0) to 1 (x ≥ 1)."""
    return 0.5 - 0.5 * np.cos(np.pi * np.clip(x, 0.0, 1.0))


def contact_envelope(t: np.ndarray, tare_s: float, strokes: Strokes, slide_s: float,
                     rng: np.random.Generator) -> np.ndarray:
    """The finger's contact: 0 while lifted, 1 pressing, raised-cosine landings."""
    env = _ramp((t - tare_s) / LANDING_S)
    rate = strokes.lifts_per_min / 60.0
    if rate <= 0:
        return env
    edge = slide_s + rng.exponential(1.0 / rate)
    while edge < t[-1] - 2.0:
        off = rng.uniform(*strokes.lift_s)
        down = _ramp((t - edge) / 0.1)
        up = _ramp((t - edge - 0.1 - off) / 0.15)
        env = env * (1.0 - down + up * down)
        edge += 0.1 + off + 0.15 + rng.exponential(1.0 / rate)
    return env


def motion(t: np.ndarray, strokes: Strokes, tare_s: float,
           rng: np.random.Generator) -> Motion:
    """The strokes from the end of the landing to the trial's end."""
    slide_s = tare_s + LANDING_S + SETTLE_S
    velocity = np.zeros(t.size)
    direction = np.ones(t.size)
    stroke = np.zeros(t.size, dtype=np.int64)
    edge, sign, k = slide_s, 1.0, 1
    while edge < t[-1]:
        dur = rng.uniform(*strokes.duration_s)
        travel = rng.uniform(*strokes.travel_m)
        ramp = min(strokes.ramp_s, dur / 3.0)
        i0, i1 = np.searchsorted(t, [edge, edge + dur])
        tau = t[i0:i1] - edge
        shape = _ramp(tau / ramp) * _ramp((dur - tau) / ramp)
        wobble = 1.0 + strokes.speed_wobble * np.sin(2 * np.pi * tau / dur
                                                     + rng.uniform(0, 2 * np.pi))
        velocity[i0:i1] = sign * travel / (dur - ramp) * shape * wobble
        dwell = rng.uniform(*strokes.dwell_s)
        j1 = int(np.searchsorted(t, edge + dur + dwell))
        direction[i0:j1] = sign
        stroke[i0:j1] = k
        edge += dur + dwell
        sign, k = -sign, k + 1
    env = contact_envelope(t, tare_s, strokes, slide_s, rng)
    return Motion(velocity, direction, stroke, env, tare_s)


def _smooth(x: np.ndarray, dt: float, tau: float = SMOOTH_S) -> np.ndarray:
    """First-order low-pass: a hand's force has no content above a few tens of Hz."""
    a = np.exp(-dt / tau)
    return np.asarray(lfilter([1.0 - a], [1.0, -a], x, zi=[a * x[0]])[0])


def _ou(n: int, dt: float, tau: float, sd: float, rng: np.random.Generator) -> np.ndarray:
    """An Ornstein-Uhlenbeck process of stationary sd ``sd`` and correlation time ``tau``,
    smoothed over 50 ms (muscles do not jump from one millisecond to the next)."""
    a = np.exp(-dt / tau)
    z = rng.standard_normal(n) * sd * np.sqrt(1.0 - a * a)
    x0 = rng.standard_normal() * sd
    out = lfilter([1.0], [1.0, -a], z, zi=[a * x0])[0]
    return _smooth(np.asarray(out), dt)


def _fold(x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Reflect x into [lo, hi] (a random walk between two walls)."""
    span = hi - lo
    y = np.mod(x - lo, 2 * span)
    return lo + np.where(y > span, 2 * span - y, y)


def press(t: np.ndarray, p: Press, pair: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The pressing force the participant aims at, N (before the contact envelope)."""
    dt = t[1] - t[0]
    n = t.size
    lo, hi = p.range_N
    if p.mode == "band":
        return p.target_N + _ou(n, dt, p.tau_s, p.band_N / 3.0, rng)
    if p.mode == "walk":
        steps = rng.standard_normal(n) * (hi - lo) / np.sqrt(p.walk_traverse_s) * np.sqrt(dt)
        start = rng.uniform(lo + 0.2 * (hi - lo), hi - 0.2 * (hi - lo))
        walk = _smooth(_fold(start + np.cumsum(steps), lo, hi), dt)
        return walk + _ou(n, dt, p.tau_s, 0.02, rng)
    if p.mode == "sweep":
        phase = rng.uniform(0, 1) + t / p.sweep_period_s
        tri = 2.0 * np.abs(np.mod(phase, 1.0) - 0.5)
        return lo + (hi - lo) * tri + _ou(n, dt, p.tau_s, 0.02, rng)
    if p.mode == "targets":
        goal = np.asarray(p.targets_N)[pair % len(p.targets_N)]
        return _smooth(goal, dt, 0.3) + _ou(n, dt, p.tau_s, p.band_N / 3.0, rng)
    raise ValueError(f"unknown press mode {p.mode!r}")
