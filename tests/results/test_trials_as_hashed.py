"""Each trial is analysed as it was when the analysis started, and counted once.

- the workers get the trials the analysis listed (paths, sidecars, log hashes): a trial
  added during the analysis is not analysed in place of another;
- each input is hashed once, and summary.json's hashes are those of the bytes analysed (a
  log changed after it was hashed is not analysed, or is analysed as it was hashed);
- the same log under two trial names is one recording: counted once, with a warning.
"""

from __future__ import annotations

import collections
import hashlib
import json
import shutil

import pandas as pd
import pytest

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_study
from evtribo.canlog import cache
from evtribo.cli import main
from evtribo.results import pipeline, provenance
from evtribo.store import memo


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    root = tmp_path_factory.mktemp("hashed") / "study"
    simulate_study(root, [SubjectParams(name="P01")], amplitudes=(80.0, 140.0),
                   config=TrialConfig(duration_s=6.0), sine_trial=False)
    return root


@pytest.fixture(scope="module")
def baseline(study, tmp_path_factory):
    """The study analysed as it is."""
    out = tmp_path_factory.mktemp("baseline") / "out"
    pipeline.analyze_study(study, out, jobs=1)
    return out


def _copy(study, tmp_path):
    return shutil.copytree(study, tmp_path / "study")


@pytest.mark.parametrize("jobs", [1, 2])
def test_a_trial_added_during_the_analysis_is_not_analysed_in_place_of_another(
        study, baseline, tmp_path, monkeypatch, jobs):
    root = _copy(study, tmp_path)
    real = pipeline.study_settings

    def add_a_trial(*args, **kwargs):  # after the study was listed, before any trial is read
        shutil.copy(root / "P01" / "run-01.log", root / "P01" / "run-00.log")
        side = json.loads((root / "P01" / "run-01.json").read_text())
        side["amplitude_V"] = 200.0
        (root / "P01" / "run-00.json").write_text(json.dumps(side))
        return real(*args, **kwargs)

    monkeypatch.setattr(pipeline, "study_settings", add_a_trial)
    res = pipeline.analyze_study(root, tmp_path / "out", jobs=jobs)
    assert list(res.trials.trial) == ["run-01", "run-02"]
    assert res.summary["trials"] == res.summary["trials_analysed"] == 2
    assert {r["file"] for r in res.summary["inputs"]} >= {"P01/run-01.log", "P01/run-02.log"}
    assert "P01/run-00.log" not in {r["file"] for r in res.summary["inputs"]}
    for name in ("trials.csv", "windows.csv", "electrostatic.csv"):
        assert (tmp_path / "out" / name).read_bytes() == (baseline / name).read_bytes(), name


def test_each_input_is_hashed_once(study, tmp_path, monkeypatch):
    hashed = collections.Counter()

    def counting(real):
        def digest(path):
            hashed[str(path)] += 1
            return real(path)
        return digest

    monkeypatch.setattr(provenance, "sha256_file", counting(provenance.sha256_file))
    monkeypatch.setattr(memo, "sha256_file", counting(memo.sha256_file))
    monkeypatch.setattr(cache, "sha256_log", counting(cache.sha256_log))
    for k in range(2):  # decoded, then from the cache (where an input unchanged since it
        hashed.clear()  # was hashed, a few seconds before, is not hashed again)
        res = pipeline.analyze_study(study, tmp_path / f"out{k}", jobs=1,
                                     cache_dir=tmp_path / "cache")
        logs = [p for p in hashed if p.endswith(".log")]
        assert set(hashed.values()) <= {1}, hashed
        assert len(logs) == 2 or k == 1, hashed
        for rec in res.summary["inputs"]:
            data = (study / rec["file"]).read_bytes()
            assert rec["sha256"] == hashlib.sha256(data).hexdigest()


