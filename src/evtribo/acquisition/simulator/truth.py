"""What the analysis of a simulated trial should recover: the truth record of a trial."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from evtribo.acquisition.simulator.config import SubjectParams, TrialConfig

__all__ = ["FEL_BIN_S", "TrialTruth"]

#: Bins of the electrostatic-force record of the truth (see TrialTruth.electrostatic_between), s.
FEL_BIN_S = 0.01


@dataclass
class TrialTruth:
    """What the analysis of a simulated trial should recover.

    Attributes
    ----------
    subject : SubjectParams
    config : TrialConfig
    schedule : list of (start_s, end_s, on)
        The voltage's ON/OFF phases, s from the trial's start.
    slides : list of (start_s, end_s, direction)
        Steady slides between reversals (direction: sign of the friction force).
    normal_force_on_N, normal_force_off_N : float or None, N
        Mean of the true (noise-free) normal force over the normal cell's samples while ON
        and while OFF (None if there was no such phase).
    electrostatic_force_N : float or None, N
        The model's electrostatic force at the realised ``normal_force_on_N`` and the trial's
        amplitude (period-averaged for a sine): what ``electrostatic.csv`` should infer.
    electrostatic_force_mean_N : float or None, N
        Mean of the instantaneous electrostatic force over the tangential cell's ON samples.
    friction_modulation_Hz : float or None, Hz
        Twice the drive frequency for a sine trial with ON phases, else None.
    nodes : dict
        Per message: effective rate (Hz), clock offset (s), frames sent, frames dropped.
    foreign_frames : int
        Frames of other nodes.
    lifted : list of (start_s, end_s)
        Stretches with the finger fully off the screen (the tare stretch, lift-offs).
    contact_lost : list of (start_s, end_s)
        The same, widened by the time the finger takes to leave and to come back.
    steady : list of (start_s, end_s, direction, on)
        Steady sliding in one condition: the slides, less the lift-offs, cut at the
        voltage's switches.
    cells : dict
        Per cell (``"normal"``, ``"tangential"``): the zero offset at the start, its drift,
        thermal term and hum (N, N/s, s, Hz) and ``mean_offset_N``, the zero's mean over
        the trial (what ``trials.csv`` reports as removed).
    crosstalk : list of list of float
        ``[Fn, Ft]_measured = crosstalk @ [Fn, Ft]_true`` (+ the zeros).
    calibration_matrix : list of list of float
        Its inverse: the ``[rig.calibration] matrix`` that undoes it.
    first_frame_s : float or None, s
        Reception time of the trial's first frame, from the trial's start: the analysis
        counts its windows' times from there.
    slide_speeds_m_s : list of float, m/s
        The finger's speed in each of :attr:`slides`.
    friction : dict
        The trial's friction law (:class:`~evtribo.acquisition.simulator.finger.
        SimulatedFriction`'s fields: ``mu0``, moisture, speed and direction terms, the load's
        ``exponent`` and ``reference_load_N``).
    outages : list of (start_s, end_s)
        Periods in which the logger received nothing.
    """

    subject: SubjectParams
    config: TrialConfig
    schedule: list[tuple[float, float, bool]]
    slides: list[tuple[float, float, int]]
    normal_force_on_N: float | None = None
    normal_force_off_N: float | None = None
    electrostatic_force_N: float | None = None
    electrostatic_force_mean_N: float | None = None
    friction_modulation_Hz: float | None = None
    nodes: dict[str, dict[str, float]] = field(default_factory=dict)
    foreign_frames: int = 0
    lifted: list[tuple[float, float]] = field(default_factory=list)
    contact_lost: list[tuple[float, float]] = field(default_factory=list)
    steady: list[tuple[float, float, int, bool]] = field(default_factory=list)
    cells: dict[str, dict[str, float]] = field(default_factory=dict)
    crosstalk: list[list[float]] = field(default_factory=list)
    calibration_matrix: list[list[float]] = field(default_factory=list)
    first_frame_s: float | None = None
    fel_sum: npt.NDArray[np.float64] | None = field(default=None, repr=False)
    fel_count: npt.NDArray[np.int64] | None = field(default=None, repr=False)
    slide_speeds_m_s: list[float] = field(default_factory=list)
    friction: dict[str, float] = field(default_factory=dict)
    outages: list[tuple[float, float]] = field(default_factory=list)
    mu_sum: npt.NDArray[np.float64] | None = field(default=None, repr=False)

    @property
    def mu(self) -> float:
        """The subject's friction coefficient."""
        return self.subject.mu

    def electrostatic_between(self, t0: float, t1: float) -> float:
        """Mean of the electrostatic force over the tangential cell's samples in
        ``[t0, t1)`` (s from the trial's start, to :data:`FEL_BIN_S`), N; NaN without
        samples or without the record (only offline trials keep it)."""
        return self._between(self.fel_sum, t0, t1)

    def mu_between(self, t0: float, t1: float) -> float:
        """Mean of the finger's friction coefficient over the tangential cell's samples in
        ``[t0, t1)`` (as :meth:`electrostatic_between`): the ratio ``F_t / F_n`` the finger
        would give without the voltage at the press of each instant (``mu`` itself with
        Amontons friction; ``mu * (F_n / W_0)**(m - 1)`` with the law ``F_t ~ W**m``)."""
        return self._between(self.mu_sum, t0, t1)

    def _between(self, sums: npt.NDArray[np.float64] | None, t0: float, t1: float) -> float:
        if sums is None or self.fel_count is None:
            return float("nan")
        b0 = max(round(t0 / FEL_BIN_S), 0)
        b1 = min(round(t1 / FEL_BIN_S), sums.size)
        n = int(self.fel_count[b0:b1].sum())
        return float(sums[b0:b1].sum() / n) if n else float("nan")

    def to_dict(self) -> dict[str, Any]:
        """The truth as a JSON-ready mapping."""
        return {
            "subject": self.subject.to_dict(), "config": self.config.to_dict(),
            "mu": self.mu,
            "schedule": [[a, b, on] for a, b, on in self.schedule],
            "slides": [[a, b, d] for a, b, d in self.slides],
            "normal_force_on_N": self.normal_force_on_N,
            "normal_force_off_N": self.normal_force_off_N,
            "electrostatic_force_N": self.electrostatic_force_N,
            "electrostatic_force_mean_N": self.electrostatic_force_mean_N,
            "friction_modulation_Hz": self.friction_modulation_Hz,
            "nodes": self.nodes, "foreign_frames": self.foreign_frames,
            "lifted": [[a, b] for a, b in self.lifted],
            "contact_lost": [[a, b] for a, b in self.contact_lost],
            "steady": [[a, b, d, on] for a, b, d, on in self.steady],
            "cells": self.cells, "crosstalk": self.crosstalk,
            "calibration_matrix": self.calibration_matrix,
            "first_frame_s": self.first_frame_s,
            "slide_speeds_m_s": self.slide_speeds_m_s, "friction": self.friction,
            "outages": [[a, b] for a, b in self.outages],
        }
