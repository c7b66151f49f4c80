"""Cell-level result tables of simulated studies with known population values, for the
population's estimates (made here, not by the simulated rig: cells fed directly to the
population step).

Each subject i has its own power law ``F_el = k_i U^n_i``: ``ln k_i`` and ``n_i`` normal
about the population's (independent), so that the population's F_el at U (the geometric
mean over subjects) is ``exp(E ln k_i) U^(E n_i)``. Each cell is measured with an absolute
error of about the study's size (1, 5 or 10 mN: a lab's short or scattered trials), part of
it shared by the subject's cells (the error of its OFF reference moves them together) and
the rest its own; the reported 95 % interval is the force plus or minus 1.96 standard errors
estimated with ten degrees of freedom; bootstrap replicates carry the errors' correlation.
Weak subjects (the low tail of the population, and with ``weak`` a share of subjects
responding at a fraction of the others) have cells near zero and below it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from evtribo.fit.tables import ResultTables

AMPLITUDES = (60.0, 80.0, 100.0, 120.0, 140.0)
U_REF = 100.0


@dataclass(frozen=True)
class CellTruth:
    """The population's values: the geometric-mean force at each amplitude, the
    exponent, the friction coefficient, and each subject's power law."""

    log_f100: float
    exponent: float
    mu: float
    subjects: dict[str, tuple[float, float]]

    def force(self, amplitude: float) -> float:
        """The population's F_el (geometric mean over subjects) at *amplitude* V, N."""
        return math.exp(self.log_f100 + self.exponent * math.log(amplitude / U_REF))


def cell_study(rng: np.random.Generator, k: int, *, error_N: float,
               f100: float = 0.04, exponent: float = 2.0, sd_log_k: float = 0.5,
               sd_exponent: float = 0.15, shared: float = 0.3, weak: float = 0.0,
               weak_factor: float = 0.15, amplitudes: Sequence[float] = AMPLITUDES,
               replicates: int = 60) -> tuple[ResultTables, CellTruth]:
    """*k* subjects' cells, each with an error of about *error_N* (see the module's notes).

    *weak*: the share of subjects whose force is *weak_factor* of what their draw gives
    (the population's truth then the geometric mean over that mixture).
    """
    amps = np.asarray(amplitudes, dtype=float)
    x = np.log(amps / U_REF)
    log_k = math.log(f100) + sd_log_k * rng.standard_normal(k)
    is_weak = rng.uniform(size=k) < weak
    log_k = np.where(is_weak, log_k + math.log(weak_factor), log_k)
    n_i = exponent + sd_exponent * rng.standard_normal(k)
    es, boot, win = [], [], []
    truth: dict[str, tuple[float, float]] = {}
    for i in range(k):
        name = f"S{i + 1:02d}"
        truth[name] = (float(log_k[i]), float(n_i[i]))
        force = np.exp(log_k[i] + n_i[i] * x)
        own = error_N * math.sqrt(1.0 - shared) * rng.uniform(0.7, 1.3, amps.size)
        cov = np.diag(own**2) + shared * error_N**2
        measured = force + rng.multivariate_normal(np.zeros(amps.size), cov)
        se = np.sqrt(np.diag(cov) * rng.chisquare(10, amps.size) / 10)
        fn = float(rng.lognormal(math.log(0.5), 0.3))
        mu = float(rng.normal(0.5, 0.08))
        es += [{"subject": name, "waveform": "square", "frequency_Hz": 10_000.0,
                "amplitude_V": a, "mu": mu, "normal_force_on_N": fn,
                "electrostatic_force_N": f, "electrostatic_force_ci_low_N": f - 1.96 * e,
                "electrostatic_force_ci_high_N": f + 1.96 * e}
               for a, f, e in zip(amps, measured, se, strict=True)]
        corr = cov / np.sqrt(np.outer(np.diag(cov), np.diag(cov)))
        reps = measured + rng.multivariate_normal(np.zeros(amps.size), corr,
                                                  replicates) * se
        boot += [{"subject": name, "waveform": "square", "frequency_Hz": 10_000.0,
                  "amplitude_V": a, "replicate": r, "electrostatic_force_N": reps[r, j]}
                 for r in range(replicates) for j, a in enumerate(amps)]
        fns = fn * rng.uniform(0.8, 1.2, 12)
        win += [{"subject": name, "trial": "off", "condition": "off", "amplitude_V": 0.0,
                 "waveform": "square", "normal_force_N": a, "friction_force_N": b}
                for a, b in zip(fns, mu * fns * (1 + rng.normal(0, 0.03, 12)), strict=True)]
    mean_log_k = math.log(f100) + weak * math.log(weak_factor)
    tables = ResultTables(out=Path("."), electrostatic=pd.DataFrame(es),
                          windows=pd.DataFrame(win), exponents=pd.DataFrame(),
                          trials=pd.DataFrame(columns=["subject", "trial"]),
                          bootstrap=pd.DataFrame(boot))
    return tables, CellTruth(mean_log_k, exponent, 0.5, truth)
