"""Cells with known truth for the population step: a minimal result folder for ``compare``.

Subjects are drawn from a population: log F_el(140 V) normal (median ``force_at_140V_N``,
log-sd ``force_log_sd``), exponent n normal (``n_mean``, ``n_sd``), so F_el = k·U^n with
k = F_el(140 V)/140^n; a share of weak responders has its force scaled by ``weak_factor``.
Each cell's estimate is its truth plus its own error, of a standard error drawn from
``se_N`` (and, optionally, an error shared by a subject's cells, as cells sharing an OFF
reference have), its 95 % interval ± 1.96 SE; the bootstrap replicates written beside it
carry the same errors. The folder holds what study format §2 lists (trials.csv,
windows.csv, electrostatic.csv, exponents.csv, electrostatic_bootstrap.csv, summary.json)
without a ``run_id``: a result folder as an older evtribo wrote it, which §5 says is read
as it is.

    python tests/heldout/population_cells.py DEST [--seed N] [--se 0.005]
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

if __package__ in (None, ""):  # run as a script: import the package from tests/
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from heldout.physics import power_law_fit

Z95 = 1.959964
TRIAL_COLUMNS = ["subject", "trial", "waveform", "frequency_Hz", "amplitude_V", "condition",
                 "duration_s", "frames", "dropped_frames", "skipped_lines",
                 "friction_modulation_Hz", "normal_offset_N", "tangential_offset_N", "tare",
                 "mu_change_per_10s", "crosstalk_normal", "crosstalk_normal_se",
                 "tangential_direction_share", "analysed_s", "excluded_switch_s",
                 "excluded_lift_s", "excluded_unsteady_s", "excluded_other_s"]


@dataclass(frozen=True)
class PopulationCells:
    """The population and the measurement errors of its cells."""

    name: str = "cells-5mN"
    subjects: int = 8
    amplitudes_V: tuple[float, ...] = (60.0, 80.0, 100.0, 120.0, 140.0)
    force_at_140V_N: float = 0.15
    force_log_sd: float = 0.4
    n_mean: float = 2.0
    n_sd: float = 0.15
    weak_share: float = 0.0
    weak_factor: tuple[float, float] = (0.03, 0.1)
    se_N: tuple[float, ...] = (0.005,)   # each cell's SE drawn from these
    shared_sd_N: float = 0.0             # an error shared by a subject's cells
    mu: tuple[float, float] = (0.35, 0.65)
    normal_force_N: float = 0.5
    windows: int = 6                     # ON windows per cell, and OFF windows per cell
    window_scatter: float = 0.02         # relative sd of a window's friction
    n_boot: int = 400


CELL_SCENARIOS = {
    "cells-1mN": PopulationCells(name="cells-1mN", se_N=(0.001,)),
    "cells-5mN": PopulationCells(),
    "cells-10mN": PopulationCells(name="cells-10mN", se_N=(0.010,)),
    "cells-mixed": PopulationCells(name="cells-mixed", se_N=(0.001, 0.005, 0.010),
                                   shared_sd_N=0.005),
    "cells-weak": PopulationCells(name="cells-weak", weak_share=0.25,
                                  se_N=(0.001, 0.005, 0.010)),
    "cells-5-subjects": PopulationCells(name="cells-5-subjects", subjects=5),
}


def draw(cfg: PopulationCells, rng: np.random.Generator) -> tuple[pd.DataFrame, dict]:
    """The subjects' truth and their cells' estimates (with bootstrap replicates)."""
    n_weak = round(cfg.weak_share * cfg.subjects)
    weak = set(rng.choice(cfg.subjects, n_weak, replace=False).tolist()) if n_weak else set()
    amps = np.asarray(cfg.amplitudes_V)
    rows, subjects = [], {}
    for i in range(cfg.subjects):
        name = f"S{i + 1:02d}"
        n = cfg.n_mean + cfg.n_sd * rng.standard_normal()
        f140 = cfg.force_at_140V_N * np.exp(cfg.force_log_sd * rng.standard_normal())
        if i in weak:
            f140 *= rng.uniform(*cfg.weak_factor)
        true = f140 * (amps / 140.0) ** n
        se = rng.choice(np.asarray(cfg.se_N), size=amps.size)
        shared = cfg.shared_sd_N * rng.standard_normal()
        est = true + se * rng.standard_normal(amps.size) + shared
        boot = (est[:, None] + se[:, None] * rng.standard_normal((amps.size, cfg.n_boot))
                + cfg.shared_sd_N * rng.standard_normal(cfg.n_boot)[None, :])
        subjects[name] = {"k": float(f140 / 140.0**n), "n": float(n), "weak": i in weak,
                          "force_at_140V_N": float(f140), "mu": float(rng.uniform(*cfg.mu))}
        for j, a in enumerate(amps):
            rows.append({"subject": name, "amplitude_V": a, "true_N": true[j], "se_N": se[j],
                         "estimate_N": est[j], "boot": boot[j]})
    return pd.DataFrame(rows), subjects


def truth_of(cfg: PopulationCells, cells: pd.DataFrame, subjects: dict) -> dict:
    """The drawn subjects' typical values and the population's (none with weak ones)."""
    amps = sorted(cells["amplitude_V"].unique())
    sample_f = {str(a): float(np.exp(np.log(cells.loc[cells["amplitude_V"] == a,
                                                      "true_N"]).mean())) for a in amps}
    superpop = None
    if cfg.weak_share == 0:
        superpop = {"electrostatic_force_N": {str(a): float(cfg.force_at_140V_N
                                                            * (a / 140.0) ** cfg.n_mean)
                                              for a in amps},
                    "exponent": cfg.n_mean,
                    "prefactor_N": cfg.force_at_140V_N / 140.0**cfg.n_mean,
                    "mu": float(np.mean(cfg.mu)), "h_L_m": None}
    s = subjects.values()
    return {"config": asdict(cfg), "subjects": subjects,
            "population": {"electrostatic_force_N": sample_f,
                           "exponent": float(np.mean([v["n"] for v in s])),
                           "prefactor_N": float(np.exp(np.mean([np.log(v["k"]) for v in s]))),
                           "mu": float(np.mean([v["mu"] for v in s])), "h_L_m": None},
            "superpopulation": superpop}


def _windows(cfg: PopulationCells, cells: pd.DataFrame, subjects: dict,
             rng: np.random.Generator) -> pd.DataFrame:
    """ON and OFF windows around each cell's estimate and its subject's mu (each window's
    friction scattered by ``window_scatter``)."""
    rows = []
    fn = cfg.normal_force_N
    trials = cells.groupby("subject").cumcount() + 1
    for trial, c in zip(trials, cells.itertuples(), strict=True):
        mu = subjects[c.subject]["mu"]
        for w in range(2 * cfg.windows):
            on = w % 2 == 1
            t0 = 2.0 + 0.8 * w
            friction = mu * (fn + (c.estimate_N if on else 0.0)) * (
                1.0 + cfg.window_scatter * rng.standard_normal())
            rows.append({"subject": c.subject, "trial": f"run-{trial:02d}",
                         "condition": "on" if on else "off",
                         "amplitude_V": c.amplitude_V if on else 0.0, "waveform": "square",
                         "t_start_s": t0, "t_end_s": t0 + 0.6, "normal_force_N": fn,
                         "friction_force_N": friction, "direction": 1 if w % 4 < 2 else -1,
                         "stroke": w, "stroke_s": 1.0, "mu_reference": mu})
    return pd.DataFrame(rows)


def _exponents(cells: pd.DataFrame) -> pd.DataFrame:
    """Each subject's power law through its estimates; the interval from the replicates."""
    rows = []
    for name, g in cells.groupby("subject", sort=False):
        u = g["amplitude_V"].to_numpy()
        k, n = power_law_fit(u, g["estimate_N"].to_numpy())
        boot = np.vstack(g["boot"].to_numpy())
        reps = np.array([power_law_fit(u, boot[:, b])[1] for b in range(boot.shape[1])])
        reps = reps[np.isfinite(reps)]
        lo, hi = np.percentile(reps, [2.5, 97.5]) if reps.size else (np.nan, np.nan)
        rows.append({"subject": name, "waveform": "square", "frequency_Hz": 10000.0,
                     "exponent": n, "exponent_ci_low": lo, "exponent_ci_high": hi,
                     "prefactor_N": k})
    return pd.DataFrame(rows)


