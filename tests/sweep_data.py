"""``electrostatic.csv`` rows of a frequency and amplitude sweep at two normal forces, one row
per subject, frequency and amplitude as ``analyze`` writes them, generated with one of the
candidate models of :mod:`evtribo.fit.models` (the table ``evtribo analyze`` writes, not
the trials behind it): each point the model's mean force times log-normal noise of a stated
relative size, its 95 % interval the width that noise implies."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from evtribo.fit.model_points import mean_electrostatic_force
from evtribo.fit.models import CANDIDATES
from evtribo.model import TABLE_1, layer_elastances
from synthetic import N_REPLICATES, make_out

FREQUENCIES = (20.0, 50.0, 100.0, 200.0, 500.0, 1000.0, 3000.0, 10000.0)
AMPLITUDES = (40.0, 70.0, 100.0, 140.0, 200.0)
NORMAL_FORCES = (0.1, 0.3)
_Z95 = 1.959963984540054


def r_g_for_corner(corner_Hz: float, h_L: float) -> float:
    """The gap leakage whose corner (``1 / (2 pi r_g (c_g + C_rest))``) is *corner_Hz*."""
    s_sc, s_g, s_i = (float(s) for s in layer_elastances(TABLE_1, h_L=h_L))
    return 1.0 / (2.0 * math.pi * corner_Hz * (1.0 / s_g + 1.0 / (s_sc + s_i)))


def truth(model: str, rng: np.random.Generator, subjects: int = 3) -> dict[str, dict]:
    """Per subject the true parameters of *model*: an air gap of 3-8 um and, for the
    circuit, a leaky gap with its corner between 20 and 300 Hz."""
    out = {}
    for i in range(subjects):
        h = float(rng.uniform(3e-6, 8e-6))
        values = {"h_L": h, "mu": 0.5}
        if CANDIDATES[model].circuit:
            values["r_g"] = r_g_for_corner(float(np.exp(rng.uniform(np.log(20), np.log(300)))), h)
        out[f"P{i + 1:02d}"] = values
    return out


def sweep_rows(model: str, seed: int, *, noise: float = 0.02, subjects: int = 3,
               waveform: str = "square") -> tuple[pd.DataFrame, dict[str, dict]]:
    """The rows and the truth."""
    rng = np.random.default_rng(seed)
    true = truth(model, rng, subjects)
    rows = []
    for subject, values in true.items():
        p = TABLE_1.with_values(values)
        f, u, fn = (a.ravel() for a in np.meshgrid(FREQUENCIES, AMPLITUDES, NORMAL_FORCES))
        # a row per subject x waveform x frequency x amplitude (the study format's key):
        # the second normal force's amplitudes 5 V higher
        u = u + 5.0 * (fn > min(NORMAL_FORCES))
        fn = fn * np.exp(0.05 * rng.standard_normal(fn.size))
        force = mean_electrostatic_force(fn, u, waveform, p, frequency=f,
                                         force=CANDIDATES[model].force)
        meas = force * np.exp(noise * rng.standard_normal(force.size))
        se = noise * meas
        for k in range(force.size):
            rows.append({"subject": subject, "waveform": waveform, "frequency_Hz": f[k],
                         "amplitude_V": u[k], "mu": 0.5, "normal_force_on_N": fn[k],
                         "normal_force_off_N": fn[k], "friction_on_N": np.nan,
                         "friction_off_N": np.nan, "electrostatic_force_N": meas[k],
                         "electrostatic_force_ci_low_N": meas[k] - _Z95 * se[k],
                         "electrostatic_force_ci_high_N": meas[k] + _Z95 * se[k],
                         "n_on": 3, "n_off": 3})
    return pd.DataFrame(rows), true


def sweep_out(folder: Path, model: str, seed: int = 0, *, noise: float = 0.02) -> dict:
    """A result folder (:func:`synthetic.make_out`'s, two subjects) whose electrostatic.csv
    is a sweep made with *model*, with independent bootstrap replicates of its noise;
    returns the truth."""
    make_out(folder, seed=seed, bootstrap=False)
    rows, true = sweep_rows(model, seed, noise=noise, subjects=2)
    rows.to_csv(folder / "electrostatic.csv", index=False)
    rng = np.random.default_rng([seed, 7])
    z = rng.standard_normal((len(rows), N_REPLICATES))
    boot = pd.DataFrame({
        "subject": np.repeat(rows["subject"].to_numpy(), N_REPLICATES),
        "waveform": np.repeat(rows["waveform"].to_numpy(), N_REPLICATES),
        "frequency_Hz": np.repeat(rows["frequency_Hz"].to_numpy(), N_REPLICATES),
        "amplitude_V": np.repeat(rows["amplitude_V"].to_numpy(), N_REPLICATES),
        "replicate": np.tile(np.arange(N_REPLICATES), len(rows)),
        "electrostatic_force_N": (rows["electrostatic_force_N"].to_numpy()[:, None]
                                  * np.exp(noise * z)).ravel()})
    boot.to_csv(folder / "electrostatic_bootstrap.csv", index=False)
    return true
