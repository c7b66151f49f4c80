"""``evtribo compare OUT``: fit the model to a result folder, write fit.csv and figures."""

from __future__ import annotations

import argparse
import sys
from typing import Any


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``compare`` on *subparsers*."""
    p = subparsers.add_parser(
        "compare", help="fit the model to analysis results; write fit.csv and figures",
        description="Fit the seed paper's model to the per-subject results of "
                    "`evtribo analyze` (the equivalent air gap h_L by default) by weighted "
                    "least squares, and write OUT/fit.csv, OUT/fit.json and OUT/figures/ "
                    "(one file per figure and format, ready for a journal: no titles, "
                    "text as text, PNG at 300 dpi), as one unit. OUT must hold one "
                    "analysis's complete results (exit 2 otherwise, as when another process "
                    "is writing OUT).",
        epilog="The model: \"Voltage-Induced Friction with Application to "
               "Electrovibration\", Lubricants 2019, 7(12), 102, "
               "doi:10.3390/lubricants7120102.")
    p.add_argument("out", metavar="OUT", help="result folder written by `evtribo analyze`")
    p.add_argument("--fit", metavar="NAMES", default=None,
                   help="comma-separated model parameters to fit per subject "
                        "(default: h_L; e.g. h_L,E_star; see `evtribo model --list`)")
    p.add_argument("--params", metavar="PARAMS.toml", default=None,
                   help="TOML of fixed model parameters, `name = value` in SI units "
                        "(default: the paper's Table 1)")
    p.add_argument("--figure-format", metavar="FORMATS", default=None,
                   help="comma-separated figure formats among pdf, svg, png (default: svg,png; "
                        "the report embeds the PNG, else the SVG)")
    p.add_argument("--figure-width", metavar="WIDTH", default="single",
                   help="figure width: single (one journal column, 85 mm; the default) or "
                        "double (a page, 175 mm)")
    p.add_argument("--models", metavar="NAMES", default=None,
                   help="comma-separated candidate models to fit and rank per subject by "
                        "AIC (paper, hertz, maugis, circuit): writes OUT/models.csv and a "
                        "figure of F_el against the drive frequency per subject")
    p.add_argument("--dpi", type=float, default=None, help="PNG resolution (default 300)")
    p.add_argument("--trial-checks", metavar="WHICH", choices=("auto", "all", "none"),
                   default=None,
                   help="which trials' checks to draw (what the analysis did with each: "
                        "forces, ON phases, windows, lifted and excluded stretches): all, "
                        "none, or auto (the default): every trial of a study of up to 24 "
                        "trials, else those with a warning that may change a number or "
                        "widens an interval (not one only for information), and those not "
                        "analysed")
    p.add_argument("--no-trial-checks", dest="trial_checks", action="store_const",
                   const="none", help="draw no trial's check (--trial-checks none)")
    p.add_argument("--jobs", metavar="N", type=int, default=None,
                   help="worker processes drawing the figures (default: the number of CPUs)")
    p.add_argument("--cache-dir", metavar="DIR", default=None,
                   help="the cache folder analyze used (what it kept of each trial for its "
                        "check), where the figures drawn are kept too (default: "
                        "$EVTRIBO_CACHE_DIR or ~/.cache/evtribo)")
    p.add_argument("--force", action="store_true",
                   help="overwrite the outputs of a previous comparison")
    p.add_argument("--dask", metavar="ADDRESS", default=None,
                   help="run the bootstrap refits on this Dask cluster (tcp://HOST:PORT; "
                        "default: $EVTRIBO_DASK_SCHEDULER, else here); the same results; "
                        "needs pip install 'evtribo[dask]' (docs/cluster.md)")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``evtribo compare``; return the exit code."""
    from contextlib import nullcontext

    say = _say_progress()
    if args.force and _unchanged(args):
        return 0
    say("loading the fitting and plotting libraries")

    from evtribo.cli.setup._signals import EXIT_TERMINATED, Terminated, sigterm_interrupts
    from evtribo.report.compare import compare
    from evtribo.results.distributed import (
        SCHEDULER_ENV,
        check_workers,
        connect,
        scheduler_address,
    )

    address = scheduler_address(args.dask)
    key = "--dask" if args.dask else SCHEDULER_ENV
    try:
        with sigterm_interrupts(), \
                (nullcontext(None) if address is None else connect(address, key=key)) as client:
            if client is not None:  # workers there, running this evtribo
                check_workers(client, [], key=key)
            result = compare(args.out, fit=args.fit, params=args.params, force=args.force,
                             dpi=args.dpi, formats=args.figure_format,
                             width=args.figure_width, models=args.models,
                             trial_checks=args.trial_checks, scheduler=client,
                             progress=say, jobs=args.jobs, cache_dir=args.cache_dir)
    except Terminated:
        print(f"evtribo compare: terminated; {args.out} holds the fit it held before (or all "
              "of the new one), nothing half-written", file=sys.stderr)
        return EXIT_TERMINATED
    from evtribo.util.numbers import r_squared, significant

    for f in result.fits:
        parts = ", ".join(_estimate(e) for e in f.estimates)
        print(f"{f.subject}: {parts}; RMSE {significant(1e3 * f.rmse_N)} mN, "
              f"R² {r_squared(f.r2)}")
    _print_population(result)
    _say_warnings(result.notes, result.out)
    from evtribo.documents.tables import FIT_CSV
    from evtribo.results.outputs import FIGURES

    print(f"wrote {result.out / FIT_CSV} and {len(result.figures)} figures in "
          f"{result.out / FIGURES}")
    return 0


