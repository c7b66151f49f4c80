"""How often the population's 95 % intervals hold the truth, and how far its estimates are
from it, on simulated populations.

Three sources of studies, each estimated as ``evtribo compare`` does (the primary rows,
every subject in):

- ``--cells`` (tests/population_cells.py): cells of 5-12 subjects with errors of 1, 5 and
  10 mN in turn, weak subjects with cells near and below zero (``--weak SHARE``: a share of
  subjects responding at a sixth of their draw);
- ``--heldout SCENARIO`` (tests/heldout/population_cells.py, written independently of
  evtribo: ``cells-1mN``, ``cells-5mN``, ``cells-10mN``, ``cells-mixed``, ``cells-weak``,
  ``cells-5-subjects``), against the population drawn from (the drawn subjects' own values
  where it has none);
- the kinds of ``tests/population_coverage.py`` (power-law populations with relative
  errors, and the seed paper's eq. 11, whose subjects' air gaps are fitted), by default.

Printed per source: the share of runs whose interval held the truth with its binomial
standard error, the mean relative error (bias), the runs whose exponent is more than 1 from
the truth (and of those, any whose checks passed), the runs that named a subject far from the
others, and the CPU time per run.

Usage::

    .venv/bin/python scripts/population_coverage.py --cells --seeds 300
    .venv/bin/python scripts/population_coverage.py --heldout cells-weak --seeds 40
    .venv/bin/python scripts/population_coverage.py --kind "eq. 11" --sizes 5 --seeds 200
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from population_coverage import KINDS, Tally, cell_run, heldout_run, run


def _share(tally: Tally, key: str) -> str:
    n = tally.counted.get(key, 0)
    if not n:
        return f"{key}: —"
    bias = tally.bias(key)
    return (f"{key} {100 * tally.rate(key):5.1f} ± {100 * tally.uncertainty(key):3.1f} % "
            f"(of {n}; bias {100 * bias:+.1f} %)")


def _print(title: str, tally: Tally) -> None:
    print(f"{title} ({tally.runs} runs, {tally.cpu_s / max(tally.runs, 1):.2f} s CPU each in "
          f"the population step; a subject named far from the others in "
          f"{100 * tally.named / max(tally.runs, 1):.1f} %; exponent more than 1 from the "
          f"truth in {tally.far}, of which with every check passed: {len(tally.silent)})")
    for key in ("exponent", "F_el", "mu", "h_L"):
        if key in tally.counted:
            print("    " + _share(tally, key))
    amps = sorted((key for key in tally.counted if key.startswith("F_el at")),
                  key=lambda s: float(s.split()[2]))
    for a in amps:
        print("    " + _share(tally, a))
    for line in tally.silent:
        print("    silent: " + line)


def main() -> None:
    """Print the coverage and bias of every source asked for."""
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=200, help="runs per source")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--cells", action="store_true", help="tests/population_cells.py")
    parser.add_argument("--weak", type=float, default=0.0, help="with --cells: weak share")
    parser.add_argument("--heldout", action="append", metavar="SCENARIO",
                        help="tests/heldout/population_cells.py's scenario (repeatable)")
    parser.add_argument("--sizes", default="5,8,12", help="numbers of subjects (kinds)")
    parser.add_argument("--kind", action="append", help="only kinds whose name holds this "
                                                        "(repeatable)")
    args = parser.parse_args()
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    if args.cells:
        tally = Tally()
        for seed in seeds:
            cell_run(seed, tally, weak=args.weak)
        _print(f"cells of 5-12 subjects, errors of 1, 5 and 10 mN, weak share {args.weak:g}",
               tally)
    for scenario in args.heldout or ():
        tally = Tally()
        with tempfile.TemporaryDirectory(prefix="evtribo-heldout-") as tmp:
            for seed in seeds:
                heldout_run(scenario, seed + 1, tally, Path(tmp))
        _print(f"held-out {scenario}", tally)
    if args.cells or args.heldout:
        return
    for name in KINDS:
        if args.kind and not any(k in name for k in args.kind):
            continue
        for k in [int(s) for s in args.sizes.split(",")]:
            tally = Tally()
            started = time.process_time()
            for seed in seeds:
                run(name, k, seed, tally)
            tally.cpu_s = time.process_time() - started
            _print(f"{name}, {k} subjects", tally)


if __name__ == "__main__":
    main()
