"""``evtribo demo``: simulate, record, analyse, compare and report a small study."""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "demo", help="simulate, record, analyse, compare and report a small study",
        description="Runs the simulated rig on a virtual CAN bus, records each trial with "
        "the code of 'evtribo acquire', then runs analyze, compare and report on the study.")
    p.add_argument("--out", default="demo-output", metavar="DIR",
                   help="output folder (default: %(default)s)")
    p.add_argument("--subjects", type=int, default=3, help="simulated subjects (default: 3)")
    p.add_argument("--trial-duration", type=float, default=16.0, metavar="S",
                   help="length of each trial, s (default: %(default)s)")
    p.add_argument("--speed", type=float, default=8.0,
                   help="time-lapse factor of the simulated rig (default: %(default)s)")
    p.add_argument("--seed", type=int, default=0, help="seed of the simulated subjects")
    p.add_argument("--jobs", type=int, default=None, help="analysis worker processes")
    p.add_argument("--force", action="store_true", help="replace a previous demo in --out")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    from evtribo.demo import run_demo
    from evtribo.errors import ConfigError

    if args.subjects < 1:
        raise ConfigError("at least one subject", key="--subjects")
    if not args.trial_duration >= 4:
        raise ConfigError("trials need at least 4 s (two ON/OFF cycles)", key="--trial-duration")
    t0 = time.monotonic()

    def say(line: str) -> None:
        print(f"[{time.monotonic() - t0:6.1f} s] {line}", file=sys.stderr, flush=True)

    res = run_demo(args.out, subjects=args.subjects, trial_s=args.trial_duration,
                   speed=args.speed, seed=args.seed, jobs=args.jobs, force=args.force,
                   progress=say)
    print(f"report: {res.report.resolve()}")
    return 0
