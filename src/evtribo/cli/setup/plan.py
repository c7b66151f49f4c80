"""``evtribo plan``: size a study before recording it.

A few pilot subjects record the design's trials on the simulated rig and are analysed as
``evtribo analyze`` does; many studies of the design's subjects, drawn from the population
the researcher expects and measured with the pilots' errors, are then analysed as ``evtribo
compare`` does. Printed: the expected 95 % interval of a subject's F_el, of the population's
F_el and of its exponent, and the power to detect a contrast between two conditions, for each
number of subjects asked (evtribo.population.plan; docs/population.md).
"""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``plan``."""
    from evtribo.cli.recording._bounds import say_bounds

    p = subparsers.add_parser(
        "plan", help="size a study before recording: expected intervals and power",
        description=__doc__.split("\n\n")[1].replace("\n", " "))
    d = p.add_argument_group("the design")
    d.add_argument("--subjects", default="8", metavar="N,N,...",
                   help="numbers of subjects to compare (8)")
    d.add_argument("--trials", type=int, default=1, help="trials per subject and amplitude (1)")
    d.add_argument("--trial-length", type=float, default=20.0, metavar="S",
                   help="each trial's length, s (20)")
    d.add_argument("--on-time", type=float, default=2.0, metavar="S", help="ON phase, s (2)")
    d.add_argument("--off-time", type=float, default=2.0, metavar="S", help="OFF phase, s (2)")
    d.add_argument("--stroke-scatter", type=float, default=0.02, metavar="FRACTION",
                   help="the friction's relative scatter between strokes (0.02)")
    d.add_argument("--amplitudes", default="60,80,100,120,140", metavar="V,V,...",
                   help="the amplitudes, V (60,80,100,120,140)")
    d.add_argument("--normal-force", type=float, default=0.5, metavar="N",
                   help="the force the subjects press with, N (0.5)")
    e = p.add_argument_group("what you expect of the population")
    e.add_argument("--force", type=float, default=0.1, metavar="N",
                   help="its F_el at the highest amplitude (geometric mean), N (0.1)")
    e.add_argument("--exponent", type=float, default=2.0, help="its exponent n (2)")
    e.add_argument("--spread", type=float, default=0.5, metavar="SD",
                   help="SD of log F_el between subjects (0.5)")
    e.add_argument("--exponent-spread", type=float, default=0.15, metavar="SD",
                   help="SD of the subjects' exponents (0.15)")
    e.add_argument("--contrast", type=float, default=1.25, metavar="RATIO",
                   help="the ratio of F_el between two conditions to detect (1.25)")
    e.add_argument("--contrast-spread", type=float, default=0.1, metavar="SD",
                   help="SD of the subjects' log ratio (0.1)")
    s = p.add_argument_group("the simulation")
    s.add_argument("--runs", type=int, default=40,
                   help="studies simulated per number of subjects (40)")
    s.add_argument("--pilots", type=int, default=2,
                   help="pilot subjects recorded on the simulated rig (2)")
    s.add_argument("--seed", type=int, default=0)
    say_bounds(p, ["--seed"])
    p.set_defaults(func=run)
    return p


def _numbers(text: str, key: str, kind: type) -> tuple[Any, ...]:
    from evtribo.errors import ConfigError

    try:
        return tuple(kind(x) for x in text.split(",") if x.strip())
    except ValueError as err:
        raise ConfigError(f"{text!r} is not allowed: numbers separated by commas",
                          key=key) from err


def _say_progress() -> Any:
    """What plan is doing, on stderr when it is a terminal, with the time since it
    started."""
    import time

    start = time.monotonic()

    def say(what: str) -> None:
        if sys.stderr.isatty():
            print(f"\r[{time.monotonic() - start:6.1f} s] {what}\033[K", end="",
                  file=sys.stderr, flush=True)

    return say


def _factor(row: Any) -> str:
    if not math.isfinite(row["value"]):
        return "—"
    return f"\u00d7/\u00f7 {row['value']:.2f}"


def _print(plan: Any, expected: Any) -> None:
    table = plan.table
    amps = sorted({float(a) for a in table["amplitude_V"].dropna()})
    first = table[table["subjects"] == table["subjects"].iloc[0]]
    subj = first[first["quantity"] == "subject F_el"]
    print("a subject's F_el, 95 % interval (from the pilots): " + ", ".join(
        f"±{1e3 * float(r['value']):.3g} mN at {float(r['amplitude_V']):g} V"
        for _, r in subj.iterrows()))
    head = ["subjects", *(f"F_el {a:g} V" for a in amps), "exponent",
            f"power ({expected.contrast:g}x)"]
    print("the population's 95 % intervals, median over the studies (F_el: times or divided "
          "by; the exponent: plus or minus), and the power to detect the contrast:")
    print("  ".join(f"{h:>11}" for h in head))
    for k, g in table.groupby("subjects", sort=False):
        pop = g[g["quantity"] == "population F_el"]
        cells = [str(k), *(_factor(r) for _, r in pop.iterrows())]
        n = g[g["quantity"] == "exponent"].iloc[0]
        power = g[g["quantity"] == "power"].iloc[0]
        cells += [f"±{n['value']:.2f}", "—" if not math.isfinite(power["value"]) else
                  f"{100 * power['value']:.0f} ± {100 * power['mc_error']:.0f} %"]
        print("  ".join(f"{c:>11}" for c in cells))
    for note in plan.notes:
        print(note)


def run(args: argparse.Namespace) -> int:
    """Run ``evtribo plan``; return the exit code."""
    from evtribo.cli.recording._bounds import check_bounds
    from evtribo.population.plan import Design, Expected, plan_study

    check_bounds(args, ["--seed"])
    design = Design(subjects=_numbers(args.subjects, "--subjects", int),
                    trials=args.trials, trial_s=args.trial_length, on_s=args.on_time,
                    off_s=args.off_time, stroke_scatter=args.stroke_scatter,
                    amplitudes=tuple(sorted(_numbers(args.amplitudes, "--amplitudes",
                                                     float))),
                    normal_force_N=args.normal_force)
    expected = Expected(force_N=args.force, exponent=args.exponent, spread=args.spread,
                        exponent_spread=args.exponent_spread, contrast=args.contrast,
                        contrast_spread=args.contrast_spread)
    say = _say_progress()
    plan = plan_study(design, expected, runs=args.runs, pilots=args.pilots, seed=args.seed,
                      progress=say)
    if sys.stderr.isatty():
        print(file=sys.stderr)
    _print(plan, expected)
    return 0
