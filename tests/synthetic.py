"""A synthetic result folder (the tables of ``evtribo analyze``) generated with the model.

Each subject has a known equivalent air gap; measured electrostatic forces are the model's
times log-normal noise of a stated relative size, and their 95 % intervals have the width
that noise implies, so a correct fit recovers the truth within its interval. The points'
errors are independent here, so ``electrostatic_bootstrap.csv`` (written unless
``bootstrap=False``) holds independent draws of that noise about each measured force.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pandas as pd

from evtribo.documents.summary import write_summary
from evtribo.model import TABLE_1, electrostatic_force, friction_force, sine_voltage

TRUE_H_L = {"P01": 3.0e-6, "P02": 8.0e-6}
AMPLITUDES = (60.0, 80.0, 100.0, 120.0, 140.0)
MU = {"P01": 0.45, "P02": 0.6}
NOISE = 0.05  # relative standard error of each electrostatic point


N_REPLICATES = 200


def make_out(folder: Path, *, seed: int = 1, note: str = "ok",
             sine_trace: bool = True, bootstrap: bool = True, exact: bool = False) -> Path:
    """Write trials.csv, windows.csv, electrostatic.csv, exponents.csv, summary.json and
    electrostatic_bootstrap.csv (*exact*: the measured forces are the model's, their
    intervals 5 % wide as ever, so that the fit goes through every point)."""
    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True, exist_ok=True)
    trials, windows, elec, expo = [], [], [], []
    for subject, h_l in TRUE_H_L.items():
        p = TABLE_1.with_values(h_L=h_l, mu=MU[subject])
        f_el_pts = []
        for k, amp in enumerate(AMPLITUDES):
            trial = f"run-{k + 1:02d}"
            trials.append({"subject": subject, "trial": trial, "waveform": "square",
                           "frequency_Hz": 10000, "amplitude_V": amp,
                           "condition": "alternating", "duration_s": 20.0, "frames": 4000,
                           "dropped_frames": 3 if (subject, k) == ("P02", 1) else 0,
                           "skipped_lines": 1 if (subject, k) == ("P01", 2) else 0,
                           "friction_modulation_Hz": np.nan, "notes": note})
            fn_on = 0.5 + 0.05 * rng.standard_normal()
            fn_off = 0.5 + 0.05 * rng.standard_normal()
            true = float(electrostatic_force(fn_on, amp, p))
            meas = true * float(np.exp(NOISE * rng.standard_normal()))
            meas = true if exact else meas
            se = NOISE * meas
            f_el_pts.append(meas)
            for j in range(3):
                for cond, fn in (("on", fn_on), ("off", fn_off)):
                    fnw = fn + 0.01 * rng.standard_normal()
                    u = amp if cond == "on" else 0.0
                    ft = float(friction_force(fnw, u, p)) * (1 + 0.02 * rng.standard_normal())
                    windows.append({"subject": subject, "trial": trial, "condition": cond,
                                    "amplitude_V": amp, "waveform": "square",
                                    "t_start_s": 2.0 * j + (1 if cond == "off" else 0),
                                    "t_end_s": 2.0 * j + (2 if cond == "off" else 1),
                                    "normal_force_N": fnw, "friction_force_N": ft})
            elec.append({"subject": subject, "waveform": "square", "amplitude_V": amp,
                         "mu": MU[subject] * (1 + 0.01 * rng.standard_normal()),
                         "normal_force_on_N": fn_on, "normal_force_off_N": fn_off,
                         "friction_on_N": MU[subject] * (fn_on + meas),
                         "friction_off_N": MU[subject] * fn_off,
                         "electrostatic_force_N": meas,
                         "electrostatic_force_ci_low_N": meas - 1.96 * se,
                         "electrostatic_force_ci_high_N": meas + 1.96 * se,
                         "n_on": 3, "n_off": 3})
        slope, icept = np.polyfit(np.log(AMPLITUDES), np.log(f_el_pts), 1)
        expo.append({"subject": subject, "waveform": "square", "exponent": slope,
                     "exponent_ci_low": slope - 0.2, "exponent_ci_high": slope + 0.2,
                     "prefactor_N": float(np.exp(icept))})
    pd.DataFrame(trials).to_csv(folder / "trials.csv", index=False)
    pd.DataFrame(windows).to_csv(folder / "windows.csv", index=False)
    pd.DataFrame(elec).to_csv(folder / "electrostatic.csv", index=False)
    pd.DataFrame(expo).to_csv(folder / "exponents.csv", index=False)
    if bootstrap:
        boot = [{"subject": e["subject"], "waveform": e["waveform"],
                 "amplitude_V": e["amplitude_V"], "replicate": i,
                 "electrostatic_force_N": e["electrostatic_force_N"]
                 * float(np.exp(NOISE * z))}
                for e in elec for i, z in enumerate(rng.standard_normal(N_REPLICATES))]
        pd.DataFrame(boot).to_csv(folder / "electrostatic_bootstrap.csv", index=False)
    if sine_trace:
        t = np.arange(0.0, 0.3, 1e-3)
        fn = 0.5 + 0.1 * np.sin(2 * np.pi * 2 * t)
        u = sine_voltage(t, 140.0, 10.0) * (t >= 0.1)
        p = TABLE_1.with_values(h_L=TRUE_H_L["P01"], mu=MU["P01"])
        ft = friction_force(fn, u, p) + 0.002 * rng.standard_normal(t.size)
        pd.DataFrame({"subject": "P01", "trial": "sine-01", "time_s": t, "normal_force_N": fn,
                      "friction_force_N": ft, "voltage_V": u}).to_csv(
            folder / "sine_trace.csv", index=False)
    log_bytes = b"(1763700000.000123) vcan0 0C1#1122334455667788\n"
    # summary.json in the shape evtribo analyze writes (older results: no run_id, no hashes)
    write_summary(folder / "summary.json", {
        "study": f"synthetic {note}", "evtribo_version": "0.1.0",
        "study_dir": "/data/study",
        "inputs": [{"file": "P01/run-01.log", "role": "log", "bytes": len(log_bytes),
                    "sha256": hashlib.sha256(log_bytes).hexdigest()}],
        "rig": {"dbc": "rig/loadcells.dbc", "normal_force": "FzCell.Fz"},
        "software": {"evtribo": "0.1.0"},
        "warnings": [f"P01/run-03: P01/run-03.log:17: skipped damaged line ({note})"]})
    return folder
