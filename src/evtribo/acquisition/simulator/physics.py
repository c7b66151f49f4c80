"""The physics of the simulated trial: finger strokes, contact, the pressing force, the voltage,
and what the load cells add to it.

Everything here is a function of the trial's true time ``t`` (s from the trial's start); the
load cells sample it on their own clocks. The electrostatic force comes from
:func:`evtribo.model.electrostatic_force` with the subject's air gap; friction is Coulomb's,
``mu * (F_n + F_el(U(t)))``, with the sign of the sliding direction. While the finger is off
the screen (:class:`Contact`: the tare stretch at the start, lift-offs) both forces are zero.

The cells do not read the true forces (:mod:`~evtribo.acquisition.simulator.cells`:
:class:`CellZero`, :func:`measured`, importable from here too).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.signal import lfilter

from evtribo.acquisition.simulator.cells import CellZero, measured
from evtribo.acquisition.simulator.config import SubjectParams, TrialConfig
from evtribo.model import (
    TABLE_1,
    ModelParameters,
    adhesion_stress,
    contact_area_jkr,
    effective_voltage,
    electrostatic_force,
    electrostatic_force_drive,
    gap_factor,
)

__all__ = [
    "CONTACT_RAMP_S",
    "CellZero",
    "Contact",
    "NormalForceProcess",
    "Strokes",
    "drive_force",
    "electrostatic",
    "excitation_gate",
    "measured",
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
#: Time the finger takes to leave the screen, and to come back into full contact, s.
CONTACT_RAMP_S = 0.08
#: Shortest time in contact between two lift-offs, s.
MIN_CONTACT_S = 1.0
#: Largest magnitude of the friction force's rest level during a dwell (fraction of sliding).
DWELL_LEVEL = 0.15
def model_parameters(subject: SubjectParams) -> ModelParameters:
    """The seed paper's Table 1 with the subject's friction coefficient, air gap and other
    model parameters (``SubjectParams.model``: e.g. the resistances ``r_sc``, ``r_g``).

    Parameters
    ----------
    subject : SubjectParams

    Returns
    -------
    ModelParameters
    """
    return TABLE_1.with_values(dict(subject.model), mu=subject.mu, h_L=subject.h_L)


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

    Returns
    -------
    ndarray, N
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
    """Time-averaged electrostatic force while ON at a steady normal force, N: the model
    under the trial's drive (:func:`evtribo.model.electrostatic_force_drive`; for a square
    wave through a perfectly insulating gap, the model at the amplitude; for a sine, the
    model's force averaged over a period)."""
    if config.amplitude_V == 0:
        return 0.0
    return float(electrostatic_force_drive(normal_force, config.amplitude_V,
                                           config.frequency_Hz, config.waveform, params))


#: Odd harmonics of a square drive whose filtering by the layers is simulated.
GAP_HARMONICS = 200
#: Phases of one period on which a square drive's filtering is tabulated.
GAP_PHASES = 4096
#: Sub-samples of a load cell's sampling interval when the force oscillates within it.
SUBSAMPLES = 8


def _leaky(params: ModelParameters | None) -> bool:
    return params is not None and not (np.isinf(params.r_sc) and np.isinf(params.r_g))


@functools.lru_cache(maxsize=64)
def _square_correction(frequency_Hz: float, params: ModelParameters) -> FloatArray:
    """One period (:data:`GAP_PHASES` phases) of ``sum_k 4/(k pi) Im((H(k w) - 1)
    e^(j k 2 pi phase))`` for a square wave of amplitude 1: what the layers change of it."""
    k = 2.0 * np.arange(GAP_HARMONICS) + 1.0
    correction = (gap_factor(frequency_Hz * k, params) - 1.0) / k
    phase = np.arange(GAP_PHASES + 1) / GAP_PHASES
    return (4 / np.pi) * np.imag(np.exp(2j * np.pi * phase[:, None] * k) @ correction)


