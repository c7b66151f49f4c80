"""``evtribo analyze``: a study folder in, the result tables of the study format out."""

from __future__ import annotations

import argparse
import os
import sys
from contextlib import AbstractContextManager, nullcontext
from pathlib import Path
from typing import Any, TextIO

from evtribo.analysis.modes import TARE_MODES
from evtribo.cli._startup import heavy_imports
from evtribo.cli.results._warnings import held, say_grouped
from evtribo.cli.setup._signals import EXIT_TERMINATED, Terminated, sigterm_interrupts

# the analysis is imported when it is needed: not for an unchanged study (.unchanged)
from evtribo.results.distributed import scheduler_address
from evtribo.results.outputs import OUTPUT_FILES


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``evtribo analyze``."""
    p = subparsers.add_parser(
        "analyze", help="friction coefficient and electrostatic force of every subject",
        description="Analyse every trial of STUDY: align the load cells, find the steady-"
                    "sliding windows, estimate mu from the OFF windows and the electrostatic "
                    "force from the ON windows (95 % bootstrap intervals), fit F_el = k*U^n "
                    f"per subject. Writes {', '.join(OUTPUT_FILES)} into --out, as one unit: "
                    "into a new folder beside it, swapped in at the end (stopped at any "
                    "moment, --out keeps the results it had). Exit 0 done, 1 failed, 2 bad "
                    "input, existing outputs without --force, --out inside the study, or "
                    "another process writing --out.")
    p.add_argument("study", metavar="STUDY", help="the study folder (with study.toml)")
    p.add_argument("--out", required=True, metavar="DIR",
                   help="output folder (created; outside the study folder)")
    p.add_argument("--jobs", type=int, default=None, metavar="N",
                   help="worker processes (default: the number of CPUs)")
    p.add_argument("--strict", action="store_true",
                   help="a damaged line in a log is an error, not a warning")
    p.add_argument("--force", action="store_true",
                   help="replace the results in --out: analyze's, and the fit, figures and "
                        "reports of compare and report (their files only)")
    p.add_argument("--cache-dir", metavar="DIR",
                   help="cache of decoded trials, of the inputs' hashes and of each trial's "
                        "outcome (default: $EVTRIBO_CACHE_DIR or ~/.cache/evtribo)")
    p.add_argument("--recompute", action="store_true",
                   help="analyse every trial again, even those whose log, sidecar, rig, "
                        "settings and evtribo are those of an analysis the cache kept")
    p.add_argument("--dask", metavar="ADDRESS", default=None,
                   help="analyse the trials on this Dask cluster's workers (tcp://HOST:PORT; "
                        "default: $EVTRIBO_DASK_SCHEDULER, else local processes); the "
                        "workers must see the study and the cache at the same absolute "
                        "paths; needs pip install 'evtribo[dask]' (docs/cluster.md)")
    settings = p.add_argument_group(
        "analysis settings (override the [analysis] table of study.toml; every key and its "
        "default: analysis/default.toml)")
    settings.add_argument("--tare", choices=TARE_MODES,
                          help="how the load cells' zero offsets are removed (default auto: "
                               "[rig.calibration], then the finger-lifted stretches, then the "
                               "friction loop)")
    settings.add_argument("--guard-s", type=float, metavar="S",
                          help="time excluded on each side of an ON/OFF switch, s")
    settings.add_argument("--confidence", type=float, metavar="P",
                          help="coverage of the confidence intervals (0.95)")
    settings.add_argument("--n-boot", type=int, metavar="N",
                          help="bootstrap replicates of the electrostatic force (2000)")
    settings.add_argument("--seed", type=int, metavar="N", help="seed of the bootstrap (0)")
    settings.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                          help="any analysis setting, e.g. --set min_window_s=0.3 "
                               "(repeatable)")
    p.set_defaults(func=run)
    return p


#: Settings that have an option of their own (the others: --set).
_FLAGS = ("tare", "guard_s", "confidence", "n_boot", "seed")


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


def _cluster(address: str | None, option: str | None) -> AbstractContextManager[Any]:
    """A client of the Dask scheduler at *address* (named by the option, else by the
    environment), or None for a local run."""
    if address is None:
        return nullcontext(None)
    from evtribo.results.distributed import SCHEDULER_ENV, connect

    return connect(address, key="--dask" if option is not None else SCHEDULER_ENV)


def _check_workers(client: Any, study: str, option: str | None) -> None:
    """Before anything is written: the cluster has workers, and they see the study."""
    from evtribo.results.distributed import SCHEDULER_ENV, check_workers

    check_workers(client, [study] if os.path.isdir(study) else [],
                  key="--dask" if option is not None else SCHEDULER_ENV)


def _options(args: argparse.Namespace) -> dict[str, Any]:
    """The options that change the results, as given (the key of an unchanged study)."""
    return {"set": list(args.set), "strict": bool(args.strict),
            **{key: getattr(args, key) for key in _FLAGS}}


def run(args: argparse.Namespace) -> int:
    """Run ``evtribo analyze``; return the exit code."""
    if args.jobs is not None and args.jobs < 1:
        print("evtribo analyze: error: --jobs must be 1 or more", file=sys.stderr)
        return 2
    from evtribo.guard import refuse_cache_in_study

    refuse_cache_in_study(args.cache_dir, args.study)  # before anything is written there
    address = scheduler_address(args.dask)
    with held(int(getattr(args, "verbose", 0) or 0)) as hold:
        return _run(args, address, hold)


def _run(args: argparse.Namespace, address: str | None, hold: Any) -> int:
    """The analysis, or an unchanged study's results again; the exit code."""
    if address is None and not args.recompute:  # an unchanged study: nothing to analyse
        from evtribo.results.unchanged import rerun

        with sigterm_interrupts():
            try:
                summary = rerun(args.study, args.out, options=_options(args),
                                force=args.force, cache_dir=args.cache_dir)
            except Terminated:
                return _terminated(args.out)
        if summary is not None:
            return _report(summary, Path(args.out), args.out, hold)
    from evtribo.store.memo import prehash

    hashing = prehash(args.study, args.cache_dir)  # while the analysis is imported
    with heavy_imports():
        from evtribo.analysis.settings import parse_setting
        from evtribo.results.pipeline import analyze_study
        from evtribo.results.unchanged import remember, study_key

    hashing.finish()
    # the study as it is before the analysis keys what it wrote: a trial recorded meanwhile
    # (a session still recording) is not filed as analysed
    try:
        study_now = study_key(args.study, _options(args)) if address is None else None
    except OSError:  # the analysis says what is wrong; nothing is kept
        study_now = None
    overrides = dict(parse_setting(text) for text in args.set)
    for key in _FLAGS:
        if getattr(args, key) is not None:
            overrides[key] = getattr(args, key)
    progress = _ProgressBar(sys.stderr) if sys.stderr.isatty() else None
    try:
        with sigterm_interrupts(), _cluster(address, args.dask) as client:
            study, cache_dir = args.study, args.cache_dir
            if client is not None:  # the workers see the paths as this machine does
                study = os.path.abspath(study)
                cache_dir = None if cache_dir is None else os.path.abspath(cache_dir)
                _check_workers(client, study, args.dask)
            res = analyze_study(study, args.out, jobs=args.jobs, strict=args.strict,
                                force=args.force, cache_dir=cache_dir,
                                overrides=overrides, progress=progress, scheduler=client,
                                reuse=not args.recompute)
            if study_now is not None:
                remember(args.study, _options(args), res.summary.data, args.out,
                         args.cache_dir, key=study_now)
    except Terminated:
        return _terminated(args.out)
    return _report(res.summary.data, res.out_dir, args.out, hold)


def _terminated(out: str) -> int:
    print(f"evtribo analyze: terminated; {out} holds the results it held before "
          "(or all of the new ones), nothing half-written", file=sys.stderr)
    return EXIT_TERMINATED


def _report(s: dict[str, Any], out_dir: Path | None, out: str, hold: Any) -> int:
    """What the analysis did, on standard output (its warnings, each kind once, on standard
    error); the exit code."""
    dup = len(s.get("duplicate_trials") or [])
    same = f"; {dup} the same log as another trial, counted once" if dup else ""
    print(f"analysed {s['trials_analysed']} of {s['trials']} trials{same} "
          f"({s['windows_on']} ON and {s['windows_off']} OFF windows) into {out_dir}")
    say_grouped(s, out_dir, out, hold)
    return 0 if s["trials_analysed"] else 1
