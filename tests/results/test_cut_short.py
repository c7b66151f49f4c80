"""A trial whose recording was interrupted (Ctrl-C or SIGTERM before its --duration) or
ended by a fault stays in the study and is analysed as recorded; ``analyze`` says so, in
its output and in summary.json's warnings (which the report shows)."""

from __future__ import annotations

import json

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, write_trial
from evtribo.cli import main
from evtribo.study import load_study


def _recorded(sidecar, **how):
    doc = json.loads(sidecar.read_text())
    doc.update(how)
    sidecar.write_text(json.dumps(doc))


def test_an_interrupted_trial_is_named_where_the_results_are(tmp_path, capsys, caplog):
    study = tmp_path / "study"
    for trial in ("run-01", "run-02", "run-03", "run-04"):
        write_trial(study, trial, SubjectParams(), TrialConfig(duration_s=6.0, seed=1))
    folder = study / "P01"
    _recorded(folder / "run-02.json", ended="interrupted", requested_duration_s=30.0,
              duration_s=6.2)
    _recorded(folder / "run-03.json", ended="bus-error", requested_duration_s=30.0,
              duration_s=4.0)
    # stopped by hand with no duration asked: how such a recording ends, nothing to say
    _recorded(folder / "run-04.json", ended="interrupted", requested_duration_s=None,
              duration_s=6.0)
    said = [w.text for w in load_study(study).warnings if w.kind == "cut-short"]
    assert said == [
        f"{folder / 'run-02.log'}: the recording was interrupted (Ctrl-C or SIGTERM) after "
        "6.2 s of the 30 s asked; analysing what was recorded",
        f"{folder / 'run-03.log'}: the recording was ended by a bus fault after 4.0 s of "
        "the 30 s asked; analysing what was recorded"]
    assert main(["analyze", str(study), "--out", str(tmp_path / "out"), "--jobs", "1"]) == 0
    err = capsys.readouterr().err
    assert "recordings cut short" in err and "not classified" not in err
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    for line in said:  # on analyze's standard error (logged), and in summary.json
        assert line in caplog.messages and line in [w["text"] for w in summary["warnings"]]
