"""The truth of a generated study, and how it is defined.

- A cell (subject x waveform x frequency x amplitude): ``F_el_N`` is the mean of the true
  electrostatic force over every grid sample (1 ms) of that subject's trials at that
  amplitude where the amplifier is on and the finger fully in contact (envelope = 1). For
  a square drive that is the force of the voltage's amplitude at the press of the moment;
  for a sine, the time mean of the instantaneous force. ``F_el_model_N`` is the model at
  the amplitude and the press's target (``Press.target_N``).
- ``F_el_windows_N`` (computed by :func:`window_truth` from the 10-ms trace and an
  analysis's ``windows.csv``) is the mean over the ON windows the analysis used of the
  true force's mean in each window.
- A subject's ``exponent`` and ``prefactor_N``: the least-squares line log F = log k +
  n·log U through the cells' ``F_el_N`` (for a power-law subject under a square drive,
  exactly its k and n).
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import asdict
from pathlib import Path

import numpy as np

from . import physics
from .cells import CellStream
from .config import StudyConfig
from .logfile import LogInfo
from .trial import Subject, TrialPhysics, TrialSpec

TRACE_BIN_S = 0.01


def write_trace(path: Path, phys: TrialPhysics, info: LogInfo) -> Path:
    """The trial's true signals in 10-ms bins, on the log's clock from its first line."""
    per = max(1, round(TRACE_BIN_S / (phys.t[1] - phys.t[0])))
    n = phys.t.size // per

    def binned(x: np.ndarray) -> np.ndarray:
        return x[: n * per].reshape(n, per).mean(axis=1)

    t0 = phys.t[: n * per : per]
    t_log = info.epoch_s + t0 * (1.0 + info.host_ppm * 1e-6) - info.first_stamp_s
    full = (phys.contact >= 0.999).astype(float)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(
        path, t_s=t_log, bin_s=per * (phys.t[1] - phys.t[0]),
        electrostatic_N=binned(phys.electrostatic), on=binned(phys.on.astype(float)),
        contact=binned(full), normal_N=binned(phys.normal), mu=binned(phys.mu_now),
        speed_m_s=binned(np.abs(phys.velocity)))
    return path


def trial_record(spec: TrialSpec, phys: TrialPhysics, streams: list[CellStream],
                 info: LogInfo, trace: Path) -> dict:
    """One trial's truth: its draws, the cells' flaws, and the sums behind the cells."""
    full = phys.contact >= 0.999
    on = phys.on & full
    off = ~phys.on & full & (np.abs(phys.velocity) > 0.005)
    return {
        "subject": spec.subject.name, "trial": spec.name, "amplitude_V": spec.amplitude_V,
        "condition": spec.condition, "mu_factor": spec.mu_factor,
        "moisture_rise": spec.moisture_rise, "moisture_tau_s": spec.moisture_tau_s,
        "normal_offset_N": streams[0].offset_N, "tangential_offset_N": streams[1].offset_N,
        "normal_drift_N": streams[0].drift_N, "tangential_drift_N": streams[1].drift_N,
        "log_first_stamp_s": info.first_stamp_s, "log_epoch_s": info.epoch_s,
        "host_clock_ppm": info.host_ppm, "jitter_s": info.jitter_s, "frames": info.frames,
        "trace": str(trace),
        "on_samples": int(on.sum()), "on_force_sum_N": float(phys.electrostatic[on].sum()),
        "mu_off_mean": float(phys.mu_now[off].mean()) if off.any() else None,
        "normal_on_mean_N": float(phys.normal[on].mean()) if on.any() else None,
    }


def model_force(cfg: StudyConfig, s: Subject, amplitude: float) -> float:
    """The force model at the amplitude and the press's target, N (square drive)."""
    if s.h_L_m is not None:
        return float(physics.paper_force(cfg.electrostatic, s.h_L_m, np.array(amplitude),
                                         np.array(cfg.press.target_N)))
    assert s.k is not None and s.n is not None
    return float(physics.power_force(s.k, s.n, np.array(amplitude)))


def _cells(cfg: StudyConfig, subjects: list[Subject], records: list[dict]) -> list[dict]:
    """Pool each subject's trials per amplitude into the cells' truth."""
    sums: dict[tuple[str, float], list[float]] = defaultdict(lambda: [0.0, 0.0])
    for r in records:
        if r["on_samples"]:
            acc = sums[(r["subject"], r["amplitude_V"])]
            acc[0] += r["on_force_sum_N"]
            acc[1] += r["on_samples"]
    by_name = {s.name: s for s in subjects}
    cells = []
    for (name, amp), (total, count) in sorted(sums.items()):
        cells.append({"subject": name, "waveform": cfg.drive.waveform,
                      "frequency_Hz": cfg.drive.frequency_Hz, "amplitude_V": amp,
                      "F_el_N": total / count, "on_samples": int(count),
                      "F_el_model_N": model_force(cfg, by_name[name], amp)})
    return cells