def voltage(t: FloatArray, config: TrialConfig, params: ModelParameters | None = None
            ) -> FloatArray:
    """The amplifier's waveform at times *t* (s), before the ON/OFF gate, V.

    With *params* whose layers conduct (finite ``r_sc`` or ``r_g``), the voltage the
    paper's model sees: the applied one as the circuit of :mod:`evtribo.model.circuit`
    passes it to the gap (relative to the paper's capacitive division), in the periodic
    steady state. A sine is scaled and shifted by ``H(w)``; a square wave is the applied
    one plus the series of ``(H(k w) - 1)`` over its odd harmonics (which converges fast:
    the edges themselves pass, ``H -> 1``; tabulated over one period), so that its force
    pulses after each edge.

    Parameters
    ----------
    t : ndarray, s
        Times from the trial's start.
    config : TrialConfig
    params : ModelParameters, optional
        The model, for the voltage at the gap (default: the applied voltage).

    Returns
    -------
    ndarray, V
    """
    t = np.asarray(t, dtype=np.float64)
    w = 2 * np.pi * config.frequency_Hz
    u = config.amplitude_V
    arg = np.sin(w * t)
    applied = u * arg if config.waveform == "sine" else np.where(arg >= 0, u, -u)
    if not _leaky(params):
        return applied
    assert params is not None
    if config.waveform == "sine":
        h = complex(gap_factor(config.frequency_Hz, params))
        return u * np.imag(h * np.exp(1j * w * t))
    table = _square_correction(float(config.frequency_Hz), params)
    phase = np.mod(t * config.frequency_Hz, 1.0)
    return applied + u * np.interp(phase, np.arange(table.size) / GAP_PHASES, table)


def drive_force(t: FloatArray, normal_force: FloatArray, config: TrialConfig,
                params: ModelParameters, interval_s: float) -> FloatArray:
    """The electrostatic force a load cell reports at times *t* (s): its mean over the
    cell's sampling interval before each sample (as an integrating converter gives), N.

    The stress follows the voltage the gap sees (:func:`voltage`); under a square drive the
    contact area is that of its mean-square voltage (a soft fingertip does not follow the
    pulses after each edge), so that the mean force is the model's
    (:func:`evtribo.model.electrostatic_force_drive`). A drive whose force oscillates faster
    than the cell samples gives the period's mean; slower, the interval is averaged over
    :data:`SUBSAMPLES` instants. Zero where the excitation is off.

    Parameters
    ----------
    t : ndarray, s
        Sample times.
    normal_force : ndarray, N
        The pressing force at those times (the contact's load).
    config : TrialConfig
    params : ModelParameters
    interval_s : float, s
        The cell's sampling interval.

    Returns
    -------
    ndarray, N
    """
    fn = np.asarray(normal_force, dtype=np.float64)
    on = excitation_gate(t, config)
    out = np.zeros(t.shape)
    if not on.any() or config.amplitude_V == 0:
        return out
    amplitude, f = config.amplitude_V, config.frequency_Hz
    steady = config.waveform == "square" and not _leaky(params)
    if steady or 2.0 * f * interval_s > 2.0:  # constant, or many periods per sample
        out[on] = electrostatic_force_drive(fn[on], amplitude, f, config.waveform, params)
        return out
    sub = t[on, None] - interval_s * (np.arange(SUBSAMPLES) + 0.5) / SUBSAMPLES
    u = voltage(sub.ravel(), config, params).reshape(sub.shape)
    load = np.broadcast_to(fn[on, None], sub.shape)
    if config.waveform == "square":
        u_eff = float(effective_voltage(amplitude, f, "square", params))
        force = adhesion_stress(u, params) * contact_area_jkr(load, u_eff, params)
    else:
        force = electrostatic(load, u, params)
    out[on] = np.mean(force, axis=1)
    return out


def excitation_gate(t: FloatArray, config: TrialConfig) -> npt.NDArray[np.bool_]:
    """Whether the voltage is applied at times *t* (s).

    Parameters
    ----------
    t : ndarray, s
        Times from the trial's start.
    config : TrialConfig

    Returns
    -------
    ndarray of bool
    """
    t = np.asarray(t, dtype=np.float64)
    if config.condition == "on":
        return np.ones(t.shape, dtype=bool)
    if config.condition == "off":
        return np.zeros(t.shape, dtype=bool)
    phase = np.mod(t, config.on_s + config.off_s)
    return phase < config.on_s if config.start_on else phase >= config.off_s


