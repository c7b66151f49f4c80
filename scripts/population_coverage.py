"""How often the population's 95 % intervals hold the truth, on simulated populations.

Simulates studies of 5, 8 and 12 subjects of each kind of population of
``tests/population_coverage.py`` (power-law populations measured as a lab does,
and populations following the seed paper's eq. 11 with log-normal air gaps and normal
forces; made without evtribo's simulator), estimates the population as ``evtribo compare``
does, and prints per kind and number of subjects the share of runs whose interval held the
population's true value, with its binomial standard error: the exponent, the force (all
amplitudes, then each), the friction coefficient mu and, where the subjects follow the
paper's model, the fitted air gap h_L. Also: the share of runs that named an outlier (these
populations have none) and the CPU time per run.

Usage::

    .venv/bin/python scripts/population_coverage.py                 # 200 seeds per row
    .venv/bin/python scripts/population_coverage.py --seeds 400 --kind "eq. 11" --sizes 5
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from population_coverage import KINDS, Tally, run


def _share(tally: Tally, key: str) -> str:
    n = tally.counted.get(key, 0)
    if not n:
        return f"{key}: —"
    return (f"{key} {100 * tally.rate(key):5.1f} ± {100 * tally.uncertainty(key):3.1f} % "
            f"(of {n})")


def main() -> None:
    """Print the coverage of every kind of population and number of subjects asked for."""
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=200, help="runs per kind and size")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--sizes", default="5,8,12", help="numbers of subjects")
    parser.add_argument("--kind", action="append", help="only kinds whose name holds this "
                                                        "(repeatable)")
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    for name in KINDS:
        if args.kind and not any(k in name for k in args.kind):
            continue
        for k in sizes:
            tally = Tally()
            started = time.process_time()
            for seed in range(args.first_seed, args.first_seed + args.seeds):
                run(name, k, seed, tally)
            spent = (time.process_time() - started) / args.seeds
            amps = sorted((key for key in tally.counted if key.startswith("F_el at")),
                          key=lambda s: float(s.split()[2]))
            print(f"{name}, {k} subjects ({args.seeds} runs, {spent:.2f} s CPU each; an "
                  f"outlier named in {100 * tally.named / tally.runs:.1f} %)")
            for key in ("exponent", "F_el", "mu", "h_L"):
                if key in tally.counted:
                    print("    " + _share(tally, key))
            print("    " + "; ".join(_share(tally, a).removeprefix("F_el at ")
                                     for a in amps), flush=True)


if __name__ == "__main__":
    main()