def _unchanged(args: argparse.Namespace) -> bool:
    """Whether OUT holds what this comparison would write (the same analysis, options and
    software, every file as compare wrote it): then it says so and writes nothing, without
    loading the fitting and plotting libraries."""
    from pathlib import Path

    from evtribo.documents.fit import FIT_JSON
    from evtribo.report.compare_cache import options_text, unchanged
    from evtribo.store.resultdir import locked, recover

    out = Path(args.out)
    if not (out / FIT_JSON).is_file():
        return False
    options = options_text(fit=args.fit, params=args.params, formats=args.figure_format,
                           dpi=args.dpi, width=args.figure_width, models=args.models,
                           trial_checks=args.trial_checks)
    with locked(out, "evtribo compare"):
        recover(out)
        doc = unchanged(out, options, cache_dir=args.cache_dir)
    if doc is None:
        return False
    from evtribo.util.numbers import r_squared, significant

    for subject, fit in doc.subjects.items():
        parts = ", ".join(_kept_estimate(name, e)
                          for name, e in (fit.get("estimates") or {}).items())
        print(f"{subject}: {parts}; RMSE {significant(1e3 * _num(fit.get('rmse_N')))} mN, "
              f"R² {r_squared(_num(fit.get('r2')))}")
    _say_warnings(doc.warnings, out)
    print(f"{out}: the fit and its {len(doc.figures)} figures are those of this analysis, "
          "these options and this evtribo already: nothing written")
    return True


def _say_warnings(records: Any, out: Any) -> None:
    """What the comparison said, each kind once (as analyze's console says its own)."""
    from pathlib import Path

    from evtribo.cli.results._warnings import say_records
    from evtribo.documents.fit import FIT_JSON

    say_records(records, Path(out), "the comparison", Path(out) / FIT_JSON)


def _num(value: Any) -> float:
    return float(value) if isinstance(value, (int, float)) else float("nan")


def _kept_estimate(name: str, e: dict[str, Any]) -> str:
    """A fitted parameter as fit.json holds it, printed as :func:`_estimate` does."""
    from evtribo.util.numbers import PREFIXES, auto_prefix, with_interval

    unit = str(e.get("unit") or "")
    value = _num(e.get("value"))
    p = auto_prefix(value) if unit else ""
    k = 10.0 ** -PREFIXES[p]
    shown = with_interval(k * value, k * _num(e.get("ci_low")), k * _num(e.get("ci_high")))
    return f"{name} = {shown}" + (f" {p}{unit}" if unit else "")


def _say_progress() -> Any:
    """What compare is doing, on stderr, with the time since it started."""
    import time

    start = time.monotonic()

    def say(what: str) -> None:  # on a terminal, as analyze's progress bar
        if sys.stderr.isatty():
            print(f"[{time.monotonic() - start:6.1f} s] {what}", file=sys.stderr, flush=True)

    return say


def _print_population(result: Any) -> None:
    """The population's exponent per drive (undetermined where the mixed model's checks
    failed: the key results' claims) and μ (every subject in), the subjects far from the
    others or excluded, or why there is none."""
    from evtribo.report.lead.claims import exponent_claims

    pop = result.population
    if pop is None:
        return
    primary = pop.primary
    for c in exponent_claims(pop.population_table()):
        assert c.row is not None and c.drive is not None  # a power law's row, checked
        where = f"population ({c.drive.label()}, {c.row.n_subjects} subjects)"
        if c.state == "quoted":
            value = c.text.replace("\u00a0", " ")
            print(f"{where}: exponent n = {value}; checks: {c.row.checks}")
        else:
            print(f"{where}: exponent n undetermined: the mixed model's checks failed "
                  f"({c.text})")
    for _, r in primary[primary["quantity"] == "mu"].iterrows():
        print(f"population ({r['n_subjects']} subjects): μ = {r['estimate']:.3g} "
              f"[{r['ci_low']:.3g}, {r['ci_high']:.3g}]")
    for o in pop.outliers:
        print(f"population: far from the others (kept; population.csv has the estimates "
              f"without it too): {o.describe()}", file=sys.stderr)
    for subject, reason in pop.excluded.items():
        print(f"population: {subject} excluded by study.toml's [population] rule: {reason}",
              file=sys.stderr)
    if pop.table.empty and pop.notes:
        print(f"population: none: {pop.notes[0].text}", file=sys.stderr)


def _estimate(e: Any) -> str:
    """A fitted parameter as the report prints it: ``h_L = 3.47 [3.43, 3.52] µm``."""
    from evtribo.report.headline import PARAMETER_DISPLAY
    from evtribo.util.numbers import PREFIXES, auto_prefix, with_interval

    _, unit, prefix = PARAMETER_DISPLAY.get(e.name, (e.name, "", ""))
    p = (auto_prefix(e.value) if prefix is None else prefix) if unit else ""
    k = 10.0 ** -PREFIXES[p]
    return (f"{e.name} = {with_interval(k * e.value, k * e.ci_low, k * e.ci_high)}"
            + (f" {p}{unit}" if unit else ""))
