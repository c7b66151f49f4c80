"""Subject-level result tables of simulated populations with known parameters, for the
population's statistics (made here, not by the simulated rig: an independent check).

:func:`hierarchical_tables` draws each subject's power law from a population (log prefactor
and exponent bivariate normal), then measures it as a lab does: each amplitude's force
with its own relative error (the ON windows' scatter, larger at low voltages), all of a
subject's forces sharing the error of its friction coefficient (F_el = F_t/mu - F_n moves
by -(F_el + F_n) dmu/mu), the reported interval from an estimated standard error (ten
degrees of freedom), bootstrap replicates drawn with the estimated errors' correlation,
and OFF windows for mu.

:func:`physics_tables` draws subjects' air gaps and normal forces and takes each
subject's true force from the seed paper's equation 11; the population's truth is then
the geometric mean over the population's distribution (Monte Carlo).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from evtribo.fit.model_points import mean_electrostatic_force
from evtribo.fit.tables import ResultTables
from evtribo.model.params import TABLE_1

AMPLITUDES = (60.0, 80.0, 100.0, 120.0, 140.0)
U_REF = 100.0


@dataclass
class Truth:
    """The population's true values."""

    exponent: float
    log_force: Callable[[float], float]  # log of the geometric mean F_el at U, N
    mu: float
    h_l: float | None = None  # the population's geometric mean of the air gap, m
    subjects: dict[str, dict[str, float]] = field(default_factory=dict)


@dataclass(frozen=True)
class Lab:
    """How precisely the lab measures (relative errors of F_el and of mu)."""

    on_rel: tuple[float, float] = (0.015, 0.04)
    mu_rel: tuple[float, float] = (0.004, 0.01)
    n_off: int = 12
    n_replicates: int = 60


Rows = list[dict[str, object]]


def _measure(rng: np.random.Generator, name: str, force: np.ndarray, *, fn: float,
             mu: float, amps: Sequence[float], lab: Lab) -> tuple[Rows, Rows, Rows]:
    """One subject's rows of electrostatic.csv, of the bootstrap table and OFF windows."""
    s_on = rng.uniform(*lab.on_rel) * np.sqrt(force[-1] / force)
    s_mu = rng.uniform(*lab.mu_rel)
    c = (force + fn) / force
    cov = np.diag(s_on**2) + np.outer(c, c) * s_mu**2
    meas = force * (1.0 + rng.multivariate_normal(np.zeros(force.size), cov))
    se = np.sqrt(np.diag(cov) * rng.chisquare(10, force.size) / 10) * meas
    es = [{"subject": name, "waveform": "square", "frequency_Hz": 10_000.0,
           "amplitude_V": a, "mu": mu, "normal_force_on_N": fn, "electrostatic_force_N": f,
           "electrostatic_force_ci_low_N": f - 1.96 * e,
           "electrostatic_force_ci_high_N": f + 1.96 * e} for a, f, e in zip(
               amps, meas, se, strict=True)]
    corr = cov / np.outer(np.sqrt(np.diag(cov)), np.sqrt(np.diag(cov)))
    reps = meas + rng.multivariate_normal(np.zeros(force.size), corr,
                                          lab.n_replicates) * se
    boot = [{"subject": name, "waveform": "square", "frequency_Hz": 10_000.0,
             "amplitude_V": a, "replicate": r, "electrostatic_force_N": reps[r, j]}
            for r in range(lab.n_replicates) for j, a in enumerate(amps)]
    fns = fn * rng.uniform(0.8, 1.2, lab.n_off)
    fts = mu * fns * (1 + rng.normal(0, s_mu * math.sqrt(lab.n_off), lab.n_off))
    win = [{"subject": name, "trial": "off", "condition": "off", "amplitude_V": 0.0,
            "waveform": "square", "normal_force_N": a, "friction_force_N": b}
           for a, b in zip(fns, fts, strict=True)]
    return es, boot, win


def _tables(es: Rows, boot: Rows, win: Rows) -> ResultTables:
    return ResultTables(out=Path("."), electrostatic=pd.DataFrame(es),
                        windows=pd.DataFrame(win), exponents=pd.DataFrame(),
                        trials=pd.DataFrame(columns=["subject", "trial"]),
                        bootstrap=pd.DataFrame(boot))


