"""The trials that import scipy.signal go to one worker process, together; every trial is
analysed once, and the tables do not depend on how the trials were grouped."""

from __future__ import annotations

import dataclasses

import pytest
from hypothesis import given
from hypothesis import strategies as st

from evtribo.acquisition.simulator import TrialConfig, default_subjects, simulate_study
from evtribo.analysis import pipeline, workers
from evtribo.analysis.provenance import input_files
from evtribo.analysis.settings import AnalysisSettings
from evtribo.study import load_study


@pytest.fixture(scope="module")
def tasks(tmp_path_factory):
    root = tmp_path_factory.mktemp("batches") / "study"
    simulate_study(root, default_subjects(3), amplitudes=(80.0, 140.0),
                   config=TrialConfig(duration_s=3.0), sine_trial=True)
    study = load_study(root)
    return study, pipeline._plan(study, input_files(study))[0]


def _waveform(task) -> str:
    return workers.trial_meta(task.ref).waveform


@given(st.integers(1, 8), st.sampled_from(["auto", "remove", "keep"]), st.data())
def test_every_trial_once_the_filtering_ones_together(tasks, jobs, hum, data):
    _, all_tasks = tasks
    chosen = data.draw(st.lists(st.sampled_from(all_tasks), unique_by=lambda t: t.index,
                                min_size=1))
    settings = dataclasses.replace(AnalysisSettings(), hum=hum)
    groups = workers.batches(chosen, jobs, settings)
    assert sorted(t.index for g in groups for t in g) == sorted(t.index for t in chosen)
    sines = [t for t in chosen if _waveform(t) == "sine"]
    squares = [t for t in chosen if _waveform(t) != "sine"]
    if hum != "remove" and len(sines) >= 2 and squares and jobs >= 2:
        share = -(-len(chosen) // jobs)
        heavy = [g for g in groups if any(_waveform(t) == "sine" for t in g)]
        assert groups[:len(heavy)] == heavy  # first
        assert len(heavy) == -(-len(sines) // share)  # as few as a worker's share allows
        assert all(len(g) <= share and all(_waveform(t) == "sine" for t in g) for g in heavy)
        assert all(len(g) == 1 for g in groups[len(heavy):])
    else:
        assert all(len(g) == 1 for g in groups)


def test_the_tables_do_not_depend_on_the_grouping(tasks, tmp_path, monkeypatch):
    study, _ = tasks
    grouped = pipeline.compute_study(study, jobs=2, cache_dir=tmp_path / "c1", reuse=False)
    monkeypatch.setattr(workers, "batches", lambda ts, *a: [[t] for t in ts])
    alone = pipeline.compute_study(study, jobs=2, cache_dir=tmp_path / "c2", reuse=False)
    for name in ("trials", "windows", "electrostatic", "exponents", "bootstrap", "sine_trace"):
        a, b = getattr(grouped, name), getattr(alone, name)
        assert a.to_csv(index=False) == b.to_csv(index=False), name
