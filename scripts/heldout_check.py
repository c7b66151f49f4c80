"""Hold ``evtribo analyze`` (and ``compare``) against studies of the held-out generator.

For each named scenario of ``tests/heldout/scenarios.py`` and each seed: generate a study
(tests/heldout/generator.py), run ``evtribo analyze`` on it from the command line (and
``evtribo compare --no-trial-checks`` with ``--compare``), and compare the result tables
with the generator's truth. Prints per scenario:

- F_el: the pooled relative bias (estimate / truth - 1) over the cells whose true F_el is
  at least 30 mN, with its standard error clustered by study and subject (cells of a
  subject share their OFF reference), and the share of 95 % intervals covering the truth;
  the truth is the mean true force over the ON windows the analysis used
  (``F_el_windows_N``), and, beside it, over every ON sample (``F_el_N``);
- the cells missing from electrostatic.csv and the estimates below 0;
- the exponent: mean error (estimate - truth) and the share of intervals covering it;
- with ``--compare``, population.csv's rows: relative error (forces, prefactor, air gap)
  or error (exponent, mu) against the drawn subjects' typical value, and coverage;
- the warnings of summary.json by kind, per study;
- the wall time of analyze (and compare) per study.

Usage::

    .venv/bin/python scripts/heldout_check.py --scenario clean --seeds 3
    .venv/bin/python scripts/heldout_check.py --scenario all --seeds 2 --compare --json out.json
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from evtribo.documents.summary import read_summary
from heldout import population_cells
from heldout.generator import generate
from heldout.scenarios import SCENARIOS
from heldout.truth import window_truth

MIN_FORCE_N = 0.030
EVTRIBO = str(Path(sys.executable).with_name("evtribo"))
KEYS = ["subject", "waveform", "amplitude_V"]


def run_study(scenario: str, seed: int, work: Path, jobs: int, compare: bool) -> dict:
    """Generate one study, analyse it (and compare); the paths and the wall times."""
    dest = work / f"{scenario}-{seed}"
    if dest.exists():
        shutil.rmtree(dest)
    t0 = time.perf_counter()
    generate(dest, SCENARIOS[scenario], seed)
    gen_s = time.perf_counter() - t0
    env = dict(os.environ, EVTRIBO_CACHE_DIR=str(work / "cache"))
    out = dest / "out"
    t0 = time.perf_counter()
    done = subprocess.run([EVTRIBO, "analyze", str(dest / "study"), "--out", str(out),
                           "--jobs", str(jobs)], env=env, capture_output=True, text=True,
                          check=False)
    analyze_s = time.perf_counter() - t0
    run = {"dest": dest, "out": out, "generate_s": gen_s, "analyze_s": analyze_s,
           "analyze_rc": done.returncode, "compare_s": None, "compare_rc": None}
    if done.returncode != 0:
        run["error"] = done.stderr[-2000:]
        return run
    if compare:
        t0 = time.perf_counter()
        cmp = subprocess.run([EVTRIBO, "compare", str(out), "--no-trial-checks",
                              "--figure-format", "png", "--dpi", "40"],
                             env=env, capture_output=True, text=True, check=False)
        run["compare_s"] = time.perf_counter() - t0
        run["compare_rc"] = cmp.returncode
        if cmp.returncode != 0:
            run["error"] = cmp.stderr[-2000:]
    return run


def run_cells(scenario: str, seed: int, work: Path) -> dict:
    """A population-cells result folder (population_cells.py), compared."""
    dest = work / f"{scenario}-{seed}"
    if dest.exists():
        shutil.rmtree(dest)
    t0 = time.perf_counter()
    population_cells.generate(dest, population_cells.CELL_SCENARIOS[scenario], seed)
    run = {"dest": dest, "out": dest / "out", "generate_s": time.perf_counter() - t0,
           "analyze_s": None, "analyze_rc": 0}
    t0 = time.perf_counter()
    env = dict(os.environ, EVTRIBO_CACHE_DIR=str(work / "cache"))
    cmp = subprocess.run([EVTRIBO, "compare", str(run["out"]), "--no-trial-checks",
                          "--figure-format", "png", "--dpi", "40"],
                         env=env, capture_output=True, text=True, check=False)
    run["compare_s"] = time.perf_counter() - t0
    if cmp.returncode != 0:
        run["error"] = cmp.stderr[-2000:]
    return run


def _window_truths(dest: Path, truth: dict, windows: pd.DataFrame) -> pd.DataFrame:
    """The true F_el averaged over each cell's ON windows (each window's mean, equally)."""
    traces = {(r["subject"], r["trial"]): r["trace"] for r in truth["trials"]}
    rows = []
    on = windows[windows["condition"] == "on"]
    for (subject, trial), group in on.groupby(["subject", "trial"]):
        trace = dict(np.load(dest / traces[(subject, trial)]))
        means = window_truth(trace, group["t_start_s"].to_numpy(), group["t_end_s"].to_numpy())
        rows.append(pd.DataFrame({"subject": subject, "waveform": group["waveform"],
                                  "amplitude_V": group["amplitude_V"], "true": means}))
    if not rows:
        return pd.DataFrame(columns=[*KEYS, "F_el_windows_N"])
    table = pd.concat(rows).groupby(KEYS, as_index=False)["true"].mean()
    return table.rename(columns={"true": "F_el_windows_N"})


def cell_table(run: dict, seed: int) -> pd.DataFrame:
    """Truth and estimate per cell (one row per true cell; NaN estimate: missing)."""
    truth = json.loads((run["dest"] / "truth.json").read_text())
    cells = pd.DataFrame(truth["cells"])
    est = pd.read_csv(run["out"] / "electrostatic.csv")
    windows = pd.read_csv(run["out"] / "windows.csv")
    merged = cells.merge(est, on=KEYS, how="left", suffixes=("", "_est"))
    merged = merged.merge(_window_truths(run["dest"], truth, windows), on=KEYS, how="left")
    weak = {name for name, s in truth["subjects"].items() if s["weak"]}
    merged["weak"] = merged["subject"].isin(weak)
    merged["seed"] = seed
    return merged


def exponent_table(run: dict, seed: int) -> pd.DataFrame:
    """Truth and estimate of each subject's exponent."""
    truth = json.loads((run["dest"] / "truth.json").read_text())
    est = pd.read_csv(run["out"] / "exponents.csv")
    rows = [{"subject": k, "true_n": v["exponent"], "weak": v["weak"]}
            for k, v in truth["subjects"].items()]
    out = pd.DataFrame(rows).merge(est, on="subject", how="left")
    out["seed"] = seed
    return out


