"""The physics of the simulated trial: finger strokes, the pressing force, the voltage.

Everything here is a function of the trial's true time ``t`` (s from the trial's start); the
load cells sample it on their own clocks. The electrostatic force comes from
:func:`evtribo.model.electrostatic_force` with the subject's air gap; friction is Coulomb's,
``mu * (F_n + F_el(U(t)))``, with the sign of the sliding direction.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.signal import lfilter

from evtribo.acquisition.simulator.config import SubjectParams, TrialConfig
from evtribo.model import TABLE_1, ModelParameters, electrostatic_force

__all__ = [
    "NormalForceProcess",
    "Strokes",
    "electrostatic",
    "excitation_gate",
    "model_parameters",
    "on_off_schedule",
    "voltage",
]

FloatArray = npt.NDArray[np.float64]

#: Time step of the normal-force process, s (the cells interpolate it).
FORCE_STEP_S = 1e-3
#: Correlation time and relative size of the fast wobble on top of the slow drift.
WOBBLE_TIME_S = 0.1
WOBBLE_FRACTION = 0.25


def model_parameters(subject: SubjectParams) -> ModelParameters:
    """The seed paper's Table 1 with the subject's friction coefficient and air gap."""
    return dataclasses.replace(TABLE_1, mu=subject.mu, h_L=subject.h_L)


def electrostatic(normal_force: npt.ArrayLike, voltage: npt.ArrayLike,
                  params: ModelParameters) -> FloatArray:
    """Electrostatic force of the model at each instant, N.

    Parameters
    ----------
    normal_force : array_like, N
        Externally applied normal force.
    voltage : array_like, V
        Instantaneous voltage (its sign does not matter).
    params : evtribo.model.ModelParameters
    """
    fn = np.asarray(normal_force, dtype=np.float64)
    u = np.abs(np.asarray(voltage, dtype=np.float64))
    out = np.zeros(np.broadcast_shapes(fn.shape, u.shape))
    live = np.broadcast_to(u, out.shape) > 0
    if live.any():
        fn_b = np.broadcast_to(fn, out.shape)[live]
        u_b = np.broadcast_to(u, out.shape)[live]
        out[live] = np.asarray(electrostatic_force(fn_b, u_b, params), dtype=np.float64)
    return out


def expected_electrostatic_force(normal_force: float, config: TrialConfig,
                                 params: ModelParameters) -> float:
    """Time-averaged electrostatic force while ON at a steady normal force, N.

    For a square wave ``U^2`` is constant: the model at the amplitude. For a sine it is the
    model's force averaged over a period of the voltage.
    """
    if config.amplitude_V == 0:
        return 0.0
    if config.waveform == "square":
        return float(electrostatic(normal_force, config.amplitude_V, params))
    phase = (np.arange(512) + 0.5) / 512
    u = config.amplitude_V * np.sin(2 * np.pi * phase)
    return float(np.mean(electrostatic(np.full(u.shape, normal_force), u, params)))


def voltage(t: FloatArray, config: TrialConfig) -> FloatArray:
    """Voltage of the amplifier's waveform at times *t* (s), before the ON/OFF gate, V."""
    arg = np.sin(2 * np.pi * config.frequency_Hz * t)
    if config.waveform == "sine":
        return config.amplitude_V * arg
    return np.where(arg >= 0, config.amplitude_V, -config.amplitude_V)


def excitation_gate(t: FloatArray, config: TrialConfig) -> npt.NDArray[np.bool_]:
    """Whether the voltage is applied at times *t* (s)."""
    t = np.asarray(t, dtype=np.float64)
    if config.condition == "on":
        return np.ones(t.shape, dtype=bool)
    if config.condition == "off":
        return np.zeros(t.shape, dtype=bool)
    phase = np.mod(t, config.on_s + config.off_s)
    return phase < config.on_s if config.start_on else phase >= config.off_s


def on_off_schedule(config: TrialConfig) -> list[tuple[float, float, bool]]:
    """The trial's phases as ``(start_s, end_s, on)``, in seconds from the trial's start."""
    end = config.duration_s
    if config.condition != "alternating":
        return [(0.0, end, config.condition == "on")]
    first, second = (config.on_s, config.off_s) if config.start_on else (config.off_s,
                                                                         config.on_s)
    phases = []
    t, on, k = 0.0, config.start_on, 0
    while t < end:
        stop = min(t + (first if k % 2 == 0 else second), end)
        phases.append((t, stop, on))
        t, on, k = stop, not on, k + 1
    return phases


