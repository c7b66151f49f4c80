"""docs/figures/friction-law.png: a finger pad's friction against the load, OFF and ON, with
the law the analysis fitted.

Simulates one subject whose friction follows ``F_t = mu W_0 (W / W_0)**m`` with ``m = 0.75``
(``W = F_n + F_el``) and whose press wanders by 25 % about 0.6 N, in alternating trials at
80 and 140 V; analyses the study as ``evtribo analyze`` does; plots each window's friction
against its load (OFF: ``F_n``; ON: ``F_n`` plus its cell's ``F_el`` as estimated), the
fitted law ``c W^m`` (``m`` from electrostatic.csv, ``c`` the OFF windows' geometric mean
of ``F_t / F_n^m``) and Amontons' line through the same OFF windows; and prints the fitted
``m`` and each cell's force beside the truth.

Usage::

    .venv/bin/python scripts/friction_law_figure.py [--out docs/figures/friction-law.png]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_study
from evtribo.results.pipeline import analyze_study

M_TRUE = 0.75


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/figures/friction-law.png"))
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        subject = SubjectParams(name="P01", mu=0.5, normal_force_N=0.6, force_drift=0.25,
                                drift_time_s=2.0, friction_exponent=M_TRUE)
        truth = simulate_study(root / "study", [subject], amplitudes=(80.0, 140.0),
                               config=TrialConfig(duration_s=20.0, seed=3), sine_trial=False)
        res = analyze_study(root / "study", root / "out", jobs=1, cache_dir=root / "cache",
                            force=True)
        w = pd.read_csv(res.out_dir / "windows.csv")
        el = pd.read_csv(res.out_dir / "electrostatic.csv")
    m = float(el.friction_exponent.iloc[0])
    print(f"m = {m:.3f} [{el.friction_exponent_ci_low.iloc[0]:.3f}, "
          f"{el.friction_exponent_ci_high.iloc[0]:.3f}] ({el.friction_law.iloc[0]}), "
          f"true {M_TRUE}")
    true_fel = {t.config.amplitude_V: t.electrostatic_force_N for t in truth["P01"].values()}
    for row in el.itertuples():
        print(f"{row.amplitude_V:g} V: F_el {row.electrostatic_force_N:.4f} N "
              f"[{row.electrostatic_force_ci_low_N:.4f}, {row.electrostatic_force_ci_high_N:.4f}],"
              f" true {true_fel[row.amplitude_V]:.4f} N")
    off = w[w.condition == "off"]
    c = float(np.exp(np.mean(np.log(off.friction_force_N) - m * np.log(off.normal_force_N))))
    mu = float(off.friction_force_N.sum() / off.normal_force_N.sum())
    fig, ax = plt.subplots(figsize=(6.0, 4.2), layout="constrained")
    ax.scatter(off.normal_force_N, off.friction_force_N, s=14, color="0.45", label="OFF: W = F_n")
    for (amp, rows), colour in zip(w[w.condition == "on"].groupby("amplitude_V"),
                                   ("tab:orange", "tab:red"), strict=False):
        fel = float(el.loc[el.amplitude_V == amp, "electrostatic_force_N"].iloc[0])
        ax.scatter(rows.normal_force_N + fel, rows.friction_force_N, s=14, color=colour,
                   label=f"ON {amp:g} V: W = F_n + F_el ({1000 * fel:.0f} mN)")
    load = np.linspace(0.8 * w.normal_force_N.min(), 1.05 * (w.normal_force_N.max() + 0.3), 100)
    ax.plot(load, c * load**m, color="k", label=f"fitted law F_t = c W^m, m = {m:.2f}")
    ax.plot(load, mu * load, color="k", linestyle=":", label="Amontons (m = 1) through OFF")
    ax.set_xlabel("load W (N)")
    ax.set_ylabel("friction F_t (N)")
    ax.legend(fontsize=8, loc="upper left")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
