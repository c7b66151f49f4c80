"""Each reason is said once, where the decision is made: ``analyze`` says every kind of warning
of the analysis once on its console, with the trials it concerns (a failed trial's reason
too), ``compare`` and ``plot trial`` (which analyse the trials again to draw them) say none of
them again."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_study
from evtribo.documents.summary import read_summary
from evtribo.warning.render import group


def _evtribo(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "evtribo", *args], capture_output=True,
                          text=True, cwd=cwd, timeout=300, check=False)


@pytest.fixture(scope="module")
def study(tmp_path_factory) -> Path:
    """Two subjects on a real rig (offsets large enough to be warned of), and a trial whose
    log holds no frame of the rig: it cannot be analysed."""
    root = tmp_path_factory.mktemp("said") / "study"
    simulate_study(root, [SubjectParams(name="P01", h_L=4e-6), SubjectParams(name="P02")],
                   amplitudes=(80.0, 140.0), config=TrialConfig(duration_s=8.0, seed=2),
                   sine_trial=False, realistic=True)
    bad = root / "P02" / "run-02.log"
    bad.write_text("".join(f"({1763700000 + 0.01 * i:.6f}) vcan0 7FF#0102\n"
                           for i in range(500)), encoding="ascii")
    return root


@pytest.fixture(scope="module")
def analysed(study: Path) -> tuple[Path, subprocess.CompletedProcess[str]]:
    out = study.parent / "out"
    run = _evtribo("analyze", str(study), "--out", str(out), "--cache-dir",
                   str(study.parent / "cache"), cwd=study.parent)
    return out, run


def test_analyze_says_every_kind_of_warning_once_a_failed_trial_s_reason_included(analysed):
    out, run = analysed
    assert run.returncode == 0, run.stderr
    summary = json.loads((out / "summary.json").read_text())
    warnings = read_summary(out / "summary.json").warnings
    failed = [w for w in warnings if w.kind == "not-analysed"]
    assert len(failed) == 1 and summary["failed_trials"][0]["trial"] == "P02/run-02"
    assert failed[0].text.startswith("P02/run-02: not analysed: ")
    assert len(warnings) >= 2  # the failed trial, and the real rig's large offsets
    groups = group(warnings)
    assert len(groups) < len(warnings)  # the offsets of several trials said as one kind
    for g in groups:  # each kind once, with the trials it concerns
        assert run.stderr.count(f"] {g.title}: ") == 1, (g.title, run.stderr)
        for subject, trial in g.trials:
            assert subject in run.stderr and trial in run.stderr
    assert "trials not analysed: P02: run-02" in run.stderr
    assert summary["failed_trials"][0]["error"] in run.stderr  # its reason, said once
    assert run.stderr.count(summary["failed_trials"][0]["error"]) == 1
    assert "WARNING" not in run.stderr  # no line per trial
    assert f"{len(warnings)} warning(s) of {len(groups)} kind(s)" in run.stderr


def test_compare_and_plot_trial_say_none_of_them_again(analysed, study):
    out, _ = analysed
    summary = json.loads((out / "summary.json").read_text())
    warnings = [w["text"] for w in summary["warnings"]]
    why = summary["failed_trials"][0]["error"]  # the failed trial's reason, said by analyze
    run = _evtribo("compare", str(out), cwd=study.parent)
    assert run.returncode == 0, run.stderr
    plot = _evtribo("plot", "trial", str(study), "P01", "run-01", "-o",
                    str(study.parent / "check.png"), "--cache-dir",
                    str(study.parent / "cache"), cwd=study.parent)
    assert plot.returncode == 0, plot.stderr
    for text in (run.stderr, plot.stderr):
        said = [w for w in warnings if w.split(": ", 1)[1] in text]
        assert said == [], text
        assert why not in text
    assert "WARNING" not in plot.stderr
