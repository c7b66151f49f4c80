"""``evtribo analyze``: a study folder in, the result tables of the study format out."""

from __future__ import annotations

import argparse
import sys
from typing import Any, TextIO

from evtribo.analysis.pipeline import OUTPUT_FILES, analyze_study
from evtribo.analysis.settings import TARE_MODES, parse_setting


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``evtribo analyze``."""
    p = subparsers.add_parser(
        "analyze", help="friction coefficient and electrostatic force of every subject",
        description="Analyse every trial of STUDY: align the load cells, find the steady-"
                    "sliding windows, estimate mu from the OFF windows and the electrostatic "
                    "force from the ON windows (95 % bootstrap intervals), fit F_el = k*U^n "
                    f"per subject. Writes {', '.join(OUTPUT_FILES)} into --out. Exit 0 done, "
                    "1 failed, 2 bad input or existing outputs without --force.")
    p.add_argument("study", metavar="STUDY", help="the study folder (with study.toml)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder (created)")
    p.add_argument("--jobs", type=int, default=None, metavar="N",
                   help="worker processes (default: the number of CPUs)")
    p.add_argument("--strict", action="store_true",
                   help="a damaged line in a log is an error, not a warning")
    p.add_argument("--force", action="store_true", help="overwrite existing outputs")
    p.add_argument("--cache-dir", metavar="DIR",
                   help="cache of decoded trials (default: $EVTRIBO_CACHE_DIR or "
                        "~/.cache/evtribo)")
    settings = p.add_argument_group(
        "analysis settings (override the [analysis] table of study.toml; every key and its "
        "default: analysis/default.toml)")
    settings.add_argument("--tare", choices=TARE_MODES,
                          help="how the load cells' zero offsets are removed (default auto: "
                               "[rig.calibration], then the finger-lifted stretches, then the "
                               "friction loop)")
    settings.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                          help="any analysis setting, e.g. --set guard_s=0.3 (repeatable)")
    p.set_defaults(func=run)
    return p


class _ProgressBar:
    """``analyze [#####.....] 12/24 trials`` on one terminal line."""

    def __init__(self, stream: TextIO, width: int = 30) -> None:
        self.stream, self.width = stream, width

    def __call__(self, done: int, total: int) -> None:
        filled = round(self.width * done / total) if total else self.width
        bar = "#" * filled + "." * (self.width - filled)
        end = "\n" if done >= total else ""
        self.stream.write(f"\ranalyze [{bar}] {done}/{total} trials{end}")
        self.stream.flush()


def run(args: argparse.Namespace) -> int:
    """Run ``evtribo analyze``; return the exit code."""
    if args.jobs is not None and args.jobs < 1:
        print("evtribo analyze: error: --jobs must be 1 or more", file=sys.stderr)
        return 2
    overrides = dict(parse_setting(text) for text in args.set)
    if args.tare is not None:
        overrides["tare"] = args.tare
    progress = _ProgressBar(sys.stderr) if sys.stderr.isatty() else None
    res = analyze_study(args.study, args.out, jobs=args.jobs, strict=args.strict,
                        force=args.force, cache_dir=args.cache_dir, overrides=overrides,
                        progress=progress)
    s = res.summary
    print(f"analysed {s['trials_analysed']} of {s['trials']} trials "
          f"({s['windows_on']} ON and {s['windows_off']} OFF windows) into {res.out_dir}")
    if s["warnings"]:
        print(f"{len(s['warnings'])} warning(s), listed in {res.out_dir / 'summary.json'}",
              file=sys.stderr)
    return 0 if s["trials_analysed"] else 1
