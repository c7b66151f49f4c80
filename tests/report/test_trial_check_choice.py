"""Which trials' checks compare draws by default in a large study: those with a warning
that may change a number or widens an interval, and those not analysed; not those whose
only warnings are for information (a drift followed, an offset removed)."""

from __future__ import annotations

import json

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_study
from evtribo.documents.summary import read_summary
from evtribo.figures import trial_checks
from evtribo.report.compare import compare
from evtribo.report.drawing import trials_to_check
from evtribo.results.pipeline import analyze_study
from evtribo.warning.render import group


def test_a_large_study_gets_the_checks_of_the_trials_worth_a_look(tmp_path, monkeypatch):
    study, out = tmp_path / "study", tmp_path / "out"
    simulate_study(study, [SubjectParams(name="P01"), SubjectParams(name="P02", h_L=7e-6)],
                   amplitudes=(80.0, 120.0, 160.0), config=TrialConfig(duration_s=8.0),
                   realistic=True)
    analyze_study(study, out, jobs=1, cache_dir=tmp_path / "cache")
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    trials = [tuple(str(t.get("file", "")).removesuffix(".log").split("/")[-2:])
              for t in summary["inputs"] if t.get("role") == "log"]
    records = read_summary(out / "summary.json").warnings
    named = {f"{s}/{t}" for g in group(records) for s, t in g.trials}
    worth = trials_to_check(records, trials)
    assert named - worth, "a trial whose warnings are all for information"
    monkeypatch.setattr(trial_checks, "AUTO_ALL", 2)  # a study "larger" than 2 trials
    compare(out, dpi=30, formats="png", jobs=1, cache_dir=tmp_path / "cache")
    fit = json.loads((out / "fit.json").read_text(encoding="utf-8"))
    drawn = {f"{f['subject']}/{f['trial']}" for f in fit["figures"] if f["kind"] == "trial"}
    failed = {str(f.get("trial")) for f in summary.get("failed_trials") or []}
    assert drawn == worth | failed
    assert any(f"{len(drawn)} of {len(trials)} trials with a warning that may change a number"
               in n for n in fit["notes"])
