"""The parameters of a generated study: one frozen dataclass per group of effects.

Every effect can be switched off (its size 0, or its range ``(0, 0)``) and its size is a
parameter. Ranges ``(lo, hi)`` are drawn uniformly per subject or per trial, as each field
says. The defaults are the "lab-like clean" study of README.md: a careful lab's rig and
participants, Amontons friction, no moisture or speed effect, the load cells' offsets,
drift, hum and noise, and a logger with its own clock and jitter.
"""

from __future__ import annotations

from dataclasses import dataclass, field

Range = tuple[float, float]


@dataclass(frozen=True)
class Friction:
    """The finger pad's friction, F_t = c·W^m (Adams et al. 2013), and what modulates it."""

    mu: Range = (0.4, 0.6)            # a subject's μ at W = f_ref_N (drawn per subject)
    m: float = 1.0                    # load exponent; 1 is Amontons, 0.67 a dry Hertzian pad
    f_ref_N: float = 0.5              # load at which c·W^m / W equals mu
    trial_spread: float = 0.05        # log-sd of μ between a subject's trials
    stroke_scatter: float = 0.01      # sd of a per-stroke multiplicative factor
    texture_noise: float = 0.005      # relative rms of the fast fluctuation within a stroke
    speed_exponent: float = 0.0       # μ ∝ (v / v_ref)^β (0.15 in the speed scenario)
    v_ref_m_s: float = 0.05
    direction_asymmetry: float = 0.0  # forward μ / backward μ - 1 (drawn ± per subject)
    moisture_rise: Range = (0.0, 0.0)  # first-order rise of μ, relative, drawn per trial
    moisture_tau_s: Range = (5.0, 9.0)  # its time constant, drawn per trial
    trend_per_10s: float = 0.0        # linear rise of μ per 10 s of contact, relative
    presliding_m: float = 0.5e-3      # Dahl displacement of the pad at a reversal, m


@dataclass(frozen=True)
class Electrostatic:
    """The electrostatic force: the seed paper's model or a power law per subject."""

    model: str = "paper"              # "paper" (eqs. 3, 8, 9, 11) or "power" (k·U^n)
    h_L_median_m: float = 5e-6        # the equivalent air gap, log-normal between subjects
    h_L_log_sd: float = 0.25
    force_at_140V_N: float = 0.15     # power law: median F_el at 140 V
    force_log_sd: float = 0.4         # power law: log-sd of k between subjects
    n_mean: float = 2.0               # power law: mean exponent
    n_sd: float = 0.0                 # power law: sd of the exponent between subjects
    weak_share: float = 0.0           # share of subjects who respond weakly
    weak_factor: Range = (0.04, 0.12)  # their force relative to their drawn one
    # Table 1 of the seed paper
    R_m: float = 0.01
    E_star_Pa: float = 40e3
    eps_sc: float = 1650.0
    eps_i: float = 3.35
    eps_L: float = 1.0
    h_sc_m: float = 300e-6
    h_i_m: float = 1e-6


@dataclass(frozen=True)
class Press:
    """The pressing force: held in a band, wandering, swept, or at protocol targets."""

    mode: str = "band"                # "band" | "walk" | "sweep" | "targets"
    target_N: float = 0.5
    band_N: float = 0.15              # band mode: ~3 sd of the tracking error
    tau_s: float = 0.5                # correlation time of the tracking error
    range_N: Range = (0.2, 1.0)       # walk and sweep modes
    walk_traverse_s: float = 10.0     # walk: time to wander across the range (diffusion)
    sweep_period_s: float = 8.0
    targets_N: tuple[float, ...] = (0.3, 0.6, 0.9)  # targets mode: one per ON/OFF pair


@dataclass(frozen=True)
class Strokes:
    """The finger's back-and-forth strokes."""

    duration_s: Range = (0.9, 1.4)    # per stroke, drawn uniformly (0.6-2.4 s irregular)
    travel_m: Range = (0.04, 0.07)
    ramp_s: float = 0.12              # raised-cosine speed-up and slow-down
    dwell_s: Range = (0.0, 0.08)      # pause at a reversal
    speed_wobble: float = 0.05        # relative slow speed variation within a stroke
    lifts_per_min: float = 0.0        # lift-offs of the finger after the tare stretch
    lift_s: Range = (0.4, 0.8)


@dataclass(frozen=True)
class Drive:
    """The amplifier: amplitudes, waveform, the ON/OFF schedule and how it is told."""

    amplitudes_V: tuple[float, ...] = (60.0, 80.0, 100.0, 120.0, 140.0)
    waveform: str = "square"          # "square" or "sine"
    frequency_Hz: float = 10000.0
    phase_s: float = 2.0              # length of each ON and each OFF phase
    phase_jitter: float = 0.0         # relative jitter of each phase's length
    signal: str = "can"               # "can": status in a CAN message; "sidecar": on/off trials
    status_rate_Hz: float = 20.0


@dataclass(frozen=True)
class Cells:
    """Load-cell realities (each cell its own draw, per trial)."""

    tare_s: float = 1.5               # finger lifted at the trial's start
    offset_N: float = 0.03            # zero offsets, uniform in ±
    drift_N: float = 0.003            # change of the zero over a trial, uniform in ±
    hum_N: float = 0.003              # mains hum amplitude
    mains_Hz: float = 50.0
    noise_N: float = 0.001            # white noise rms per sample
    crosstalk: float = 0.0            # off-diagonal share, uniform in ± per rig
    calibration_in_toml: bool = False  # write the cross-talk matrix into [rig.calibration]
    creep: float = 0.0                # share of a load change crept in over creep_tau_s
    creep_tau_s: float = 3.0


@dataclass(frozen=True)
class Logger:
    """The CAN nodes' clocks and the logger's timestamps."""

    rates_Hz: tuple[float, float] = (1000.0, 1000.0)  # normal cell, tangential cell
    clock_ppm: float = 50.0           # each node's clock error, uniform in ±
    jitter_s: Range = (0.0001, 0.0005)  # per trial: the frames' delay, uniform in [0, j]
    batch_s: float = 0.0              # USB adapter delivering frames every batch_s (0: each)
    drop_rate: float = 0.0            # share of load-cell frames lost
    foreign_rate_Hz: float = 1.0      # a heartbeat the DBC does not describe


@dataclass(frozen=True)
class StudyConfig:
    """A whole study: its size and every group of effects."""

    name: str = "clean"
    subjects: int = 3
    trial_s: float = 16.0
    repetitions: int = 1              # trials per amplitude
    friction: Friction = field(default_factory=Friction)
    electrostatic: Electrostatic = field(default_factory=Electrostatic)
    press: Press = field(default_factory=Press)
    strokes: Strokes = field(default_factory=Strokes)
    drive: Drive = field(default_factory=Drive)
    cells: Cells = field(default_factory=Cells)
    logger: Logger = field(default_factory=Logger)
    grid_s: float = 0.001             # the physics' time step
