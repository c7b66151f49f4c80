"""What analyze keeps of each trial for its check (its sketch): the same bytes as a new
analysis of the trial gives, found again by compare under the analysis's key, and read back
as written."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from analysed import analysed_study
from evtribo.results.trial_sketch import SketchPiece, Stretch, TrialSketch
from evtribo.results.trial_view import kept_sketches, sketch_of, view_trial
from evtribo.study import load_study

_floats = st.floats(-1e3, 1e3, allow_nan=False, width=32)


@st.composite
def _pieces(draw):
    n = draw(st.integers(0, 40))
    m = draw(st.integers(0, 5))
    arr = st.lists(_floats, min_size=n, max_size=n)
    return SketchPiece(np.asarray(draw(arr), np.float32), np.asarray(draw(arr), np.float32),
                       np.asarray(draw(arr), np.float32),
                       (draw(_floats), draw(_floats)),
                       np.asarray(draw(st.lists(_floats, min_size=2 * m, max_size=2 * m)),
                                  np.float64).reshape(-1, 2),
                       np.asarray(draw(st.lists(_floats, min_size=4 * m, max_size=4 * m)),
                                  np.float64).reshape(-1, 4),
                       np.asarray(draw(st.lists(st.booleans(), min_size=m, max_size=m)), bool),
                       [Stretch(draw(_floats), draw(_floats), draw(st.sampled_from(
                           ["lifted", "switch", "hole", "pause"])))
                        for _ in range(draw(st.integers(0, 3)))])


@given(subject=st.text(min_size=1, max_size=8), trial=st.text(min_size=1, max_size=8),
       pieces=st.lists(_pieces(), max_size=3),
       amplitude=st.one_of(st.none(), st.floats(0, 300, allow_nan=False)))
def test_a_sketch_reads_back_as_written(subject, trial, pieces, amplitude):
    sketch = TrialSketch(subject, trial, pieces, {"waveform": "square", "frequency_Hz": 10.0,
                                                  "amplitude_V": amplitude, "tare": None})
    data = sketch.to_bytes()
    again = TrialSketch.from_bytes(data)
    assert again.to_bytes() == data
    assert (again.subject, again.trial, again.row) == (subject, trial, sketch.row)
    assert again.stretches == sketch.stretches
    for a, b in zip(again.pieces, pieces, strict=True):
        for name in ("t", "normal", "tangential", "on", "windows", "window_on"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    with pytest.raises(ValueError):
        TrialSketch.from_bytes(data + b"x")
    with pytest.raises(ValueError):
        TrialSketch.from_bytes(b"not a sketch" + data)


@pytest.fixture(scope="module")
def analysed(tmp_path_factory):
    return analysed_study(tmp_path_factory.mktemp("sketch"))


def test_compare_finds_what_analyze_kept_and_it_is_what_an_analysis_gives(analysed):
    study_dir, out = analysed
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    study = load_study(study_dir)
    cache = study_dir.parent / "cache"  # the cache folder the analysis used
    kept = kept_sketches(study, summary, cache)
    assert sorted(kept) == sorted(t.key for t in study.trials)  # every trial's
    for ref in study.trials:
        again = sketch_of(view_trial(study, ref.subject, ref.name,
                                      settings=summary["settings"], cache_dir=cache))
        assert kept[ref.key].to_bytes() == again.to_bytes(), ref.key
        assert 1_000 < len(again.to_bytes()) < 200_000  # a few tens of kB
    # other settings than the analysis's: not its sketches
    other = {**summary, "settings": {**summary["settings"], "min_window_s": 0.9}}
    assert kept_sketches(study, other, cache) == {}
    assert kept_sketches(study, summary, study_dir.parent / "another") == {}


def test_a_study_analysed_by_a_relative_path_has_its_sketches_found(tmp_path, monkeypatch):
    """compare loads the study from summary.json's absolute path; analyze was given the
    study as the user typed it (``evtribo analyze study --out out``): the sketches it kept
    are found all the same, and again after the study folder is moved."""
    from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_study
    from evtribo.results.pipeline import analyze_study

    simulate_study(tmp_path / "study", [SubjectParams(name="P01")], amplitudes=(120.0,),
                   config=TrialConfig(duration_s=4.0))
    monkeypatch.chdir(tmp_path)
    analyze_study("study", "out", jobs=1, cache_dir="cache")
    summary = json.loads((tmp_path / "out" / "summary.json").read_text(encoding="utf-8"))
    assert summary["study_dir"] == str(tmp_path / "study")
    keys = sorted(t.key for t in load_study(tmp_path / "study").trials)
    assert len(keys) == 2
    assert sorted(kept_sketches(load_study(summary["study_dir"]), summary,
                                tmp_path / "cache")) == keys
    (tmp_path / "study").rename(tmp_path / "moved")
    assert sorted(kept_sketches(load_study(tmp_path / "moved"), summary,
                                tmp_path / "cache")) == keys
