"""The trials go to the workers longest first; the tables do not depend on the order, and
each outcome is kept as it arrives (an analysis stopped half-way keeps what it finished)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from evtribo.acquisition.simulator import TrialConfig, default_subjects, simulate_study
from evtribo.results import pipeline, workers
from evtribo.results.provenance import input_files
from evtribo.study import load_study


@pytest.fixture(scope="module")
def tasks(tmp_path_factory):
    root = tmp_path_factory.mktemp("order") / "study"
    simulate_study(root, default_subjects(3), amplitudes=(80.0, 140.0),
                   config=TrialConfig(duration_s=3.0), sine_trial=True)
    study = load_study(root)
    return study, pipeline._plan(study, input_files(study))[0]


def _work(task) -> float:
    sine = workers.trial_meta(task.ref).waveform == "sine"
    return task.log[1] * (workers.SINE_WORK if sine else 1.0)


@given(st.data())
def test_longest_first_is_every_task_once_by_its_work(tasks, data):
    _, all_tasks = tasks
    chosen = data.draw(st.permutations(all_tasks))
    ordered = workers.longest_first(chosen)
    assert sorted(t.index for t in ordered) == sorted(t.index for t in chosen)
    work = [_work(t) for t in ordered]
    assert work == sorted(work, reverse=True)
    assert any(workers.trial_meta(t.ref).waveform == "sine" for t in ordered[:3])


def test_the_tables_do_not_depend_on_the_order(tasks, tmp_path, monkeypatch):
    study, _ = tasks
    longest = pipeline.compute_study(study, jobs=2, cache_dir=tmp_path / "c1", reuse=False)
    monkeypatch.setattr(workers, "longest_first", lambda ts: list(ts)[::-1])
    reverse = pipeline.compute_study(study, jobs=2, cache_dir=tmp_path / "c2", reuse=False)
    for name in ("trials", "windows", "electrostatic", "exponents", "bootstrap", "sine_trace"):
        a, b = getattr(longest, name), getattr(reverse, name)
        assert a.to_csv(index=False) == b.to_csv(index=False), name


def test_an_analysis_stopped_half_way_keeps_the_trials_it_finished(tasks, tmp_path,
                                                                   monkeypatch):
    study, all_tasks = tasks
    cache = tmp_path / "cache"

    def stop_at_3(done, total):
        if done == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        pipeline.compute_study(study, jobs=1, cache_dir=cache, progress=stop_at_3)
    analysed: list[int] = []
    real = workers.analyze_task
    monkeypatch.setattr(workers, "analyze_task", lambda t: analysed.append(t.index) or real(t))
    pipeline.compute_study(study, jobs=1, cache_dir=cache)
    assert len(analysed) == len(all_tasks) - 3
