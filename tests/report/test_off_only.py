"""A study of OFF trials only (μ, no electrostatic force): analyze says no electrostatic
force will result, and compare and report still give a report of what it has, each
subject's friction coefficient."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_study

MU = {"P01": 0.42, "P02": 0.61}


def _evtribo(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "evtribo", *args], capture_output=True,
                          text=True, timeout=600, check=False)


@pytest.fixture(scope="module")
def reported(tmp_path_factory) -> tuple[Path, dict[str, subprocess.CompletedProcess[str]]]:
    base = tmp_path_factory.mktemp("off")
    simulate_study(base / "study", [SubjectParams(name=s, mu=m) for s, m in MU.items()],
                   amplitudes=(120.0, 140.0), sine_trial=False, realistic=True,
                   config=TrialConfig(duration_s=8.0, condition="off", seed=4))
    out = base / "out"
    runs = {"analyze": _evtribo("analyze", str(base / "study"), "--out", str(out),
                                "--cache-dir", str(base / "cache")),
            "compare": _evtribo("compare", str(out)),
            "report": _evtribo("report", str(out), "--tables", "md")}
    return out, runs


def test_analyze_says_no_electrostatic_force_will_result(reported):
    out, runs = reported
    assert runs["analyze"].returncode == 0, runs["analyze"].stderr
    said = [w["text"] for w in json.loads((out / "summary.json").read_text())["warnings"]
            if w["kind"] == "no-on-window"]
    assert said and said[0].startswith("no electrostatic force: no trial has an ON window")
    assert len(said) == 1 and runs["analyze"].stderr.count(said[0]) == 1
    assert pd.read_csv(out / "electrostatic.csv").empty


def test_compare_and_report_give_each_subject_s_mu(reported):
    out, runs = reported
    for step in ("compare", "report"):
        assert runs[step].returncode == 0, runs[step].stderr
    windows = pd.read_csv(out / "windows.csv", dtype={"subject": str})
    table = (out / "tables" / "friction.md").read_text(encoding="utf-8")
    html = (out / "report.html").read_text(encoding="utf-8")
    assert "Friction coefficient μ by subject" in html
    # two subjects: no population's mu, and why
    assert not (out / "population.csv").exists()
    assert ("No population estimate of μ: friction coefficient mu: 2 subject(s) to pool; a "
            "population estimate needs at least 3") in html
    for subject, true_mu in MU.items():
        off = windows[(windows.subject == subject) & (windows.condition == "off")]
        mu = off.friction_force_N.sum() / off.normal_force_N.sum()
        assert mu == pytest.approx(true_mu, rel=0.05)  # the simulated finger's, roughly
        row = next(line for line in table.splitlines() if line.startswith(f"| {subject} "))
        assert f"| {mu:.3f} |" in row, row
        assert f"Subject {subject}" in html
    figures = json.loads((out / "fit.json").read_text())["figures"]
    kinds = sorted({f["kind"] for f in figures})
    assert kinds == ["friction_normal_force", "trial"]
    assert len([f for f in figures if f["kind"] == "trial"]) == 4
    assert pd.read_csv(out / "fit.csv").empty
    assert np.isfinite(windows.normal_force_N).all()


def test_the_python_api_compares_them_too(reported):
    import evtribo

    out, _ = reported
    fit = evtribo.compare(evtribo.load_results(out))
    assert fit.table.empty
    # the figures evtribo compare drew, in its order: each subject's friction, each trial's check
    written = [f["stem"] for f in json.loads((out / "fit.json").read_text())["figures"]]
    assert list(fit.figures) == written
    assert sorted(s for s in fit.figures if not s.startswith("trial_")) == [
        f"friction_normal_force_{s}" for s in sorted(MU)]