def _subject_truth(cfg: StudyConfig, s: Subject, cells: list[dict],
                   records: list[dict]) -> dict:
    mine = [c for c in cells if c["subject"] == s.name]
    k, n = physics.power_law_fit(np.array([c["amplitude_V"] for c in mine]),
                                 np.array([c["F_el_N"] for c in mine]))
    mus = [r["mu_off_mean"] for r in records
           if r["subject"] == s.name and r["mu_off_mean"] is not None]
    return {**asdict(s), "m": cfg.friction.m, "f_ref_N": cfg.friction.f_ref_N,
            "exponent": n, "prefactor_N": k, "mu_off_mean": float(np.mean(mus)) if mus else None}


def _population(subjects: dict[str, dict], cells: list[dict]) -> dict:
    """The drawn subjects' typical values (geometric means of forces, means of the rest)."""
    amps = sorted({c["amplitude_V"] for c in cells})
    force = {}
    for a in amps:
        vals = [c["F_el_N"] for c in cells if c["amplitude_V"] == a]
        force[str(a)] = float(np.exp(np.mean(np.log(vals))))
    exps = [s["exponent"] for s in subjects.values() if np.isfinite(s["exponent"])]
    pref = [s["prefactor_N"] for s in subjects.values() if np.isfinite(s["prefactor_N"])]
    mus = [s["mu_off_mean"] for s in subjects.values() if s["mu_off_mean"] is not None]
    gaps = [s["h_L_m"] for s in subjects.values() if s["h_L_m"] is not None]
    return {"h_L_m": float(np.exp(np.mean(np.log(gaps)))) if gaps else None,
            "electrostatic_force_N": force,
            "exponent": float(np.mean(exps)) if exps else None,
            "prefactor_N": float(np.exp(np.mean(np.log(pref)))) if pref else None,
            "mu": float(np.mean(mus)) if mus else None}


def superpopulation(cfg: StudyConfig) -> dict | None:
    """The population the subjects are drawn from, where it has one typical value.

    Geometric means of the force at each amplitude (at the press's target) and of the
    prefactor, the mean exponent, the median air gap; by Gauss-Hermite quadrature over the
    subjects' log-normal air gap (paper model) or in closed form (power law). None with
    weak responders (a mixture) or outside a square drive.
    """
    e = cfg.electrostatic
    if e.weak_share > 0 or cfg.drive.waveform != "square":
        return None
    amps = np.asarray(cfg.drive.amplitudes_V, dtype=float)
    if e.model == "power":
        log_f = np.log(e.force_at_140V_N) + e.n_mean * np.log(amps / 140.0)
        return {"electrostatic_force_N": {str(a): float(np.exp(v)) for a, v in zip(amps, log_f,
                                                                                 strict=True)},
                "exponent": e.n_mean, "prefactor_N": e.force_at_140V_N / 140.0**e.n_mean,
                "h_L_m": None}
    nodes, weights = np.polynomial.hermite_e.hermegauss(20)
    weights = weights / weights.sum()
    logs, exps, logk = [], [], []
    for z in nodes:
        h = e.h_L_median_m * np.exp(e.h_L_log_sd * z)
        f = physics.paper_force(e, h, amps, np.full(amps.size, cfg.press.target_N))
        k, n = physics.power_law_fit(amps, f)
        logs.append(np.log(f))
        exps.append(n)
        logk.append(np.log(k))
    mean_log = np.average(np.array(logs), axis=0, weights=weights)
    return {"electrostatic_force_N": {str(a): float(np.exp(v)) for a, v in zip(amps, mean_log,
                                                                             strict=True)},
            "exponent": float(np.average(exps, weights=weights)),
            "prefactor_N": float(np.exp(np.average(logk, weights=weights))),
            "h_L_m": e.h_L_median_m}


def study_truth(cfg: StudyConfig, seed: int, subjects: list[Subject], records: list[dict],
                xtalk: np.ndarray) -> dict:
    """The truth document of a study."""
    cells = _cells(cfg, subjects, records)
    subj = {s.name: _subject_truth(cfg, s, cells, records) for s in subjects}
    return {"scenario": cfg.name, "seed": seed, "config": asdict(cfg),
            "crosstalk_matrix": xtalk.tolist(), "subjects": subj, "cells": cells,
            "population": _population(subj, cells),
            "superpopulation": superpopulation(cfg), "trials": records}


def window_truth(trace: dict, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Mean true F_el over each window [start, end) of the log's time, N (NaN: no bin)."""
    t = trace["t_s"]
    centre = t + 0.5 * float(trace["bin_s"])
    cum = np.r_[0.0, np.cumsum(trace["electrostatic_N"])]
    i0 = np.searchsorted(centre, starts)
    i1 = np.searchsorted(centre, ends)
    count = i1 - i0
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, (cum[i1] - cum[i0]) / count, np.nan)
