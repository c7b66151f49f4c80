"""The analysis held against what real fingers, rigs and loggers do, effect by effect.

Simulates studies of 4 subjects x 5 amplitudes (alternating trials, on a real rig: offsets,
drift, hum, irregular strokes, lift-offs, a tare stretch), each with one effect of
``docs/simulator.md`` added (and all of them at once), over several seeds, analyses them as
``evtribo analyze`` does, and prints per effect what the truth says of the results:

- F_el bias: the mean over cells of (estimate / truth - 1), its standard error, the share
  of cells too high, and the worst cell's; the same mean over the cells of 30 mN or more
  (``bias30_%``);
- covered: the share of the 95 % intervals that hold the true force;
- mu error: the mean and the worst relative error of the ``mu`` column against the true
  coefficient over the cell's ON windows (averaged as the estimate averages them);
- exponent: the worst |exponent - true exponent|, and whether every interval covers;
- the warnings the analysis gave, counted by their first words.

Usage::

    .venv/bin/python scripts/lab_effects.py                     # every effect, 3 seeds
    .venv/bin/python scripts/lab_effects.py --effects moisture,all --seeds 0,1,2,3,4
"""

from __future__ import annotations

import argparse
import collections
import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from _realistic import EFFECTS, run_study


def evaluate(effect: str, seeds: list[int], n_boot: int) -> dict[str, object]:
    """One effect's figures over *seeds*."""
    rig_changes, subject_changes = EFFECTS[effect]
    cells, expo, warned = [], [], collections.Counter[str]()
    for seed in seeds:
        run = run_study(seed, rig_changes=rig_changes, subject_changes=subject_changes,
                        n_boot=n_boot, duration_s=20.0)
        cells.append(run.electrostatic)
        expo.append(run.exponents)
        warned.update(w.kind for w in run.records)
    el = pd.concat(cells, ignore_index=True)
    ex = pd.concat(expo, ignore_index=True)
    rel = el.electrostatic_force_N / el.fel_true_N - 1
    covered = ((el.electrostatic_force_ci_low_N <= el.fel_true_N)
               & (el.fel_true_N <= el.electrostatic_force_ci_high_N))
    ex_cov = (ex.exponent_ci_low <= ex.exponent_true) & (ex.exponent_true <= ex.exponent_ci_high)
    big = el.fel_true_N >= 0.03
    return {"effect": effect, "cells": len(el), "bias_%": 100 * rel.mean(),
            "bias30_%": 100 * rel[big].mean(),
            "bias_se_%": 100 * rel.std() / np.sqrt(len(rel)),
            "high_%": 100 * (rel > 0).mean(),
            "worst_%": 100 * rel.abs().max(), "covered_%": 100 * covered.mean(),
            "mu_err_%": 100 * (el.mu / el.mu_true - 1).abs().mean(),
            "mu_worst_%": 100 * (el.mu / el.mu_true - 1).abs().max(),
            "exp_err": (ex.exponent - ex.exponent_true).abs().max(),
            "exp_covered_%": 100 * ex_cov.mean(),
            "warnings": "; ".join(f"{n}x {w}" for w, n in warned.most_common(4))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--effects", default=",".join(EFFECTS))
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--n-boot", type=int, default=1000)
    args = parser.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    rows = []
    for effect in args.effects.split(","):
        rows.append(evaluate(effect, seeds, args.n_boot))
        print(pd.DataFrame([rows[-1]]).drop(columns="warnings").round(2).to_string(
            index=False, header=len(rows) == 1), flush=True)
    print()
    for r in rows:
        print(f"{r['effect']}: {r['warnings']}")


if __name__ == "__main__":
    main()
