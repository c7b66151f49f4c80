"""What a comparison with per-trial checks and ``--models`` adds to a result folder, drawn
from the folder's own tables: figure records of the kinds ``electrostatic_force_all``,
``trial`` and ``frequency_response`` and a ``models.csv``, recorded in fit.json with their
SHA-256 as compare records its files (:func:`with_checks_and_models`)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from evtribo.files import sha256_file


def _save(fig, path: Path) -> None:
    fig.savefig(path, dpi=40)
    plt.close(fig)


def _figures(out: Path) -> list[dict]:
    """Figures of the three kinds, drawn from the folder's tables; their records."""
    es = pd.read_csv(out / "electrostatic.csv", dtype={"subject": str})
    win = pd.read_csv(out / "windows.csv", dtype={"subject": str, "trial": str})
    trials = pd.read_csv(out / "trials.csv", dtype={"subject": str, "trial": str})
    fig, ax = plt.subplots()
    for s, rows in es.groupby("subject"):
        ax.errorbar(rows["amplitude_V"], 1e3 * rows["electrostatic_force_N"], fmt="o", label=s)
    _save(fig, out / "figures" / "electrostatic_force_all.png")
    records = [{"kind": "electrostatic_force_all", "title": "Electrostatic force, all subjects",
                "stem": "electrostatic_force_all", "subject": None, "caption": "All subjects."}]
    for _, t in trials.iterrows():
        stem = f"trial_{t['subject']}_{t['trial']}"
        mine = win[(win["subject"] == t["subject"]) & (win["trial"] == t["trial"])]
        fig, ax = plt.subplots()
        ax.hlines(mine["friction_force_N"], mine["t_start_s"], mine["t_end_s"])
        _save(fig, out / "figures" / f"{stem}.png")
        records.append({"kind": "trial", "title": f"Trial {t['subject']}/{t['trial']}",
                        "stem": stem, "subject": t["subject"], "trial": t["trial"],
                        "caption": "Windows used."})
    for s, rows in es.groupby("subject"):
        fig, ax = plt.subplots()
        ax.plot(rows["frequency_Hz"], rows["electrostatic_force_N"], "o")
        stem = f"frequency_response_{s}"
        fig.savefig(out / "figures" / f"{stem}.{'svg' if s == 'P01' else 'pdf'}")
        plt.close(fig)
        records.append({"kind": "frequency_response", "title": f"F_el vs frequency, {s}",
                        "stem": stem, "subject": s, "caption": "Each model's curve."})
    return records


def _models(out: Path) -> pd.DataFrame:
    """models.csv of two candidates per subject, from fit.csv's misfit: the paper's model,
    and one more parameter with the same misfit (ΔAIC = 2)."""
    fit = pd.read_csv(out / "fit.csv", dtype={"subject": str})
    rows = []
    for _, f in fit.iterrows():
        n = int(f["n_points"])
        rss = float(f["rmse_N"]) ** 2 * n
        for model, k, fitted in (("paper", 1, f"h_L={f['value']:.6g}"),
                                 ("circuit", 2, f"h_L={f['value']:.6g}; r_g=0.012")):
            aic = n * math.log(rss / n) + 2 * k
            rows.append({"subject": f["subject"], "model": model, "fitted": fitted,
                         "n_params": k, "n_points": n, "rss_N2": rss, "aic": aic,
                         "bic": n * math.log(rss / n) + k * math.log(n)})
    models = pd.DataFrame(rows)
    best = models.groupby("subject")["aic"].transform("min")
    models["delta_aic"] = models["aic"] - best
    w = np.exp(-models["delta_aic"] / 2)
    models["akaike_weight"] = w / w.groupby(models["subject"]).transform("sum")
    return models.sort_values(["subject", "aic"])


def with_checks_and_models(out: Path) -> None:
    doc = json.loads((out / "fit.json").read_text(encoding="utf-8"))
    doc["figures"] += _figures(out)
    _models(out).to_csv(out / "models.csv", index=False)
    written = ["models.csv", *(f"figures/{p.name}" for p in (out / "figures").iterdir())]
    doc["output_sha256"].update({rel: sha256_file(out / rel) for rel in written})
    (out / "fit.json").write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
