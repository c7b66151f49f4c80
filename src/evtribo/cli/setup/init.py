"""``evtribo init STUDY --dbc FILE [--log SAMPLE]``: a study folder for a lab's own rig.

Writes ``STUDY/study.toml`` with every key of the study format (spec §1; the optional ones
commented out with their meaning) and copies the DBC to ``STUDY/rig/``. The rig's roles are
guessed from the DBC's names, units and value tables and, with ``--log``, from what the
signals do in a sample log (the normal force is positive and steady, the tangential force
changes sign with the strokes, status signals switch, counters count); each guess is printed
with its reason. Refuses (exit 2) a STUDY that already has a study.toml, unless ``--force``.
"""

from __future__ import annotations

import argparse
from typing import Any


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``init``."""
    p = subparsers.add_parser("init", help="create a study folder for your rig from its DBC",
                              description=__doc__.split("\n\n")[1].replace("\n", " "))
    p.add_argument("study", metavar="STUDY", help="the study folder to create")
    p.add_argument("--dbc", required=True, help="the rig's CAN database")
    p.add_argument("--log", metavar="SAMPLE",
                   help="a sample log of the rig (a few seconds of sliding, any format "
                        "evtribo reads): the signals' behaviour guides the guesses")
    p.add_argument("--force", action="store_true", help="replace an existing study.toml")
    p.add_argument("--strict", action="store_true",
                   help="a damaged line of the sample log is an error")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Create the study and print the guesses; return the exit code."""
    from evtribo.rigsetup import init_study

    result = init_study(args.study, args.dbc, log=args.log, force=args.force,
                        strict=args.strict)
    width = max(len(r) for r in result.guesses)
    for role, guess in result.guesses.items():
        if guess.name is None:
            print(f"{role:<{width}}  --  ({guess.reason})")
            continue
        mark = "  CHECK" if not guess.certain else ""
        print(f"{role:<{width}}  {guess.name}{mark}\n{'':<{width}}    because {guess.reason}")
    print(f"wrote {result.study_toml} and {result.dbc}")
    if result.missing:
        print(f"not guessed: {', '.join(result.missing)}: edit {result.study_toml} (the "
              "signals of the DBC are listed by `evtribo inspect LOG --dbc "
              f"{result.dbc}`)")
    else:
        print(f"next: check the guesses in {result.study_toml}, then `evtribo simulate "
              f"--study {args.study}` to rehearse, or `evtribo session` / `evtribo acquire` "
              "to record")
    return 0