def population_table(run: dict, seed: int) -> pd.DataFrame:
    """population.csv's rows beside the drawn subjects' and the population's values."""
    path = run["out"] / "population.csv"
    if not path.exists():
        return pd.DataFrame()
    truth = json.loads((run["dest"] / "truth.json").read_text())
    pop = pd.read_csv(path)
    sample, superpop = truth["population"], truth["superpopulation"] or {}
    rows = []
    for _, r in pop.iterrows():
        q = r["quantity"]
        if q == "electrostatic_force_N":
            key = str(float(r["amplitude_V"]))
            true, true_pop = (sample[q].get(key),
                              superpop.get(q, {}).get(key) if superpop else None)
            label = f"F_el at {r['amplitude_V']:.0f} V"
        else:
            true, true_pop, label = sample.get(q), superpop.get(q), q
        rows.append({"quantity": label, "kind": q, "estimate": r["estimate"],
                     "ci_low": r["ci_low"], "ci_high": r["ci_high"], "true": true,
                     "true_population": true_pop, "seed": seed})
    return pd.DataFrame(rows)


def clustered_mean(values: np.ndarray, groups: np.ndarray) -> tuple[float, float]:
    """Mean and its standard error clustered by group (cells sharing a reference)."""
    if values.size == 0:
        return float("nan"), float("nan")
    mean = float(values.mean())
    resid = pd.Series(values - mean).groupby(groups).sum().to_numpy()
    g = resid.size
    if g < 2:
        return mean, float("nan")
    return mean, float(np.sqrt((resid**2).sum() * g / (g - 1)) / values.size)


def _covered(lo: pd.Series, hi: pd.Series, true: pd.Series) -> pd.Series:
    return (lo <= true) & (true <= hi)


