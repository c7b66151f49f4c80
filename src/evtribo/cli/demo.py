"""``evtribo demo``: simulate, record, analyse, compare and report a small study."""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

#: Most subjects of a demo.
MAX_SUBJECTS = 100
#: Longest trial of a demo, s.
MAX_TRIAL_S = 3600.0
#: Largest time-lapse factor of the demo's simulated rig.
MAX_SPEED = 1000.0


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "demo", help="simulate, record, analyse, compare and report a small study",
        description="Runs the simulated rig on a virtual CAN bus, records each trial with "
        "the code of 'evtribo acquire', then runs analyze, compare and report on the study.")
    p.add_argument("--out", default="demo-output", metavar="DIR",
                   help="output folder (default: %(default)s)")
    p.add_argument("--subjects", type=int, default=3,
                   help=f"simulated subjects (default: 3; 1 to {MAX_SUBJECTS})")
    p.add_argument("--trial-duration", type=float, default=16.0, metavar="S",
                   help=f"length of each trial, s (default: %(default)s; 4 to {MAX_TRIAL_S:g})")
    p.add_argument("--speed", type=float, default=8.0,
                   help="time-lapse factor of the simulated rig (default: %(default)s; > 0 "
                        f"and <= {MAX_SPEED:g})")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the simulated subjects (0 to 2^64 - 1)")
    p.add_argument("--jobs", type=int, default=None, help="analysis worker processes")
    p.add_argument("--force", action="store_true", help="replace a previous demo in --out")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    from evtribo.demo import run_demo
    from evtribo.errors import ConfigError

    if args.subjects < 1:
        raise ConfigError("at least one subject", key="--subjects")
    if args.subjects > MAX_SUBJECTS:
        raise ConfigError(f"{args.subjects} is not allowed: at most {MAX_SUBJECTS} subjects "
                          "(a demo; `evtribo simulate --study --subjects` writes a study of "
                          "more)", key="--subjects")
    if not args.trial_duration >= 4:
        raise ConfigError("trials need at least 4 s (two ON/OFF cycles)", key="--trial-duration")
    if args.trial_duration > MAX_TRIAL_S:
        raise ConfigError(f"{args.trial_duration!r} s is not allowed: at most {MAX_TRIAL_S:g} "
                          "s (an hour: longer than any trial)", key="--trial-duration")
    if not 0 < args.speed <= MAX_SPEED:
        raise ConfigError(f"{args.speed!r} is not allowed: > 0 and <= {MAX_SPEED:g} (a "
                          "time-lapse factor: the simulated rig runs that many times faster "
                          "than real time)", key="--speed")
    if not 0 <= args.seed < 2**64:
        raise ConfigError(f"{args.seed!r} is not allowed: a seed is a number from 0 to "
                          "2^64 - 1", key="--seed")
    t0 = time.monotonic()

    def say(line: str) -> None:
        print(f"[{time.monotonic() - t0:6.1f} s] {line}", file=sys.stderr, flush=True)

    res = run_demo(args.out, subjects=args.subjects, trial_s=args.trial_duration,
                   speed=args.speed, seed=args.seed, jobs=args.jobs, force=args.force,
                   progress=say)
    print(f"report: {res.report.resolve()}")
    return 0
