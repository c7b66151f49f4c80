"""Coverage of the population's 95 % intervals on simulated populations (population_sim.py).

Run from the checkout: ``python tests/population_coverage.py --seeds 400``. Prints,
per kind of population and number of subjects, the share of runs whose interval held the
truth: the exponent, and the force at each amplitude (all amplitudes counted). The test
suite runs fewer seeds of the same (tests/population/test_population_coverage.py).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))

from evtribo.fit.tables import ResultTables
from evtribo.population.estimates import population
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


@dataclass
class Tally:
    """Runs whose intervals held the truth."""

    exponent: int = 0
    exponent_runs: int = 0
    force: int = 0
    force_runs: int = 0
    runs: int = 0
    named: int = 0  # runs that named an outlier (there is none in these populations)

    def rates(self) -> tuple[float, float]:
        return (self.exponent / max(self.exponent_runs, 1),
                self.force / max(self.force_runs, 1))


def check(tables: ResultTables, truth: Truth, tally: Tally) -> None:
    """Count whether the population's exponent and forces hold the truth."""
    pop = population(tables)
    tally.runs += 1
    tally.named += bool(pop.outliers)
    for _, row in pop.table.iterrows():
        if row["quantity"] == "exponent":
            tally.exponent_runs += 1
            tally.exponent += int(row["ci_low"] <= truth.exponent <= row["ci_high"])
        elif row["quantity"] == "electrostatic_force_N":
            true = math.exp(truth.log_force(float(row["amplitude_V"])))
            tally.force_runs += 1
            tally.force += int(row["ci_low"] <= true <= row["ci_high"])


def coverage(make: Maker, sizes: Sequence[int], seeds: Sequence[int]) -> Tally:
    """The tally over *seeds*, each run's number of subjects cycling through *sizes*."""
    tally = Tally()
    for i, seed in enumerate(seeds):
        k = sizes[i % len(sizes)]
        tables, truth = make(np.random.default_rng([seed, k]), k)
        check(tables, truth, tally)
    return tally


def main() -> None:
    """Print the coverage of every kind of population at 5, 8 and 12 subjects."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, default=200)
    parser.add_argument("--kind", action="append", help="only these kinds (repeatable)")
    args = parser.parse_args()
    for name, make in KINDS.items():
        if args.kind and not any(k in name for k in args.kind):
            continue
        for k in (5, 8, 12):
            started = time.process_time()
            tally = coverage(make, [k], range(args.seeds))
            exp_rate, f_rate = tally.rates()
            spent = (time.process_time() - started) / args.seeds
            print(f"{name:36s} {k:2d} subjects: exponent {100 * exp_rate:5.1f} %, "
                  f"F_el {100 * f_rate:5.1f} %, an outlier named in "
                  f"{100 * tally.named / tally.runs:4.1f} %  ({args.seeds} runs, "
                  f"{spent:.2f} s CPU each)", flush=True)


if __name__ == "__main__":
    main()