def summarize_cells(cells: pd.DataFrame) -> dict:
    """F_el bias and coverage over the cells of at least 30 mN, missing and negative."""
    found = cells.dropna(subset=["electrostatic_force_N"])
    big = found[found["F_el_windows_N"].fillna(found["F_el_N"]) >= MIN_FORCE_N]
    out: dict = {"cells": len(cells), "cells_missing": int(len(cells) - len(found)),
                 "cells_30mN": len(big),
                 "negative_estimates": int((found["electrostatic_force_N"] < 0).sum())}
    groups = (big["seed"].astype(str) + "/" + big["subject"]).to_numpy()
    for name, col in (("windows", "F_el_windows_N"), ("samples", "F_el_N")):
        true = big[col].fillna(big["F_el_N"])
        rel = (big["electrostatic_force_N"] / true - 1.0).to_numpy()
        out[f"bias_{name}"], out[f"bias_{name}_se"] = clustered_mean(rel, groups)
        cov = _covered(big["electrostatic_force_ci_low_N"], big["electrostatic_force_ci_high_N"],
                       true)
        out[f"coverage_{name}"] = float(cov.mean()) if len(big) else float("nan")
    true_all = found["F_el_windows_N"].fillna(found["F_el_N"])
    out["coverage_all_cells"] = float(_covered(found["electrostatic_force_ci_low_N"],
                                               found["electrostatic_force_ci_high_N"],
                                               true_all).mean()) if len(found) else float("nan")
    return out


def summarize_exponents(exps: pd.DataFrame) -> dict:
    """The exponent's error and coverage (all subjects, and the strong responders)."""
    out = {}
    for name, sel in (("all", exps), ("strong", exps[~exps["weak"]])):
        got = sel.dropna(subset=["exponent"])
        err = (got["exponent"] - got["true_n"]).to_numpy()
        out[f"exponent_{name}_n"] = len(got)
        out[f"exponent_{name}_missing"] = int(len(sel) - len(got))
        out[f"exponent_{name}_bias"] = float(err.mean()) if err.size else float("nan")
        out[f"exponent_{name}_rmse"] = float(np.sqrt((err**2).mean())) if err.size else float(
            "nan")
        out[f"exponent_{name}_coverage"] = float(_covered(
            got["exponent_ci_low"], got["exponent_ci_high"], got["true_n"]).mean()
        ) if len(got) else float("nan")
    return out


def summarize_population(pop: pd.DataFrame) -> list[dict]:
    """Per population.csv quantity: error against the drawn subjects and coverage."""
    rows = []
    if pop.empty:
        return rows
    for label, g in pop.groupby("quantity", sort=False):
        kind = g["kind"].iloc[0]
        relative = kind in ("electrostatic_force_N", "prefactor_N", "h_L_m")
        row: dict = {"quantity": label, "studies": len(g)}
        for which in ("true", "true_population"):
            t = pd.to_numeric(g[which], errors="coerce")
            ok = t.notna()
            if not ok.any():
                continue
            err = g["estimate"][ok] / t[ok] - 1.0 if relative else g["estimate"][ok] - t[ok]
            row[f"{which}_error"] = float(err.mean())
            row[f"{which}_coverage"] = float(_covered(g["ci_low"][ok], g["ci_high"][ok],
                                                      t[ok]).mean())
        row["relative"] = relative
        rows.append(row)
    return rows


def check_scenario(scenario: str, seeds: list[int], work: Path, jobs: int,
                   compare: bool) -> dict:
    """Every seed of one scenario, summarised."""
    cells, exps, pops, kinds = [], [], [], Counter()
    examples: dict[str, str] = {}
    times = {"generate_s": [], "analyze_s": [], "compare_s": []}
    failures = []
    is_cells = scenario in population_cells.CELL_SCENARIOS
    for seed in seeds:
        if is_cells:
            run = run_cells(scenario, seed, work)
            if "error" in run:
                failures.append({"seed": seed, "error": run["error"]})
            else:
                pops.append(population_table(run, seed))
            times["generate_s"].append(run["generate_s"])
            times["compare_s"].append(run["compare_s"])
            continue
        run = run_study(scenario, seed, work, jobs, compare)
        for key, spent in times.items():
            if run.get(key) is not None:
                spent.append(run[key])
        if "error" in run:
            failures.append({"seed": seed, "error": run["error"]})
            if run["analyze_rc"] != 0:
                continue
        cells.append(cell_table(run, seed))
        exps.append(exponent_table(run, seed))
        if compare:
            pops.append(population_table(run, seed))
        for record in read_summary(run["out"] / "summary.json").warnings:
            kinds[record.kind] += 1
            examples.setdefault(record.kind, record.text)
    result: dict = {"scenario": scenario, "seeds": seeds, "failures": failures,
                    "time_s": {k: float(np.mean(v)) if v else None for k, v in times.items()}}
    if cells:
        result.update(summarize_cells(pd.concat(cells, ignore_index=True)))
        result.update(summarize_exponents(pd.concat(exps, ignore_index=True)))
    studies = len(seeds) - len(failures)
    result["warnings_per_study"] = {k: v / max(studies, 1) for k, v in kinds.most_common()}
    result["warning_examples"] = examples
    if pops:
        result["population"] = summarize_population(pd.concat(pops, ignore_index=True))
    return result