def hierarchical_tables(rng: np.random.Generator, k: int, *, log_f100: float = math.log(0.1),
                        exponent: float = 2.1, sd_log_f: float = 0.5,
                        sd_exponent: float = 0.1, rho: float = 0.3,
                        amps: Sequence[float] = AMPLITUDES, lab: Lab = Lab(),
                        drop: Callable[[int, float], bool] | None = None
                        ) -> tuple[ResultTables, Truth]:
    """*k* subjects of a power-law population, measured (see the module's notes).

    ``drop(i, amplitude)`` leaves a subject's amplitude unmeasured.
    """
    g = np.array([[sd_log_f**2, rho * sd_log_f * sd_exponent],
                  [rho * sd_log_f * sd_exponent, sd_exponent**2]])
    effects = rng.multivariate_normal([log_f100, exponent], g, k)
    es, boot, win = [], [], []
    truth = Truth(exponent, lambda u: log_f100 + exponent * math.log(u / U_REF), 0.5)
    for i, (a_i, n_i) in enumerate(effects):
        name = f"S{i + 1:02d}"
        mine = [a for a in amps if drop is None or not drop(i, a)]
        force = np.exp(a_i + n_i * np.log(np.asarray(mine) / U_REF))
        fn, mu = float(rng.lognormal(math.log(0.5), 0.3)), float(rng.normal(0.5, 0.08))
        truth.subjects[name] = {"log_f100": float(a_i), "exponent": float(n_i)}
        parts = _measure(rng, name, force, fn=fn, mu=mu, amps=mine, lab=lab)
        es += parts[0]
        boot += parts[1]
        win += parts[2]
    return _tables(es, boot, win), truth


def _physics_force(h_l: float, fn: float, amps: Sequence[float]) -> np.ndarray:
    return np.asarray(mean_electrostatic_force(fn, np.asarray(amps, dtype=float), "square",
                                               TABLE_1.with_values(h_L=h_l)), dtype=float)


@functools.cache
def _population_log_force(h_l: float, sd_log_h: float, fn: float, sd_log_fn: float,
                          amps: tuple[float, ...]) -> np.ndarray:
    """The mean over the population of log F_el at each amplitude (4000 subjects)."""
    mc = np.random.default_rng(12345)
    h_all = h_l * np.exp(sd_log_h * mc.standard_normal(4000))
    fn_all = fn * np.exp(sd_log_fn * mc.standard_normal(4000))
    logs = np.log([_physics_force(h, f, amps) for h, f in zip(h_all, fn_all, strict=True)])
    return np.asarray(logs.mean(axis=0), dtype=float)


def physics_tables(rng: np.random.Generator, k: int, *, h_l: float = 5e-6,
                   sd_log_h: float = 0.3, fn: float = 0.5, sd_log_fn: float = 0.4,
                   amps: Sequence[float] = AMPLITUDES, lab: Lab = Lab()
                   ) -> tuple[ResultTables, Truth]:
    """*k* subjects whose forces follow the seed paper's equation 11 (air gap and normal
    force log-normal across the population), measured as :func:`hierarchical_tables`
    does; the truth is the population's geometric mean (Monte Carlo over 4000 subjects)
    and the least-squares exponent of that mean over *amps*."""
    mean_log = _population_log_force(h_l, sd_log_h, fn, sd_log_fn, tuple(amps))
    x = np.log(np.asarray(amps) / U_REF)
    slope = float(np.polyfit(x, mean_log, 1)[0])
    table = dict(zip(amps, mean_log, strict=True))
    truth = Truth(slope, lambda u: float(table[u]), 0.5, h_l)
    es, boot, win = [], [], []
    for i in range(k):
        name = f"S{i + 1:02d}"
        h_i = h_l * math.exp(sd_log_h * rng.standard_normal())
        fn_i = fn * math.exp(sd_log_fn * rng.standard_normal())
        mu = float(rng.normal(0.5, 0.08))
        truth.subjects[name] = {"h_L": h_i, "normal_force_N": fn_i}
        parts = _measure(rng, name, _physics_force(h_i, fn_i, amps), fn=fn_i, mu=mu,
                         amps=amps, lab=lab)
        es += parts[0]
        boot += parts[1]
        win += parts[2]
    return _tables(es, boot, win), truth


def write_result_folder(folder: Path, tables: ResultTables) -> Path:
    """*tables* as a result folder compare reads: electrostatic.csv, its replicates,
    windows.csv (the OFF windows, and ON windows at each measured force), trials.csv and
    a summary.json of an older evtribo (no hashes to check)."""
    from evtribo.documents.summary import write_summary

    folder.mkdir(parents=True, exist_ok=True)
    es = tables.electrostatic.copy()
    on = pd.DataFrame({"subject": es["subject"], "trial": "on", "condition": "on",
                       "amplitude_V": es["amplitude_V"], "waveform": es["waveform"],
                       "normal_force_N": es["normal_force_on_N"],
                       "friction_force_N": es["mu"] * (es["normal_force_on_N"]
                                                       + es["electrostatic_force_N"])})
    windows = pd.concat([tables.windows, on], ignore_index=True)
    windows["t_start_s"], windows["t_end_s"] = 0.0, 1.0
    es["normal_force_off_N"] = es["normal_force_on_N"]
    es["n_on"], es["n_off"] = 10, 10
    es.to_csv(folder / "electrostatic.csv", index=False)
    tables.bootstrap.to_csv(folder / "electrostatic_bootstrap.csv", index=False)
    windows.to_csv(folder / "windows.csv", index=False)
    trials = windows[["subject", "trial"]].drop_duplicates()
    trials.to_csv(folder / "trials.csv", index=False)
    write_summary(folder / "summary.json", {"study": "a simulated population",
                                            "evtribo_version": "0.1.0"})
    return folder