@dataclass
class Strokes:
    """The finger's strokes: slides at constant speed separated by reversals.

    During a slide the friction force has the sign of ``direction``; during the reversal
    that follows, the finger sticks and the force swings through zero (as ``cos``) to the
    opposite sign.

    Attributes
    ----------
    slide_start, slide_end : ndarray, s
        Start and end of each slide.
    direction : ndarray of +1/-1
        Sign of the friction force during each slide.
    reversal_s : float, s
    """

    slide_start: FloatArray
    slide_end: FloatArray
    direction: FloatArray
    reversal_s: float

    @classmethod
    def draw(cls, subject: SubjectParams, duration_s: float,
             rng: np.random.Generator) -> Strokes:
        """Strokes covering ``[0, duration_s]``, starting at a random point of a slide."""
        base = subject.stroke_length_m / subject.sliding_speed_m_s
        shortest = base * (1 - subject.stroke_jitter) + subject.reversal_s
        n = math.ceil(duration_s / shortest) + 2
        slides = base * (1 + subject.stroke_jitter * rng.uniform(-1, 1, n))
        first = -rng.uniform(0, 1) * slides[0]
        start = first + np.concatenate([[0.0], np.cumsum(slides + subject.reversal_s)[:-1]])
        direction = np.where(np.arange(n) % 2 == 0, 1.0, -1.0) * rng.choice([-1.0, 1.0])
        return cls(start, start + slides, direction, subject.reversal_s)

    def factor(self, t: FloatArray) -> FloatArray:
        """Signed fraction of full sliding friction at times *t* (-1 to 1)."""
        i = np.clip(np.searchsorted(self.slide_start, t, side="right") - 1, 0,
                    len(self.slide_start) - 1)
        tau = (t - self.slide_end[i]) / self.reversal_s
        return self.direction[i] * np.where(tau <= 0, 1.0, np.cos(np.pi * np.clip(tau, 0, 1)))

    def slides(self, duration_s: float) -> list[tuple[float, float, int]]:
        """Steady slides inside the trial as ``(start_s, end_s, direction)``."""
        out = []
        for a0, b0, d in zip(self.slide_start, self.slide_end, self.direction, strict=True):
            a, b = max(float(a0), 0.0), min(float(b0), duration_s)
            if b > a:
                out.append((a, b, int(d)))
        return out


class NormalForceProcess:
    """The subject's normal force: the target plus a slow drift and a faster wobble.

    Both are Ornstein-Uhlenbeck processes, sampled exactly on a grid of
    :data:`FORCE_STEP_S` and generated chunk after chunk with their state carried over.
    """

    def __init__(self, subject: SubjectParams, rng: np.random.Generator) -> None:
        self.target = subject.normal_force_N
        sd_slow = subject.force_drift * subject.normal_force_N
        self._a = np.array([math.exp(-FORCE_STEP_S / subject.drift_time_s),
                            math.exp(-FORCE_STEP_S / WOBBLE_TIME_S)])
        self._sd = np.array([sd_slow, sd_slow * WOBBLE_FRACTION])
        self._state = self._sd * rng.standard_normal(2)  # stationary start
        self.index = 0  # grid index of the last value produced

    def value(self) -> float:
        """The force at the current grid point, N."""
        return float(self.target + self._state.sum())

    def advance(self, n: int, rng: np.random.Generator) -> FloatArray:
        """Values at grid points ``index .. index + n`` (n + 1 values), then move on by n."""
        out = np.full(n + 1, self.target)
        for c in range(2):
            a, sd = self._a[c], self._sd[c]
            w = sd * math.sqrt(1 - a * a) * rng.standard_normal(n)
            y, _ = lfilter([1.0], [1.0, -a], w, zi=[a * self._state[c]])
            out[0] += self._state[c]
            out[1:] += y
            if n:
                self._state[c] = y[-1]
        self.index += n
        return out