def write_folder(out: Path, cfg: PopulationCells, cells: pd.DataFrame, subjects: dict,
                 rng: np.random.Generator) -> None:
    """The minimal result folder: the tables of study format §2 and a summary.json."""
    out.mkdir(parents=True, exist_ok=False)
    windows = _windows(cfg, cells, subjects, rng)
    trials = windows.groupby(["subject", "trial"], as_index=False, sort=False).agg(
        amplitude_V=("amplitude_V", "max"))
    trials = trials.assign(waveform="square", frequency_Hz=10000.0, condition="alternating",
                           duration_s=12.0, frames=24000, dropped_frames=0, skipped_lines=0,
                           friction_modulation_Hz=np.nan, normal_offset_N=np.nan,
                           tangential_offset_N=np.nan, tare="none", mu_change_per_10s=np.nan,
                           crosstalk_normal=np.nan, crosstalk_normal_se=np.nan,
                           tangential_direction_share=np.nan, analysed_s=12.0,
                           excluded_switch_s=0.0, excluded_lift_s=0.0,
                           excluded_unsteady_s=0.0, excluded_other_s=0.0)[TRIAL_COLUMNS]
    est = pd.DataFrame({
        "subject": cells["subject"], "waveform": "square", "frequency_Hz": 10000.0,
        "amplitude_V": cells["amplitude_V"],
        "mu": cells["subject"].map(lambda s: subjects[s]["mu"]),
        "normal_force_on_N": cfg.normal_force_N, "normal_force_off_N": cfg.normal_force_N,
        "friction_on_N": cells["subject"].map(lambda s: subjects[s]["mu"])
        * (cfg.normal_force_N + cells["estimate_N"]),
        "friction_off_N": cells["subject"].map(lambda s: subjects[s]["mu"]) * cfg.normal_force_N,
        "electrostatic_force_N": cells["estimate_N"],
        "electrostatic_force_ci_low_N": cells["estimate_N"] - Z95 * cells["se_N"],
        "electrostatic_force_ci_high_N": cells["estimate_N"] + Z95 * cells["se_N"],
        "n_on": cfg.windows, "n_off": cfg.windows})
    boot = cells[["subject", "amplitude_V", "boot"]].explode("boot")
    boot = pd.DataFrame({"subject": boot["subject"], "waveform": "square",
                         "frequency_Hz": 10000.0, "amplitude_V": boot["amplitude_V"],
                         "replicate": boot.groupby(level=0).cumcount(),
                         "electrostatic_force_N": boot["boot"].astype(float)})
    tables = {"trials.csv": trials, "windows.csv": windows, "electrostatic.csv": est,
              "exponents.csv": _exponents(cells), "electrostatic_bootstrap.csv": boot}
    for name, table in tables.items():
        table.to_csv(out / name, index=False)
    summary = {"study": f"population cells: {cfg.name}", "subjects": sorted(subjects),
               "trials": len(trials), "trials_analysed": len(trials), "failed_trials": [],
               "warnings": [], "outputs": [*tables, "summary.json"]}
    (out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")


def generate(dest: Path, cfg: PopulationCells, seed: int) -> dict:
    """Write ``dest/out`` (the result folder) and ``dest/truth.json``; return the truth."""
    rng = np.random.default_rng(seed)
    cells, subjects = draw(cfg, rng)
    write_folder(dest / "out", cfg, cells, subjects, rng)
    truth = truth_of(cfg, cells, subjects)
    truth["cells"] = cells.drop(columns="boot").to_dict(orient="records")
    (dest / "truth.json").write_text(json.dumps(truth, indent=1, default=float) + "\n")
    return truth


def main(argv: list[str] | None = None) -> int:
    """The command line: one result folder of a named population."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dest", type=Path)
    parser.add_argument("--scenario", default="cells-5mN", choices=sorted(CELL_SCENARIOS))
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--subjects", type=int)
    args = parser.parse_args(argv)
    cfg = CELL_SCENARIOS[args.scenario]
    if args.subjects:
        cfg = replace(cfg, subjects=args.subjects)
    generate(args.dest, cfg, args.seed)
    print(f"{args.dest}/out: {cfg.subjects} subjects; run evtribo compare {args.dest}/out")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
