"""What the simulated rig is asked to do: the subject, and the trial's settings."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field, fields
from typing import Any, cast

from evtribo.errors import ConfigError
from evtribo.model import TABLE_1

__all__ = ["CONDITIONS", "WAVEFORMS", "SubjectParams", "TrialConfig"]

WAVEFORMS = ("sine", "square")
CONDITIONS = ("on", "off", "alternating")


def _check_positive(obj: object, names: tuple[str, ...], *, allow_zero: bool = False) -> None:
    for name in names:
        value = getattr(obj, name)
        bad = not isinstance(value, int | float) or not math.isfinite(value)
        bad = bad or (value < 0 if allow_zero else value <= 0)
        if bad:
            what = "a finite number >= 0" if allow_zero else "a finite number > 0"
            raise ConfigError(f"{value!r} is not allowed: must be {what}",
                              key=f"{type(obj).__name__}.{name}")


def _check_finite(obj: object, name: str) -> None:
    value = getattr(obj, name)
    if isinstance(value, bool) or not isinstance(value, int | float) \
            or not math.isfinite(value):
        raise ConfigError(f"{value!r} is not allowed: must be a finite number",
                          key=f"{type(obj).__name__}.{name}")


def _matrix(value: object) -> tuple[tuple[float, float], tuple[float, float]]:
    """A 2x2 matrix of finite numbers, as nested tuples, invertible."""
    key = "TrialConfig.crosstalk"
    try:
        # anything: what is not rows of numbers raises TypeError or ValueError, reported
        rows = [[float(x) for x in row] for row in cast("Iterable[Iterable[Any]]", value)]
    except (TypeError, ValueError) as err:
        raise ConfigError(f"{value!r} is not allowed: must be a 2x2 matrix of numbers",
                          key=key) from err
    if len(rows) != 2 or any(len(r) != 2 for r in rows) \
            or not all(math.isfinite(x) for r in rows for x in r):
        raise ConfigError(f"{value!r} is not allowed: must be a 2x2 matrix of finite numbers",
                          key=key)
    det = rows[0][0] * rows[1][1] - rows[0][1] * rows[1][0]
    if abs(det) < 1e-6:
        raise ConfigError(f"{value!r} is not allowed: the matrix is singular", key=key)
    return (rows[0][0], rows[0][1]), (rows[1][0], rows[1][1])


@dataclass(frozen=True)
class SubjectParams:
    """A simulated subject: their skin, their finger's motion and how steadily they press.

    Attributes
    ----------
    name : str
        Subject name (``P01``).
    mu : float
        Coulomb friction coefficient of the finger on the screen.
    h_L : float, m
        Equivalent air gap of the seed paper's capacitor model (Table 1: 5e-6 m).
    normal_force_N : float, N
        The force the subject aims to hold.
    force_drift : float
        Standard deviation of the slow wander of the normal force, relative to the target
        (an Ornstein-Uhlenbeck process; 0.05 = 5 %). A faster, smaller wobble with a quarter
        of this deviation and a 0.1 s time constant rides on top.
    drift_time_s : float, s
        Correlation time of the slow wander.
    sliding_speed_m_s : float, m/s
        Finger speed while sliding.
    stroke_length_m : float, m
        Length of one stroke between reversals.
    reversal_s : float, s
        Duration of a reversal: the finger sticks and the friction force swings through
        zero to the opposite sign.
    stroke_jitter : float
        Relative spread of stroke durations, from stroke to stroke (uniform, +/-): a person's
        strokes differ in length and speed.
    dwell_s : float, s
        Mean time the finger rests at a reversal before sliding back (each dwell drawn
        uniformly from 0 to twice this); 0 for a reversal without rest. While it rests the
        friction force relaxes towards a small value of either sign.
    lifts_per_min : float, 1/min
        Rate of lift-offs (Poisson): the finger leaves the screen, normal and friction force
        fall to zero, and it comes back down.
    lift_s : float, s
        Mean duration of a lift-off with the finger fully off (each drawn uniformly from
        half to one and a half times this), plus :data:`~evtribo.acquisition.simulator.
        physics.CONTACT_RAMP_S` to leave and to come back.
    moisture_rise : float
        Relative rise of the friction coefficient as the fingertip's contact moistens,
        once saturated (0.3: 30 % higher; 0: a dry, constant finger). Each trial starts dry.
    moisture_time_s : float, s
        Time constant of that rise, in time of contact.
    speed_exponent : float
        ``beta`` of a friction coefficient that depends on the sliding speed,
        ``mu * (v / sliding_speed_m_s)**beta`` (0: none).
    speed_spread : float
        Ratio of the fastest to the slowest stroke's speed (each stroke's speed drawn
        log-uniformly about ``sliding_speed_m_s``; 1: every stroke at that speed, its
        length varying with ``stroke_jitter``).
    direction_asymmetry : float
        Forward strokes have ``mu * (1 + a)``, backward ones ``mu * (1 - a)``.
    mu_trial_spread : float
        Relative standard deviation of each trial's friction coefficient about ``mu`` (the
        skin's state differs between trials; 0: the same in every trial).
    friction_exponent : float
        ``m`` of the friction's dependence on the load ``W = F_n + F_el``:
        ``F_t = mu * W_0 * (W / W_0)**m`` with ``W_0 = normal_force_N`` (``mu`` is the
        coefficient at the target press). 1: Amontons-Coulomb friction; a finger pad on
        glass, a soft Hertzian contact, has about 0.67-0.9 (Adams et al. 2013).
    model : dict
        Other parameters of the model for this subject (``ModelParameters`` names, SI
        units), e.g. ``{"r_g": 80.0}``: a gap that leaks, so that the force depends on the
        drive's frequency.
    """

    name: str = "P01"
    mu: float = 0.5
    h_L: float = 5e-6
    normal_force_N: float = 0.5
    force_drift: float = 0.05
    drift_time_s: float = 1.5
    sliding_speed_m_s: float = 0.02
    stroke_length_m: float = 0.04
    reversal_s: float = 0.15
    stroke_jitter: float = 0.1
    dwell_s: float = 0.0
    lifts_per_min: float = 0.0
    lift_s: float = 0.4
    moisture_rise: float = 0.0
    moisture_time_s: float = 8.0
    speed_exponent: float = 0.0
    speed_spread: float = 1.0
    direction_asymmetry: float = 0.0
    mu_trial_spread: float = 0.0
    friction_exponent: float = 1.0
    model: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        _check_positive(self, ("mu", "h_L", "normal_force_N", "drift_time_s",
                               "sliding_speed_m_s", "stroke_length_m", "reversal_s", "lift_s",
                               "moisture_time_s"))
        _check_positive(self, ("force_drift", "stroke_jitter", "dwell_s", "lifts_per_min",
                               "moisture_rise", "mu_trial_spread"), allow_zero=True)
        _check_finite(self, "speed_exponent")
        if not (isinstance(self.speed_spread, int | float) and self.speed_spread >= 1):
            raise ConfigError(f"{self.speed_spread!r} is not allowed: must be >= 1",
                              key="SubjectParams.speed_spread")
        if not (isinstance(self.direction_asymmetry, int | float)
                and abs(self.direction_asymmetry) < 0.5):
            raise ConfigError(f"{self.direction_asymmetry!r} is not allowed: |a| < 0.5",
                              key="SubjectParams.direction_asymmetry")
        if not (isinstance(self.friction_exponent, int | float)
                and 0.3 <= self.friction_exponent <= 1.5):
            raise ConfigError(f"{self.friction_exponent!r} is not allowed: must be between "
                              "0.3 and 1.5", key="SubjectParams.friction_exponent")
        if self.mu_trial_spread >= 0.5:
            raise ConfigError(f"{self.mu_trial_spread!r} is not allowed: must be < 0.5",
                              key="SubjectParams.mu_trial_spread")
        if self.stroke_jitter >= 1:
            raise ConfigError(f"{self.stroke_jitter!r} is not allowed: must be < 1",
                              key="SubjectParams.stroke_jitter")
        reserved = {"mu", "h_L"} & set(self.model)
        if reserved:
            raise ConfigError(f"{sorted(reserved)[0]} is a subject's own parameter, not one "
                              "of its model's", key=f"SubjectParams.model.{sorted(reserved)[0]}")
        try:  # every name and value checked by the model's own parameters
            TABLE_1.with_values(dict(self.model))
        except ConfigError as err:
            raise ConfigError(err.message, key=f"SubjectParams.model.{err.key}") from err
        object.__setattr__(self, "model", {k: float(v) for k, v in self.model.items()})

    def to_dict(self) -> dict[str, Any]:
        """The parameters as a JSON-ready mapping (an infinite value as the text "inf")."""
        out = asdict(self)
        out["model"] = {k: v if math.isfinite(v) else str(v) for k, v in self.model.items()}
        return out


@dataclass(frozen=True)
class TrialConfig:
    """One simulated trial: excitation, schedule, the rig's nodes and imperfections.

    Attributes
    ----------
    duration_s : float, s
        Length of the trial.
    waveform : {"sine", "square"}
    frequency_Hz : float, Hz
        Frequency of the applied voltage.
    amplitude_V : float, V
        Amplitude of the applied voltage.
    condition : {"on", "off", "alternating"}
        Voltage on or off for the whole trial, or switched on and off periodically.
    on_s, off_s : float, s
        Lengths of the ON and OFF phases when alternating.
    start_on : bool
        Whether an alternating trial starts with an ON phase.
    fz_rate_Hz, fx_rate_Hz : float, Hz
        Nominal sample rates of the normal (FzCell) and tangential (FxCell) load cells.
    fz_ppm, fx_ppm, hv_ppm : float, ppm
        Clock errors of the nodes: a node with +100 ppm samples 100e-6 faster than nominal.
    hv_rate_Hz : float, Hz
        Rate of the amplifier's HvStatus frames.
    noise_N : float, N
        Standard deviation of the load cells' white noise.
    latency_s, jitter_s : float, s
        Fixed reception delay and mean of the (exponential) reception jitter.
    drop_probability : float
        Probability that any rig frame is lost (a gap in its counter).
    foreign_rate_Hz : float, Hz
        Rate of frames from other nodes on the bus (ids the rig does not describe).
    tare_s : float, s
        The finger is off the screen for this long at the start of the trial (the tare
        stretch an operator asks for), then comes down and starts sliding.
    fz_offset_N, fx_offset_N : float, N
        Zero offset of each load cell at the trial's start: what it reads with no force.
    fz_drift_N_per_s, fx_drift_N_per_s : float, N/s
        Linear drift of each cell's zero.
    fz_thermal_N, fx_thermal_N : float, N
        Slow thermal drift of each cell's zero: ``A * (1 - exp(-t / thermal_time_s))``.
    thermal_time_s : float, s
        Time constant of the thermal drift.
    fz_hum_N, fx_hum_N : float, N
        Amplitude of the mains hum each cell picks up (a sine at ``mains_Hz``, with a
        phase of its own, plus a third harmonic of a fifth of it).
    mains_Hz : float, Hz
        Mains frequency (50 or 60).
    creep : float
        Creep of both strain-gauge cells: after a change of load a cell's reading approaches
        the new load by this fraction of the change over ``creep_time_s`` (0.01: it first
        reads 1 % short of the change, then creeps towards it).
    creep_time_s : float, s
        Time constant of the creep.
    logger_ppm : float, ppm
        Clock error of the logger that timestamps the frames (its seconds are this much
        longer than true ones).
    burst_s : float, s
        The adapter delivers the frames in batches, this often (a USB adapter polled every
        millisecond): each frame is stamped when its batch arrives (0: frame by frame).
    spike_rate_Hz : float, Hz
        Rate of single-sample spikes on each cell (electrical interference).
    spike_N : float, N
        Their size: each spike adds a value drawn uniformly in ``+/- spike_N``.
    outages_per_min : float, 1/min
        Rate of outages (Poisson) in which every frame is lost (a USB adapter resetting).
    press_only : bool
        A calibration recording: after the tare stretch the finger presses without
        sliding, its force swelling from 40 % to 160 % of the target and back every
        :data:`~evtribo.acquisition.simulator.finger.PRESS_PERIOD_S` seconds.
    outage_s : float, s
        Mean length of an outage (each drawn from half to one and a half times this).
    crosstalk : ((float, float), (float, float))
        The cells' axis cross-talk: ``[Fn, Ft]_measured = crosstalk @ [Fn, Ft]_true`` (plus
        the offsets); its inverse is the ``[rig.calibration] matrix`` that undoes it.
    start_time : float, s
        Epoch time of the trial's start, for the frames' timestamps.
    channel : str
        Channel name given to the frames (``vcan0``).
    seed : int
        Seed of every random draw: the same seed gives the same frames.
    """

    duration_s: float = 30.0
    waveform: str = "square"
    frequency_Hz: float = 10_000.0
    amplitude_V: float = 140.0
    condition: str = "alternating"
    on_s: float = 2.0
    off_s: float = 2.0
    start_on: bool = False
    fz_rate_Hz: float = 1000.0
    fx_rate_Hz: float = 2000.0
    hv_rate_Hz: float = 50.0
    fz_ppm: float = 40.0
    fx_ppm: float = -25.0
    hv_ppm: float = 150.0
    noise_N: float = 1e-3
    latency_s: float = 2e-4
    jitter_s: float = 5e-5
    drop_probability: float = 0.0
    foreign_rate_Hz: float = 0.0
    tare_s: float = 0.0
    fz_offset_N: float = 0.0
    fx_offset_N: float = 0.0
    fz_drift_N_per_s: float = 0.0
    fx_drift_N_per_s: float = 0.0
    fz_thermal_N: float = 0.0
    fx_thermal_N: float = 0.0
    thermal_time_s: float = 60.0
    fz_hum_N: float = 0.0
    fx_hum_N: float = 0.0
    mains_Hz: float = 50.0
    creep: float = 0.0
    creep_time_s: float = 3.0
    logger_ppm: float = 0.0
    burst_s: float = 0.0
    spike_rate_Hz: float = 0.0
    spike_N: float = 0.0
    outages_per_min: float = 0.0
    outage_s: float = 0.05
    press_only: bool = False
    crosstalk: tuple[tuple[float, float], tuple[float, float]] = ((1.0, 0.0), (0.0, 1.0))
    start_time: float = 1_763_700_000.0
    channel: str = "vcan0"
    seed: int = 0

    def __post_init__(self) -> None:
        if self.waveform not in WAVEFORMS:
            raise ConfigError(f"{self.waveform!r} is not allowed: choose one of {WAVEFORMS}",
                              key="TrialConfig.waveform")
        if self.condition not in CONDITIONS:
            raise ConfigError(f"{self.condition!r} is not allowed: choose one of {CONDITIONS}",
                              key="TrialConfig.condition")
        _check_positive(self, ("duration_s", "frequency_Hz", "on_s", "off_s", "fz_rate_Hz",
                               "fx_rate_Hz", "hv_rate_Hz"))
        _check_positive(self, ("amplitude_V", "noise_N", "latency_s", "jitter_s",
                               "foreign_rate_Hz", "drop_probability", "tare_s", "fz_hum_N",
                               "fx_hum_N", "creep", "burst_s", "spike_rate_Hz", "spike_N",
                               "outages_per_min"), allow_zero=True)
        _check_positive(self, ("thermal_time_s", "mains_Hz", "creep_time_s", "outage_s"))
        _check_finite(self, "logger_ppm")
        if self.creep >= 0.5 or abs(self.logger_ppm) >= 1e5:
            name = "creep" if self.creep >= 0.5 else "logger_ppm"
            raise ConfigError(f"{getattr(self, name)!r} is not allowed: "
                              + ("must be < 0.5" if name == "creep" else "|ppm| < 1e5"),
                              key=f"TrialConfig.{name}")
        for name in ("fz_offset_N", "fx_offset_N", "fz_drift_N_per_s", "fx_drift_N_per_s",
                     "fz_thermal_N", "fx_thermal_N"):
            _check_finite(self, name)
        if self.tare_s >= self.duration_s:
            raise ConfigError(f"{self.tare_s!r} is not allowed: the tare stretch must be "
                              f"shorter than the trial ({self.duration_s:g} s)",
                              key="TrialConfig.tare_s")
        object.__setattr__(self, "crosstalk", _matrix(self.crosstalk))
        if self.drop_probability >= 1:
            raise ConfigError(f"{self.drop_probability!r} is not allowed: must be < 1",
                              key="TrialConfig.drop_probability")
        for name in ("fz_ppm", "fx_ppm", "hv_ppm"):
            if abs(getattr(self, name)) >= 1e5:
                raise ConfigError(f"{getattr(self, name)!r} is not allowed: |ppm| < 1e5",
                                  key=f"TrialConfig.{name}")

    def to_dict(self) -> dict[str, Any]:
        """The settings as a JSON-ready mapping."""
        return {f.name: getattr(self, f.name) for f in fields(self)}