def _pct(x: float | None) -> str:
    return "n/a" if x is None or not np.isfinite(x) else f"{100 * x:+.1f} %"


def _share(x: float | None) -> str:
    return "n/a" if x is None or not np.isfinite(x) else f"{100 * x:.0f} %"


def report(r: dict) -> str:
    """One scenario's figures as text."""
    t = r["time_s"]
    spent = ", ".join(f"{k[:-2]} {v:.1f} s" for k, v in t.items() if v is not None)
    lines = [f"== {r['scenario']} ({len(r['seeds'])} seeds) ==", f"  time per study: {spent}"]
    for f in r["failures"]:
        lines.append(f"  FAILED seed {f['seed']}: {f['error'].strip().splitlines()[-1]}")
    if "cells" in r:
        lines += [
            f"  F_el (cells >= 30 mN: {r['cells_30mN']} of {r['cells']}; missing "
            f"{r['cells_missing']}, negative {r['negative_estimates']}):",
            f"    bias vs windows' truth {_pct(r['bias_windows'])}"
            f" ± {100 * r['bias_windows_se']:.1f}"
            f", coverage {_share(r['coverage_windows'])};"
            f" vs all ON samples {_pct(r['bias_samples'])} ± {100 * r['bias_samples_se']:.1f}"
            f", coverage {_share(r['coverage_samples'])}; all cells' coverage "
            f"{_share(r['coverage_all_cells'])}",
            f"  exponent: error {r['exponent_all_bias']:+.3f} (rmse {r['exponent_all_rmse']:.3f},"
            f" {r['exponent_all_n']} subjects, coverage {_share(r['exponent_all_coverage'])});"
            f" strong responders {r['exponent_strong_bias']:+.3f}, coverage "
            f"{_share(r['exponent_strong_coverage'])}"]
    for p in r.get("population", []):
        if "true_error" not in p and "true_population_error" not in p:
            continue
        fmt = _pct if p["relative"] else (lambda x: f"{x:+.3f}")
        parts = [f"  population {p['quantity']}:"]
        if "true_error" in p:
            parts.append(f"vs the subjects {fmt(p['true_error'])} "
                         f"(coverage {_share(p['true_coverage'])})")
        if "true_population_error" in p:
            parts.append(f"vs the population {fmt(p['true_population_error'])} "
                         f"(coverage {_share(p['true_population_coverage'])})")
        lines.append(" ".join(parts))
    warn = ", ".join(f"{v:.1f}x '{k}'" for k, v in r["warnings_per_study"].items())
    lines.append(f"  warnings per study: {warn or 'none'}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Run the scenarios and print their figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", action="append", default=[],
                        help="a scenario (repeatable), 'all' or 'cells': "
                        f"{', '.join([*SCENARIOS, *population_cells.CELL_SCENARIOS])}")
    parser.add_argument("--seeds", type=int, default=3, help="studies per scenario (3)")
    parser.add_argument("--first-seed", type=int, default=1)
    parser.add_argument("--jobs", type=int, default=2, help="analyze's worker processes")
    parser.add_argument("--compare", action="store_true", help="run evtribo compare too")
    parser.add_argument("--work", type=Path, help="keep the studies and results here")
    parser.add_argument("--json", type=Path, help="write every figure to this JSON file")
    args = parser.parse_args(argv)
    names = args.scenario or ["clean"]
    names = [m for n in names for m in {"all": list(SCENARIOS),
                                         "cells": list(population_cells.CELL_SCENARIOS)
                                         }.get(n, [n])]
    unknown = [n for n in names if n not in SCENARIOS and n not in population_cells.CELL_SCENARIOS]
    if unknown:
        parser.error(f"unknown scenario(s) {unknown}; known: {', '.join(SCENARIOS)}")
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    work = args.work or Path(tempfile.mkdtemp(prefix="heldout-"))
    work.mkdir(parents=True, exist_ok=True)
    results = []
    try:
        for name in names:
            r = check_scenario(name, seeds, work, args.jobs, args.compare)
            results.append(r)
            print(report(r), flush=True)
            if args.json:
                args.json.write_text(json.dumps(results, indent=1, default=float) + "\n")
    finally:
        if args.work is None:
            shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