def on_off_schedule(config: TrialConfig) -> list[tuple[float, float, bool]]:
    """The trial's phases as ``(start_s, end_s, on)``, in seconds from the trial's start.

    Parameters
    ----------
    config : TrialConfig

    Returns
    -------
    list of (float, float, bool)
    """
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

    During a slide the friction force has the sign of ``direction``. In the reversal that
    follows, the finger sticks and the force swings through zero to the opposite sign as
    ``cos(pi p) + r sin(pi p)`` with ``p`` going from 0 to 1 in ``reversal_s``, except that a
    person may rest at the turning point: ``p`` then stays at 1/2 for the reversal's dwell,
    while the force rests at ``r`` (a small level of either sign, the skin's relaxed shear).

    Attributes
    ----------
    slide_start, slide_end : ndarray, s
        Start and end of each slide.
    direction : ndarray of +1/-1
        Sign of the friction force during each slide.
    reversal_s : float, s
    dwell : ndarray, s
        Rest at the reversal after each slide.
    rest_level : ndarray
        ``r`` of each reversal.
    speed : ndarray, m/s
        The finger's speed during each slide.
    """

    slide_start: FloatArray
    slide_end: FloatArray
    direction: FloatArray
    reversal_s: float
    dwell: FloatArray
    rest_level: FloatArray
    speed: FloatArray

    @classmethod
    def draw(cls, subject: SubjectParams, duration_s: float, rng: np.random.Generator,
             dwell_rng: np.random.Generator | None = None,
             speed_rng: np.random.Generator | None = None) -> Strokes:
        """Strokes covering ``[0, duration_s]``, starting at a random point of a slide.

        The dwells and rest levels come from *dwell_rng* (only drawn when the subject
        dwells), the strokes' speeds from *speed_rng* (only when they differ,
        ``speed_spread > 1``), so that a subject without them gets the same strokes for a
        seed as ever. A stroke's length varies by ``stroke_jitter``; at one speed, so does
        its duration.
        """
        base = subject.stroke_length_m / subject.sliding_speed_m_s
        spread = subject.speed_spread
        shortest = base * (1 - subject.stroke_jitter) / math.sqrt(spread) + subject.reversal_s
        n = math.ceil(duration_s / shortest) + 2
        stretch = 1 + subject.stroke_jitter * rng.uniform(-1, 1, n)
        speed = np.full(n, subject.sliding_speed_m_s)
        if spread > 1:
            speed = speed * spread ** (speed_rng or rng).uniform(-0.5, 0.5, n)
        slides = stretch * subject.stroke_length_m / speed
        first = -rng.uniform(0, 1) * slides[0]
        if subject.dwell_s > 0:
            drng = dwell_rng or rng
            dwell = drng.uniform(0.0, 2.0 * subject.dwell_s, n)
            rest = drng.uniform(-DWELL_LEVEL, DWELL_LEVEL, n)
        else:
            dwell, rest = np.zeros(n), np.zeros(n)
        start = first + np.concatenate(
            [[0.0], np.cumsum(slides + subject.reversal_s + dwell)[:-1]])
        direction = np.where(np.arange(n) % 2 == 0, 1.0, -1.0) * rng.choice([-1.0, 1.0])
        return cls(start, start + slides, direction, subject.reversal_s, dwell, rest, speed)

    def index(self, t: FloatArray) -> npt.NDArray[np.intp]:
        """The slide under way at times *t* (its reversal after it included)."""
        return np.clip(np.searchsorted(self.slide_start, t, side="right") - 1, 0,
                       len(self.slide_start) - 1)

    def factor(self, t: FloatArray) -> FloatArray:
        """Signed fraction of full sliding friction at times *t* (-1 to 1)."""
        i = self.index(t)
        tau = t - self.slide_end[i]
        half = 0.5 * self.reversal_s
        dwell = self.dwell[i]
        # phase of the reversal: 0 at the slide's end, 1/2 through the dwell, 1 at the next
        p = np.where(tau <= half, tau, np.maximum(tau - dwell, half)) / self.reversal_s
        p = np.clip(p, 0.0, 1.0)
        swing = np.cos(np.pi * p) + self.rest_level[i] * np.sin(np.pi * p)
        return self.direction[i] * np.where(tau <= 0, 1.0, swing)

    def slides(self, duration_s: float) -> list[tuple[float, float, int]]:
        """Steady slides inside the trial as ``(start_s, end_s, direction)``."""
        return [(a, b, d) for a, b, d, _ in self.slides_with_speed(duration_s)]

    def slides_with_speed(self, duration_s: float) -> list[tuple[float, float, int, float]]:
        """Steady slides inside the trial as ``(start_s, end_s, direction, speed_m_s)``."""
        out = []
        for a0, b0, d, v in zip(self.slide_start, self.slide_end, self.direction, self.speed,
                                strict=True):
            a, b = max(float(a0), 0.0), min(float(b0), duration_s)
            if b > a:
                out.append((a, b, int(d), float(v)))
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


@dataclass
class Contact:
    """Whether the finger touches the screen: 1 in contact, 0 off, ramps in between.

    The finger is off for the trial's tare stretch (from the start to ``tare_s``) and during
    lift-offs. Each off-period ``(a, b)`` starts leaving contact at ``a`` (fully off at
    ``a + CONTACT_RAMP_S``) and is back in full contact at ``b`` (touching from
    ``b - CONTACT_RAMP_S``).

    Attributes
    ----------
    start, end : ndarray, s
        The off-periods, sorted and disjoint (the tare stretch's starts before 0).
    """

    start: FloatArray
    end: FloatArray

    @classmethod
    def draw(cls, subject: SubjectParams, tare_s: float, duration_s: float,
             rng: np.random.Generator) -> Contact:
        """The tare stretch, then lift-offs at the subject's rate (Poisson), each one
        ``lift_s`` long on average, at least :data:`MIN_CONTACT_S` of contact apart."""
        starts: list[float] = []
        ends: list[float] = []
        if tare_s > 0:
            starts.append(-CONTACT_RAMP_S)
            ends.append(tare_s + CONTACT_RAMP_S)
        rate = subject.lifts_per_min / 60.0
        t = (ends[-1] if ends else 0.0) + MIN_CONTACT_S
        while rate > 0:
            t += float(rng.exponential(1.0 / rate))
            if t >= duration_s:
                break
            off = subject.lift_s * float(rng.uniform(0.5, 1.5)) + 2 * CONTACT_RAMP_S
            starts.append(t)
            ends.append(t + off)
            t += off + MIN_CONTACT_S
        return cls(np.asarray(starts, dtype=np.float64), np.asarray(ends, dtype=np.float64))

    def lifted_at(self, t0: float, duration_s: float) -> Contact:
        """The same contact with the finger lifted from *t0* for *duration_s* (leaving from
        *t0*, back in full contact :data:`CONTACT_RAMP_S` after the stretch): an operator's
        tare stretch at the start of a recording. Lift-offs that overlap it are dropped."""
        a, b = t0, t0 + duration_s + 2 * CONTACT_RAMP_S
        keep = (self.end <= a) | (self.start >= b + MIN_CONTACT_S)
        start = np.append(self.start[keep], a)
        end = np.append(self.end[keep], b)
        order = np.argsort(start)
        return Contact(start[order], end[order])

    def factor(self, t: FloatArray) -> FloatArray:
        """Contact at times *t*: 1 touching, 0 off the screen, linear ramps in between."""
        t = np.asarray(t, dtype=np.float64)
        out = np.ones(t.shape)
        if self.start.size == 0:
            return out
        i = np.searchsorted(self.start, t, side="right") - 1
        inside = (i >= 0) & (t < self.end[np.clip(i, 0, None)])
        a, b = self.start[i[inside]], self.end[i[inside]]
        ti = t[inside]
        out[inside] = np.clip(np.maximum(a + CONTACT_RAMP_S - ti, ti - (b - CONTACT_RAMP_S))
                              / CONTACT_RAMP_S, 0.0, 1.0)
        return out

    def periods(self, duration_s: float) -> list[tuple[float, float]]:
        """Off-periods inside the trial as ``(start_s, end_s)``, ramps included."""
        return [(max(float(a), 0.0), min(float(b), duration_s))
                for a, b in zip(self.start, self.end, strict=True) if b > 0 and a < duration_s]

    def lifted(self, duration_s: float) -> list[tuple[float, float]]:
        """Stretches with the finger fully off the screen, as ``(start_s, end_s)``."""
        out = []
        for a, b in zip(self.start, self.end, strict=True):
            lo, hi = max(float(a) + CONTACT_RAMP_S, 0.0), min(float(b) - CONTACT_RAMP_S,
                                                              duration_s)
            if hi > lo:
                out.append((lo, hi))
        return out
