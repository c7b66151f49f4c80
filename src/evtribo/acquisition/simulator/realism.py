"""What real rigs and hands add to the ideal simulated trial, as presets.

The ideal simulated rig has load cells that read zero at zero force and a finger that slides
like a machine. A lab's rig does not: strain-gauge cells that were tared minutes earlier (or
not at all) read tens of mN at rest and drift by several mN over a trial, the bus carries
mains hum, the axes leak into each other, and a person's strokes are irregular, rest at the
reversals, and now and then the finger lifts. :func:`realistic_rig` and :func:`human` give a
trial and a subject those imperfections, drawn from a seed, within the ranges below.

================================  ==========================================================
per load cell                     zero offset uniform in +/- ``offset_N`` (default 50 mN);
                                  drift over the trial uniform in +/- ``drift_N`` (10 mN),
                                  60 % linear and 40 % a thermal settling (time constant
                                  20-60 s); mains hum of ``hum_N`` (10 mN) at ``mains_Hz``
trial                             the finger lifted for ``tare_s`` (1.5 s) at the start
person                            strokes of 4 cm at 30-60 mm/s (0.7-1.3 s), their
                                  lengths +/- 20-35 %, rests of 0.1-0.25 s on average
                                  at reversals, 2-4 lift-offs a minute of 0.3-0.5 s, a
                                  normal force wandering by 8-15 % (about +/- 0.1-0.2 N at
                                  a target of 0.5-1 N)
fingertip (:func:`real_finger`)   friction rising by 20-40 % as the contact moistens (time
                                  constant 5-10 s of contact), depending on speed
                                  (exponent 0.1-0.2, strokes' speeds spread 3x) and on
                                  direction (+/- 3-8 %), each trial's coefficient 5-10 %
                                  apart, and a friction that grows slower than the load
                                  (``F_t ~ W**m``, m 0.67-0.9)
logger (:func:`real_logger`)      1 ms of reception jitter, batches every 1 ms, a clock
                                  100 ppm off, an outage of 50 ms or so a minute
================================  ==========================================================

:func:`realistic_rig` adds, on request, cross-talk between the axes (a few %) and creep
(0.5-2 % over 1-5 s).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from evtribo.acquisition.simulator.config import SubjectParams, TrialConfig

__all__ = ["IDEAL_RIG", "IDEAL_SUBJECT", "human", "real_finger", "real_logger", "realistic_rig"]

#: The TrialConfig fields of an ideal rig (load cells exact, no tare stretch).
IDEAL_RIG = {"tare_s": 0.0, "fz_offset_N": 0.0, "fx_offset_N": 0.0, "fz_drift_N_per_s": 0.0,
             "fx_drift_N_per_s": 0.0, "fz_thermal_N": 0.0, "fx_thermal_N": 0.0,
             "fz_hum_N": 0.0, "fx_hum_N": 0.0, "crosstalk": ((1.0, 0.0), (0.0, 1.0))}
#: The SubjectParams fields of a machine-like finger (the defaults).
IDEAL_SUBJECT = {"stroke_jitter": 0.1, "dwell_s": 0.0, "lifts_per_min": 0.0,
                 "force_drift": 0.05}

# random streams of the presets, apart from the simulator's own
_S_RIG, _S_PERSON, _S_FINGER, _S_LOGGER, _S_CREEP = 2001, 2002, 2003, 2004, 2005


def realistic_rig(config: TrialConfig, *, offset_N: float = 0.05, drift_N: float = 0.01,
                  hum_N: float = 0.01, mains_Hz: float = 50.0, tare_s: float = 1.5,
                  crosstalk: float | None = None, trial_s: float | None = None,
                  seed: int | None = None, creep: bool = False) -> TrialConfig:
    """*config* with a real rig's load cells: offsets, drift, hum, (cross-talk), a tare stretch.

    Parameters
    ----------
    config : TrialConfig
        The trial; its other settings are kept.
    offset_N : float, N
        Each cell's zero offset is drawn uniformly in ``[-offset_N, offset_N]``.
    drift_N : float, N
        Each cell's zero moves by a total drawn uniformly in ``[-drift_N, drift_N]`` over
        *trial_s*: 60 % of it linearly, 40 % as a thermal settling.
    hum_N : float, N
        Amplitude of the mains hum on each cell.
    mains_Hz : float, Hz
        50 or 60.
    tare_s : float, s
        Finger lifted at the start of the trial (at most half the trial).
    crosstalk : float, optional
        Each off-diagonal term of the cross-talk matrix is drawn uniformly in
        ``[-crosstalk, crosstalk]`` (default: the trial's own matrix is kept; a rig's
        cross-talk is the rig's, not the trial's).
    trial_s : float, s, optional
        The time over which *drift_N* accrues (default: the trial's duration; give it for
        a stream of open-ended length).
    seed : int, optional
        Seed of the draws (default: the trial's seed).
    creep : bool
        The cells creep: 0.5-2 % of a change of load, over 1-5 s.

    Returns
    -------
    TrialConfig
    """
    rng = np.random.default_rng([config.seed if seed is None else seed, _S_RIG])
    if creep:
        crng = np.random.default_rng([config.seed if seed is None else seed, _S_CREEP])
        config = dataclasses.replace(config, creep=round(float(crng.uniform(0.005, 0.02)), 4),
                                     creep_time_s=round(float(crng.uniform(1.0, 5.0)), 2))
    span = float(trial_s or config.duration_s)
    offsets = rng.uniform(-offset_N, offset_N, 2)
    drifts = rng.uniform(-drift_N, drift_N, 2)
    tau = float(rng.uniform(20.0, 60.0))
    settle = -math.expm1(-span / tau)
    off_diag = rng.uniform(-(crosstalk or 0.0), crosstalk or 0.0, 2)
    matrix = config.crosstalk if crosstalk is None else (
        (1.0, float(off_diag[0])), (float(off_diag[1]), 1.0))
    return dataclasses.replace(
        config,
        tare_s=min(tare_s, 0.5 * config.duration_s),
        fz_offset_N=float(offsets[0]), fx_offset_N=float(offsets[1]),
        fz_drift_N_per_s=float(0.6 * drifts[0] / span),
        fx_drift_N_per_s=float(0.6 * drifts[1] / span),
        fz_thermal_N=float(0.4 * drifts[0] / settle),
        fx_thermal_N=float(0.4 * drifts[1] / settle),
        thermal_time_s=tau, fz_hum_N=hum_N, fx_hum_N=hum_N, mains_Hz=mains_Hz,
        crosstalk=matrix)


def human(subject: SubjectParams, seed: int = 0) -> SubjectParams:
    """*subject* with a person's strokes: about a second each, irregular, resting at reversals,
    lifting now and then, pressing with a force that wanders (drawn with *seed*; μ, air gap
    and target kept).

    Parameters
    ----------
    subject : SubjectParams
    seed : int

    Returns
    -------
    SubjectParams
    """
    rng = np.random.default_rng([seed, _S_PERSON])
    return dataclasses.replace(
        subject,
        stroke_length_m=0.04,
        sliding_speed_m_s=round(float(rng.uniform(0.03, 0.06)), 4),
        stroke_jitter=round(float(rng.uniform(0.2, 0.35)), 3),
        dwell_s=round(float(rng.uniform(0.1, 0.25)), 3),
        lifts_per_min=round(float(rng.uniform(2.0, 4.0)), 2),
        lift_s=round(float(rng.uniform(0.3, 0.5)), 3),
        force_drift=round(float(rng.uniform(0.08, 0.15)), 3))


def real_finger(subject: SubjectParams, seed: int = 0, *, moisture: bool = True,
                speed: bool = True, direction: bool = True, trials: bool = True,
                load: bool = True) -> SubjectParams:
    """*subject* with a real fingertip's friction (:mod:`~evtribo.acquisition.simulator.
    finger`), drawn with *seed*; each effect can be left out.

    Parameters
    ----------
    subject : SubjectParams
    seed : int
    moisture : bool
        Friction rising by 20-40 % as the contact moistens, time constant 5-10 s.
    speed : bool
        Friction ~ speed**(0.1-0.2), the strokes' speeds spread over a factor of 3.
    direction : bool
        Forward and backward strokes 3-8 % apart (either way).
    trials : bool
        Each trial's coefficient 5-10 % (standard deviation) apart.
    load : bool
        Friction ``F_t ~ W**m`` of the load ``W = F_n + F_el``, ``m`` drawn in 0.67-0.9
        (a soft Hertzian contact, Adams et al. 2013).

    Returns
    -------
    SubjectParams
    """
    rng = np.random.default_rng([seed, _S_FINGER])
    draws = rng.uniform(0.0, 1.0, 7)
    changes: dict[str, Any] = {}
    if moisture:
        changes.update(moisture_rise=round(0.2 + 0.2 * float(draws[0]), 3),
                       moisture_time_s=round(5.0 + 5.0 * float(draws[1]), 2))
    if speed:
        changes.update(speed_exponent=round(0.1 + 0.1 * float(draws[2]), 3), speed_spread=3.0)
    if direction:
        sign = 1.0 if draws[3] < 0.5 else -1.0
        changes.update(direction_asymmetry=round(sign * (0.03 + 0.05 * float(draws[4])), 4))
    if trials:
        changes.update(mu_trial_spread=round(0.05 + 0.05 * float(draws[5]), 3))
    if load:
        changes.update(friction_exponent=round(0.67 + 0.23 * float(draws[6]), 3))
    return dataclasses.replace(subject, **changes)


def real_logger(config: TrialConfig, seed: int | None = None, *, jitter_s: float = 1e-3,
                burst_s: float = 1e-3, ppm: float = 100.0, outages_per_min: float = 1.0
                ) -> TrialConfig:
    """*config* with a logger as labs have them: late frames, batches, its own clock, an
    outage now and then (the clock's sign drawn with *seed*, default the trial's).

    Parameters
    ----------
    config : TrialConfig
    seed : int, optional
    jitter_s : float, s
        Mean reception jitter.
    burst_s : float, s
        Batch period of the adapter.
    ppm : float, ppm
        Size of the logger's clock error.
    outages_per_min : float, 1/min

    Returns
    -------
    TrialConfig
    """
    rng = np.random.default_rng([config.seed if seed is None else seed, _S_LOGGER])
    sign = 1.0 if rng.uniform() < 0.5 else -1.0
    return dataclasses.replace(config, jitter_s=jitter_s, burst_s=burst_s,
                               logger_ppm=sign * ppm, outages_per_min=outages_per_min)
