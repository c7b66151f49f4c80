"""``evtribo report OUT -o report.html``: one self-contained HTML page of a result folder."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

#: The seed paper (as :data:`evtribo.report.headline.CITATION`; kept here so that the
#: command line starts without importing the library).
CITATION = ('"Voltage-Induced Friction with Application to Electrovibration", Lubricants 2019, '
            "7(12), 102, doi:10.3390/lubricants7120102")


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``report`` on *subparsers*."""
    p = subparsers.add_parser(
        "report", help="write a self-contained HTML report of a result folder",
        description="Write one HTML file (figures embedded, works offline) that leads with "
                    "the answer: the electrostatic force F_el by subject and voltage (mN, "
                    "95 % intervals), the model fit per subject (air gap in µm, exponents, "
                    "μ), the figure of all subjects, the model comparison, then each "
                    "subject's results and a check of each trial, the warnings, and the "
                    "provenance and settings last. The model is that of "
                    f"{CITATION}. With --tables md,tex the headline tables are also written "
                    "as Markdown and LaTeX (booktabs) into tables/ beside the report. Runs "
                    "`evtribo compare` first when OUT has no fit.csv. Refuses (exit 2) a "
                    "folder that is not one analysis's complete results, or whose fit is of "
                    "another analysis (run `evtribo compare OUT --force`); warns when an input "
                    "of the study changed since the analysis.")
    p.add_argument("out", metavar="OUT", help="result folder written by `evtribo analyze`")
    p.add_argument("-o", "--output", metavar="REPORT.html", default=None,
                   help="the HTML file to write (default: OUT/report.html)")
    p.add_argument("--no-compare", action="store_true",
                   help="fail instead of running `evtribo compare` when fit.csv is missing")
    p.add_argument("--tables", metavar="FORMATS", default=None,
                   help="also write the headline tables (tables/electrostatic_force.* and "
                        "tables/fit.*) in these formats, comma-separated: md, tex")
    p.add_argument("--force", action="store_true",
                   help="overwrite an existing report (and its tables)")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``evtribo report``; return the exit code."""
    from evtribo.cli.setup._signals import EXIT_TERMINATED, Terminated, sigterm_interrupts
    from evtribo.report.study_report import build_report

    if (Path(args.out) / "study.toml").is_file():
        from evtribo.errors import UserInputError

        raise UserInputError(
            "is a study folder: report takes the result folder `evtribo analyze` wrote "
            f"(`evtribo analyze {args.out} --out RESULTS`, then `evtribo report RESULTS`)",
            path=args.out)
    output = Path(args.output) if args.output else Path(args.out) / "report.html"
    try:
        with sigterm_interrupts():
            path = build_report(args.out, output, force=args.force,
                                run_compare=not args.no_compare, tables=args.tables)
    except Terminated:
        print(f"evtribo report: terminated; {output} is the report it was before (if any), "
              "nothing half-written", file=sys.stderr)
        return EXIT_TERMINATED
    print(f"wrote {path}")
    return 0
