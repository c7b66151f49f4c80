"""Coverage and bias of the population's estimates on simulated populations.

The kinds of population checked (population_sim.py: forces with relative errors and the
seed paper's model; population_cells.py: cells with absolute errors of 1, 5 and 10 mN and
weak subjects with negative cells) and the tally of runs whose interval held the truth, with
each estimate's error: the exponent, the force at each amplitude, the friction coefficient mu
and, for populations that follow the seed paper's model, the fitted air gap h_L.
``scripts/population_coverage.py`` prints them over many seeds with their binomial
uncertainty; the test suite runs fewer seeds (tests/population/test_population_coverage.py).
Only the primary rows (every subject in) are counted.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))

from evtribo.fit.fit import SubjectFit, fit_study
from evtribo.fit.tables import ResultTables
from evtribo.population.estimates import population
from population_cells import cell_study
from population_sim import Lab, Truth, hierarchical_tables, physics_tables

Maker = Callable[[np.random.Generator, int], tuple[ResultTables, Truth]]

#: The kinds of population checked: name -> maker.
KINDS: dict[str, Maker] = {
    "power law, exponents spread 0.1": hierarchical_tables,
    "power law, exponents spread 0.3": lambda rng, k: hierarchical_tables(
        rng, k, sd_exponent=0.3),
    "power law, one exponent": lambda rng, k: hierarchical_tables(
        rng, k, sd_exponent=0.0, sd_log_f=0.3),
    "power law, noisy cells": lambda rng, k: hierarchical_tables(
        rng, k, lab=Lab(on_rel=(0.05, 0.15), mu_rel=(0.01, 0.03))),
    "power law, amplitudes missing": lambda rng, k: hierarchical_tables(
        rng, k, drop=lambda i, a: (i % 3 == 1 and a > 110) or (i % 4 == 2 and a == 60)),
    "the paper's model (eq. 11)": physics_tables,
}
#: The kinds whose subjects follow the seed paper's model: their air gap h_L is fitted.
FITTED = ("the paper's model (eq. 11)",)


@dataclass
class Tally:
    """Per quantity, the intervals that held the truth and the intervals counted.

    Keys: ``exponent``, ``F_el`` (every amplitude), ``F_el at 60 V`` (each amplitude),
    ``mu``, ``h_L``.
    """

    held: dict[str, int] = field(default_factory=dict)
    counted: dict[str, int] = field(default_factory=dict)
    runs: int = 0
    named: int = 0  # runs that named an outlier (there is none in these populations)
    #: each estimate's relative error (estimate / truth - 1), by key
    errors: dict[str, list[float]] = field(default_factory=dict)
    #: runs whose exponent is more than 1 from the truth with every check passed
    silent: list[str] = field(default_factory=list)
    #: runs whose exponent is more than 1 from the truth (with a note or not)
    far: int = 0
    cpu_s: float = 0.0

    def count(self, key: str, low: float, high: float, truth: float,
              estimate: float = math.nan) -> None:
        """One interval of *key*: did it hold *truth*? (and the estimate's error)"""
        self.counted[key] = self.counted.get(key, 0) + 1
        self.held[key] = self.held.get(key, 0) + int(low <= truth <= high)
        if math.isfinite(estimate):
            self.errors.setdefault(key, []).append(estimate / truth - 1.0)

    def bias(self, key: str) -> float:
        """The mean relative error of *key*'s estimates (NaN: none)."""
        e = self.errors.get(key, [])
        return float(np.mean(e)) if e else math.nan

    def rate(self, key: str) -> float:
        """The share of *key*'s intervals that held the truth (NaN: none counted)."""
        n = self.counted.get(key, 0)
        return self.held.get(key, 0) / n if n else math.nan

    def uncertainty(self, key: str) -> float:
        """The binomial standard error of :meth:`rate` (runs taken as independent)."""
        p, n = self.rate(key), self.counted.get(key, 0)
        return math.sqrt(p * (1 - p) / n) if n else math.nan


def check(tables: ResultTables, truth: Truth, tally: Tally,
          fits: Sequence[SubjectFit] = ()) -> None:
    """Count whether the population's exponent, forces, mu and h_L hold the truth.

    *fits*: the subjects' model fits (for h_L; the population's truth ``truth.h_l``).
    """
    pop = population(tables, fits)
    tally.runs += 1
    tally.named += bool(pop.outliers)
    for _, row in pop.primary.iterrows():
        lo, hi, what = float(row["ci_low"]), float(row["ci_high"]), row["quantity"]
        est = float(row["estimate"])
        if what == "exponent":
            tally.count("exponent", lo, hi, truth.exponent, est)
        elif what == "electrostatic_force_N":
            amp = float(row["amplitude_V"])
            true = math.exp(truth.log_force(amp))
            tally.count("F_el", lo, hi, true, est)
            tally.count(f"F_el at {amp:g} V", lo, hi, true, est)
        elif what == "mu":
            tally.count("mu", lo, hi, truth.mu, est)
        elif what == "h_L_m" and truth.h_l is not None:
            tally.count("h_L", lo, hi, truth.h_l, est)


def run(kind: str, k: int, seed: int, tally: Tally, *, fit: bool = True) -> None:
    """One simulated study of *k* subjects of *kind*, checked into *tally*; its subjects
    fitted with the seed paper's model (for h_L) when *fit* and the kind follows it."""
    tables, truth = KINDS[kind](np.random.default_rng([seed, k]), k)
    check(tables, truth, tally, fit_study(tables) if fit and kind in FITTED else ())


#: The cells' errors of the cell-level studies, N.
CELL_ERRORS = (0.001, 0.005, 0.010)


def cell_run(seed: int, tally: Tally, *, maker: Callable[..., tuple[ResultTables, Any]]
             = cell_study, weak: float = 0.0) -> None:
    """One cell-level study (population_cells.py by default): 5 to 12 subjects, cells'
    errors of 1, 5 or 10 mN in turn; its primary rows checked into *tally*, and a run
    whose exponent is more than 1 from the truth with every check passed named in
    ``tally.silent``."""
    k = 5 + seed % 8
    error = CELL_ERRORS[seed % 3]
    tables, truth = maker(np.random.default_rng([seed, 36]), k, error_N=error, weak=weak)
    started = time.process_time()
    pop = population(tables)
    tally.cpu_s += time.process_time() - started
    tally.runs += 1
    tally.named += bool(pop.outliers)
    for _, row in pop.primary.iterrows():
        lo, hi, est = float(row["ci_low"]), float(row["ci_high"]), float(row["estimate"])
        if row["quantity"] == "exponent":
            tally.count("exponent", lo, hi, truth.exponent, est)
            if abs(est - truth.exponent) > 1.0:
                tally.far += 1
                if str(row["checks"]).startswith("ok"):
                    tally.silent.append(f"seed {seed}: n = {est:.2f}, {row['checks']}")
        elif row["quantity"] == "electrostatic_force_N":
            amp = float(row["amplitude_V"])
            true = truth.force(amp)
            tally.count("F_el", lo, hi, true, est)
            tally.count(f"F_el at {amp:g} V", lo, hi, true, est)
        elif row["quantity"] == "mu":
            tally.count("mu", lo, hi, truth.mu, est)


def heldout_run(scenario: str, seed: int, tally: Tally, work: Path) -> None:
    """One study of tests/heldout/population_cells.py's *scenario* (an independent
    generator), written as its result folder under *work*, read as compare reads it, its
    primary rows checked into *tally* against the population it was drawn from (the drawn
    subjects' own values where it has none: weak responders)."""
    from evtribo.fit.tables import read_results
    from heldout import population_cells

    dest = work / f"{scenario}-{seed}"
    truth = population_cells.generate(dest, population_cells.CELL_SCENARIOS[scenario], seed)
    target = truth["superpopulation"] or truth["population"]
    tables = read_results(dest / "out")
    started = time.process_time()
    pop = population(tables)
    tally.cpu_s += time.process_time() - started
    tally.runs += 1
    tally.named += bool(pop.outliers)
    forces = {float(a): v for a, v in target["electrostatic_force_N"].items()}
    for _, row in pop.primary.iterrows():
        lo, hi, est = float(row["ci_low"]), float(row["ci_high"]), float(row["estimate"])
        if row["quantity"] == "exponent":
            tally.count("exponent", lo, hi, target["exponent"], est)
            if abs(est - target["exponent"]) > 1.0:
                tally.far += 1
                if str(row["checks"]).startswith("ok"):
                    tally.silent.append(f"{scenario} seed {seed}: n = {est:.2f}")
        elif row["quantity"] == "electrostatic_force_N":
            amp = float(row["amplitude_V"])
            tally.count("F_el", lo, hi, forces[amp], est)
            tally.count(f"F_el at {amp:g} V", lo, hi, forces[amp], est)
        elif row["quantity"] == "mu":
            tally.count("mu", lo, hi, target["mu"], est)
