"""The report's warnings: summary.json's records, and those its tables say besides (a failed
trial summary.json does not say, dropped frames, damaged lines summary.json has no record
of), each once: damaged lines are one record, not the summary's and the report's own."""

from __future__ import annotations

from types import SimpleNamespace

import pandas as pd

from evtribo.documents.summary import Summary
from evtribo.report.study_report import _warnings
from evtribo.warning.catalogue import kind
from evtribo.warning.record import Scope


def _tables(warnings, trials, failed=()):
    summary = Summary({"subjects": ["P01"], "warnings": warnings, "failed_trials": list(failed),
                       "inputs": [{"file": "P01/run-01.asc", "role": "log", "sha256": "0"}]})
    return SimpleNamespace(summary=summary, trials=pd.DataFrame(trials))


def test_damaged_lines_are_one_record_and_dropped_frames_one_more():
    said = kind("damaged-lines").record(Scope("P01", "run-01"),
                                        {"lines": 3, "log": "study/P01/run-01.asc"})
    tables = _tables([said.as_json()], {"subject": ["P01", "P01"],
                                        "trial": ["run-01", "run-02"],
                                        "dropped_frames": [0, 12], "skipped_lines": [3, 0]})
    got = _warnings(tables)
    assert [(w.kind, w.scope.trial) for w in got] == [("damaged-lines", "run-01"),
                                                      ("frames-lost", "run-02")]
    assert got[1].text == "P01/run-02: 12 dropped frame(s)"


def test_an_earlier_folder_s_damaged_lines_and_failed_trial_are_said_once_each():
    tables = _tables(["P01/run-01: 3 damaged line(s) skipped in study/P01/run-01.asc",
                      "P01/run-02: not analysed: no samples"],
                     {"subject": ["P01", "P01"], "trial": ["run-01", "run-02"],
                      "dropped_frames": [0, 0], "skipped_lines": [3, 0]},
                     failed=[{"trial": "P01/run-02", "error": "no samples"}])
    assert [(w.kind, w.scope.trial) for w in _warnings(tables)] == [
        ("damaged-lines", "run-01"), ("not-analysed", "run-02")]
    missing = _tables([], {"subject": ["P01"], "trial": ["run-01"], "dropped_frames": [0],
                           "skipped_lines": [2]},
                      failed=[{"trial": "P01/run-03", "error": "no samples"}])
    assert [w.text for w in _warnings(missing)] == [
        "P01/run-03: not analysed: no samples",
        "P01/run-01: 2 damaged line(s) skipped in P01/run-01.asc"]