def test_a_log_changed_after_it_was_hashed_is_not_analysed_as_another_file(
        study, tmp_path, monkeypatch):
    root = _copy(study, tmp_path)
    log = root / "P01" / "run-02.log"
    original = hashlib.sha256(log.read_bytes()).hexdigest()
    real = pipeline.input_files

    def then_change(study_, *more):
        records = real(study_, *more)
        with log.open("a") as fh:
            fh.write("(1763700099.000000) vcan0 7FF#00\n")
        return records

    monkeypatch.setattr(pipeline, "input_files", then_change)
    # a cache without this log: it must be read again, and is no longer the file hashed
    res = pipeline.analyze_study(root, tmp_path / "out", jobs=1, cache_dir=tmp_path / "c1")
    [failed] = res.summary["failed_trials"]
    assert failed["trial"] == "P01/run-02" and "changed since the analysis started" in \
        failed["error"]
    assert list(res.electrostatic.amplitude_V) == [80.0]
    recorded = {r["file"]: r["sha256"] for r in res.summary["inputs"]}
    assert recorded["P01/run-02.log"] == original
    assert any("run-02.log: changed during the analysis" in w["text"]
               for w in res.summary["warnings"])
    # with the bytes of that hash in the cache, they are what is analysed
    shutil.copy(study / "P01" / "run-02.log", log)
    monkeypatch.setattr(pipeline, "input_files", real)
    pipeline.analyze_study(root, tmp_path / "warm", jobs=1, cache_dir=tmp_path / "c2")
    monkeypatch.setattr(pipeline, "input_files", then_change)
    res = pipeline.analyze_study(root, tmp_path / "out2", jobs=1, cache_dir=tmp_path / "c2")
    assert res.summary["failed_trials"] == []
    assert list(res.electrostatic.amplitude_V) == [80.0, 140.0]
    assert {r["file"]: r["sha256"] for r in res.summary["inputs"]}["P01/run-02.log"] == \
        original


@pytest.mark.parametrize("copy", ["P01/run-03", "P02/run-01"])
def test_the_same_log_under_two_names_is_counted_once(study, baseline, tmp_path, capsys,
                                                      copy):
    folder, trial = copy.split("/")
    root = _copy(study, tmp_path)
    (root / folder).mkdir(exist_ok=True)
    shutil.copy(root / "P01" / "run-02.log", root / folder / f"{trial}.log")
    side = json.loads((root / "P01" / "run-02.json").read_text())
    side["subject"] = folder
    (root / folder / f"{trial}.json").write_text(json.dumps(side))
    out = tmp_path / "out"
    assert main(["analyze", str(root), "--out", str(out), "--jobs", "2"]) == 0
    printed = capsys.readouterr().out
    assert "analysed 2 of 3 trials; 1 the same log as another trial, counted once" in printed
    summary = json.loads((out / "summary.json").read_text())
    dup = summary["duplicate_trials"]
    assert [(d["trial"], d["same_as"]) for d in dup] == [(f"{folder}/{trial}", "P01/run-02")]
    assert any(f"{folder}/{trial}" in w["text"] and "P01/run-02" in w["text"]
               and w["kind"] == "same-log" for w in summary["warnings"])
    # the estimates are those of the study without the copy
    for name in ("windows.csv", "electrostatic.csv", "exponents.csv",
                 "electrostatic_bootstrap.csv"):
        assert (out / name).read_bytes() == (baseline / name).read_bytes(), name
    assert list(pd.read_csv(out / "trials.csv").trial) == ["run-01", "run-02"]


def test_a_duplicate_with_other_sidecar_values_says_which_are_used(study, tmp_path):
    root = _copy(study, tmp_path)
    shutil.copy(root / "P01" / "run-02.log", root / "P01" / "run-03.log")
    side = json.loads((root / "P01" / "run-02.json").read_text())
    side["amplitude_V"] = 120.0
    (root / "P01" / "run-03.json").write_text(json.dumps(side))
    res = pipeline.analyze_study(root, tmp_path / "out", jobs=1)
    [warning] = [w["text"] for w in res.summary["warnings"] if w["kind"] == "same-log"]
    assert "sidecars differ in amplitude_V (P01/run-02's values are used)" in warning
    assert sorted(res.electrostatic.amplitude_V) == [80.0, 140.0]
