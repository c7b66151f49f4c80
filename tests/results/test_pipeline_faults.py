"""A fault in one trial's analysis is reported for that trial; the study goes on."""

import json

import pandas as pd
import pytest

from _faults import fail_trial
from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_study
from evtribo.results import pipeline


def test_unexpected_fault_in_one_trial_is_reported_not_fatal(tmp_path, monkeypatch):
    study = tmp_path / "study"
    simulate_study(study, [SubjectParams(name="P01")], amplitudes=(80.0, 140.0),
                   config=TrialConfig(duration_s=8.0), sine_trial=False)
    fail_trial(monkeypatch, "run-02")
    res = pipeline.analyze_study(study, tmp_path / "out", jobs=1)
    trials = pd.read_csv(tmp_path / "out" / "trials.csv")
    assert list(trials.trial) == ["run-01", "run-02"]
    assert trials.frames.iloc[0] > 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert "ZeroDivisionError: a fault nobody planned for" in json.dumps(summary)
    assert res.summary["trials_analysed"] == 1
    with pytest.raises(ZeroDivisionError):
        pipeline.analyze_study(study, tmp_path / "out2", jobs=1, strict=True)
