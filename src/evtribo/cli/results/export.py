"""``evtribo export STUDY -o OUT.mf4``: the study's aligned forces, trial by trial, as MDF 4.

Each trial analysed as ``evtribo analyze`` analyses it (through the cache of decoded
trials), one channel group per trial (``SUBJECT/TRIAL``, its drive in the group's comment):
the normal and tangential forces on the analysis's grid (N; calibrated, tared, hum
removed) and each point's condition (ON, OFF, excluded), time in s from the trial's start.
For asammdf's GUI, CANape or MATLAB; needs the ``mf4`` extra (``pip install
'evtribo[mf4]'``). A trial that cannot be analysed is left out and named.
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import Any


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``export``."""
    p = subparsers.add_parser("export", help="a study's aligned forces per trial as MF4",
                              description=__doc__.split("\n\n")[1].replace("\n", " "))
    p.add_argument("study", help="the study folder")
    p.add_argument("-o", "--output", required=True, help="output file (.mf4)")
    p.add_argument("--subject", action="append",
                   help="only this subject's trials (repeat for several)")
    p.add_argument("--force", action="store_true", help="overwrite an existing output")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Export the study's forces; return the exit code."""
    from evtribo.errors import UserInputError
    from evtribo.guard import refuse_input
    from evtribo.results.export import export_forces
    from evtribo.store.owned import check_output, claim

    out = args.output
    suffix = os.path.splitext(out)[1].lower()
    if suffix != ".mf4":
        raise UserInputError(f"output must end in .mf4, not {suffix or '(none)'!r}", path=out)
    refuse_input(out, command="evtribo export", key="-o")
    check_output(out, "export", force=args.force, key="-o")  # only its own: --force or not

    def progress(done: int, total: int, key: str) -> None:
        print(f"[{done}/{total}] {key}", file=sys.stderr, flush=True)

    print("analysing each trial again to export its aligned forces (a few seconds a trial)",
          file=sys.stderr, flush=True)
    done = export_forces(args.study, out, subjects=args.subject, progress=progress)
    claim(out, "export")
    for why in done.skipped:
        print(f"left out: {why}", file=sys.stderr)
    print(f"{out}: {len(done.groups)} trials' aligned forces ({done.samples} samples in all: "
          "normal force, tangential force, condition)")
    return 0
