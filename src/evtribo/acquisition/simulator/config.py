"""What the simulated rig is asked to do: the subject, and the trial's settings."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any

from evtribo.errors import ConfigError

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
        Relative spread of stroke durations (uniform, +/-).
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

    def __post_init__(self) -> None:
        _check_positive(self, ("mu", "h_L", "normal_force_N", "drift_time_s",
                               "sliding_speed_m_s", "stroke_length_m", "reversal_s"))
        _check_positive(self, ("force_drift", "stroke_jitter"), allow_zero=True)
        if self.stroke_jitter >= 1:
            raise ConfigError(f"{self.stroke_jitter!r} is not allowed: must be < 1",
                              key="SubjectParams.stroke_jitter")

    def to_dict(self) -> dict[str, Any]:
        """The parameters as a JSON-ready mapping."""
        return asdict(self)


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
                               "foreign_rate_Hz", "drop_probability"), allow_zero=True)
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
