"""The Python API of study format §8: what it computes is what the command line writes."""

from __future__ import annotations

import hashlib
import inspect
import json
import shutil
import threading
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

import evtribo
import evtribo.api
from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_study
from evtribo.cli import main
from evtribo.errors import (
    AnalysisError,
    ConfigError,
    OutputBusyError,
    OutputExistsError,
    ResultFolderError,
    StudyError,
    UserInputError,
)
from evtribo.store.resultdir import locked

REFERENCE = Path(__file__).parents[1] / "data" / "reference-study"
TABLES = ("trials", "windows", "electrostatic", "exponents", "bootstrap", "sine_trace")


def _tree(root: Path) -> dict[str, str]:
    """Every file under *root* and the SHA-256 of its bytes."""
    return {p.relative_to(root).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


def _same_as_csv(table: pd.DataFrame, csv: Path,
                 text: tuple[str, ...] = evtribo.api.results.TEXT_COLUMNS) -> None:
    """*table* holds what *csv* holds: the same columns in order, the same rows; numbers
    equal to the last bit (NaN where the file is empty), names equal as text."""
    raw = pd.read_csv(csv, keep_default_na=False, na_values=[""], dtype=str)
    assert list(table.columns) == list(raw.columns)
    assert len(table) == len(raw) > 0
    for c in raw.columns:
        ours = table[c]
        if c in text:
            assert ours.dtype == object, c
            assert ours.isna().tolist() == raw[c].isna().tolist(), c
            assert ours.dropna().tolist() == raw[c].dropna().tolist(), c
        else:
            theirs = pd.to_numeric(raw[c]).to_numpy(float)
            assert ours.dtype in (np.float64, pd.Int64Dtype()), (c, ours.dtype)
            np.testing.assert_array_equal(ours.to_numpy(float, na_value=np.nan), theirs,
                                          err_msg=c)


@pytest.fixture(scope="module")
def simulated(tmp_path_factory) -> Path:
    """A simulated two-subject study (square sweep and a sine trial each)."""
    root = tmp_path_factory.mktemp("api") / "study"
    simulate_study(root, [SubjectParams(name="S1", h_L=4e-6), SubjectParams(name="S2",
                                                                             h_L=7e-6)],
                   amplitudes=(80.0, 140.0), config=TrialConfig(duration_s=6.0))
    return root


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    """The recorded study of data/, copied (a test never writes beside the repository's)."""
    root = tmp_path_factory.mktemp("api-ref") / "reference-study"
    shutil.copytree(REFERENCE, root)
    return root


def test_evtribo_exports_the_api():
    for name in ("open_study", "Study", "Trial", "analyze", "Results", "load_results",
                 "compare", "Fit"):
        assert name in evtribo.__all__
        assert getattr(evtribo, name) is not None
    assert evtribo.open_study is evtribo.api.open_study
    assert evtribo.analyze is evtribo.api.analyze
    # evtribo.compare is the package and, called, the API's compare
    assert callable(evtribo.compare)
    assert evtribo.fit.fit.fit_study is evtribo.fit.fit.fit_study
    with pytest.raises(AttributeError, match="no attribute 'nonesuch'"):
        evtribo.nonesuch  # noqa: B018


def test_api_methods_document_parameters_and_returns():
    from test_api_docs import _missing

    bad = {}
    for cls in (evtribo.Study, evtribo.Trial, evtribo.Results, evtribo.Fit):
        for name, member in vars(cls).items():
            func = member.__func__ if isinstance(member, classmethod) else member
            if name.startswith("_") or not inspect.isfunction(func):
                continue
            if missing := _missing(func):
                bad[f"{cls.__name__}.{name}"] = missing
    assert not bad, bad


def test_open_study_names_the_trials(reference):
    study = evtribo.open_study(reference)
    assert study.subjects == ["P01", "P02", "P03"]
    assert len(study.trials) == 18
    trial = study.trial("P02", "run-06")
    assert (trial.subject, trial.name, trial.key) == ("P02", "run-06", "P02/run-06")
    assert repr(trial) == "Trial('P02/run-06', sine 10 Hz 140 V alternating)"
    assert "18 trials" in repr(study)
    assert trial.meta["waveform"] == "sine" and trial.meta["amplitude_V"] == 140
    assert trial.log_path == reference / "P02" / "run-06.log.gz"
    assert study.rig.normal_force.qualified_name == "FzCell.Fz"
    with pytest.raises(KeyError, match="P02's trials: run-01"):
        study.trial("P02", "run-99")


def test_open_study_raises_the_errors_of_the_command_line(tmp_path):
    with pytest.raises(StudyError, match="no such study folder"):
        evtribo.open_study(tmp_path / "nowhere")
    (tmp_path / "s").mkdir()
    (tmp_path / "s" / "study.toml").write_text("[rig]\ndbc = 3\n", encoding="utf-8")
    with pytest.raises(UserInputError) as err:
        evtribo.open_study(tmp_path / "s")
    assert "study.toml" in str(err.value)


def test_forces_of_a_trial(reference):
    trial = evtribo.open_study(reference).trial("P01", "run-05")
    forces = trial.forces()
    assert list(forces.columns) == ["t_s", "normal_force_N", "tangential_force_N",
                                    "excitation_on", "amplitude_V", "frequency_Hz", "waveform"]
    t = forces["t_s"].to_numpy()
    assert t[0] >= 0 and np.all(np.diff(t) > 0)
    assert 11.5 < t[-1] < 12.5  # a 12-s trial, load cells at 1 kHz
    assert 0.0009 < np.median(np.diff(t)) < 0.0011
    on = forces["excitation_on"]
    assert str(on.dtype) == "boolean"
    assert 0 < on.isna().sum() < 0.02 * len(on)  # unknown only around the switches
    assert set(forces["amplitude_V"].dropna()) <= {0.0, 140.0}
    assert set(forces["waveform"].dropna()) == {"square"}
    # what the simulator did (truth.json; its times from the simulator's start, which is
    # within a few ms of the log's first frame): the ON/OFF schedule, the strokes' direction,
    # the mean normal force ON
    truth = json.loads((REFERENCE / "truth.json").read_text(encoding="utf-8"))
    sim = truth["trials"]["P01/run-05"]["simulation"]
    for start, end, state in sim["schedule"]:
        inside = (t > start + 0.1) & (t < end - 0.1)
        assert on[inside].notna().all() and on[inside].eq(bool(state)).all(), (start, end)
    for start, end, direction in sim["slides"]:
        inside = (t > start + 0.1) & (t < end - 0.1)
        if inside.any():
            ft = forces["tangential_force_N"][inside].dropna()
            assert np.all(np.sign(ft) == direction), (start, end)
    # NaN only in the recording's gaps (the logger missed both cells' frames at times)
    assert 0 < forces["tangential_force_N"].isna().mean() < 0.01
    mean_on = float(forces.loc[on.eq(True).fillna(False).to_numpy(bool), "normal_force_N"].mean())
    assert mean_on == pytest.approx(sim["normal_force_on_N"], abs=0.005)


def test_forces_of_a_trial_whose_load_cells_do_not_overlap(tmp_path):
    import _studies
    from evtribo.canlog.rig import default_rig_path

    log = ("(1763700000.000000) vcan0 0C1#0000000000000000\n"
           "(1763700000.001000) vcan0 0C2#0000000000000000\n")
    rig = {"dbc": "rig/default.dbc", "normal_force": "FzCell.Fz",
           "tangential_force": "FxCell.Fx"}
    root = _studies.make_study(tmp_path / "s", {"P01/run-01": {"condition": "on"}}, rig=rig,
                               log=log, dbc=default_rig_path().with_name("default.dbc"))
    trial = evtribo.open_study(root).trials[0]
    with pytest.raises(AnalysisError, match=r"run-01\.log"):
        trial.forces()


def test_analyze_writes_nothing_and_matches_the_command_line(simulated, tmp_path,
                                                             monkeypatch):
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    monkeypatch.chdir(cwd)
    before, before_cwd = _tree(simulated), _tree(cwd)
    beside = sorted(simulated.parent.iterdir())
    results = evtribo.analyze(evtribo.open_study(simulated), jobs=1)
    assert _tree(simulated) == before and _tree(cwd) == before_cwd == {}
    assert sorted(simulated.parent.iterdir()) == beside
    assert results.out is None and results.fit is None
    out = tmp_path / "cli"
    assert main(["analyze", str(simulated), "--out", str(out), "--jobs", "1"]) == 0
    for name in ("electrostatic", "trials", "windows", "exponents"):
        _same_as_csv(getattr(results, name), out / f"{name}.csv")
    assert results.subjects == ["S1", "S2"]
    # saved, the same files as the command line's, byte for byte (but the run's own
    # identifiers and times in summary.json)
    saved = results.save(tmp_path / "api")
    tables = sorted(p.name for p in out.glob("*.csv"))
    assert tables == sorted(p.name for p in saved.glob("*.csv"))
    assert {"electrostatic.csv", "electrostatic_bootstrap.csv", "sine_trace.csv"} <= set(tables)
    for name in tables:
        assert (saved / name).read_bytes() == (out / name).read_bytes(), name
    ours, theirs = (json.loads((d / "summary.json").read_text(encoding="utf-8"))
                    for d in (saved, out))
    assert ours.keys() == theirs.keys()
    assert ours["output_sha256"] == theirs["output_sha256"]
    for key in ("run_id", "created", "started", "elapsed_s", "inputs"):
        ours.pop(key, None), theirs.pop(key, None)
    assert ours == theirs


def test_analyze_matches_the_command_line_on_the_recorded_study(reference, tmp_path):
    results = evtribo.analyze(reference, jobs=2)
    out = tmp_path / "cli"
    assert main(["analyze", str(reference), "--out", str(out), "--jobs", "2"]) == 0
    _same_as_csv(results.electrostatic, out / "electrostatic.csv")
    assert len(results.electrostatic) == 18  # 3 subjects x (5 square + 1 sine)


def test_analyze_takes_settings_by_name(simulated):
    with pytest.raises(ConfigError, match="guard_sec"):
        evtribo.analyze(simulated, jobs=1, guard_sec=0.3)
    results = evtribo.analyze(simulated, jobs=1, n_boot=100, seed=3)
    assert results.summary["settings"]["n_boot"] == 100
    assert results.summary["settings"]["seed"] == 3


def test_save_then_load_gives_the_same_results(simulated, tmp_path):
    results = evtribo.analyze(simulated, jobs=1)
    out = tmp_path / "out"
    assert results.save(out) == out
    assert results.out == out
    loaded = evtribo.load_results(out)
    for name in TABLES:
        pd.testing.assert_frame_equal(getattr(loaded, name), getattr(results, name))
    assert loaded.summary == results.summary
    assert loaded.summary["output_sha256"].keys() >= {"electrostatic.csv", "trials.csv"}
    assert loaded.fit is None
    with pytest.raises(UserInputError, match="saved already"):
        loaded.save(tmp_path / "elsewhere")


def test_save_follows_the_rules_of_the_command_line(simulated, tmp_path):
    results = evtribo.analyze(simulated, jobs=1)
    out = tmp_path / "out"
    results.save(out)
    (out / "notes.txt").write_text("mine", encoding="utf-8")
    first = _tree(out)
    with pytest.raises(OutputExistsError, match="--force"):
        results.save(out)
    assert _tree(out) == first
    with pytest.raises(UserInputError, match="inside the study folder"):
        results.save(simulated / "results")
    assert not (simulated / "results").exists()
    held, release = threading.Event(), threading.Event()

    def hold() -> None:
        with locked(out, "another analysis"):
            held.set()
            release.wait(10)

    holder = threading.Thread(target=hold)
    holder.start()
    try:
        held.wait(10)
        with pytest.raises(OutputBusyError, match="another analysis"):
            results.save(out, force=True)
    finally:
        release.set()
        holder.join()
    assert _tree(out) == first
    results.save(out, force=True)
    assert (out / "notes.txt").read_text(encoding="utf-8") == "mine"
    assert evtribo.load_results(out).summary["run_id"] == results.summary["run_id"]


def test_load_results_refuses_what_is_not_one_analysis(simulated, tmp_path):
    with pytest.raises(UserInputError, match="no such result folder"):
        evtribo.load_results(tmp_path / "none")
    (tmp_path / "empty").mkdir()
    with pytest.raises(UserInputError, match=r"summary\.json"):
        evtribo.load_results(tmp_path / "empty")
    out = tmp_path / "out"
    evtribo.analyze(simulated, jobs=1).save(out)
    with (out / "electrostatic.csv").open("a", encoding="utf-8") as fh:
        fh.write("S9,square,10000,80,0.5,0.5,0.5,0.3,0.25,0.01,0.0,0.02,3,3\n")
    with pytest.raises(ResultFolderError, match=r"electrostatic\.csv"):
        evtribo.load_results(out)


def test_compare_fits_as_the_command_line(simulated, tmp_path):
    results = evtribo.analyze(simulated, jobs=1)
    fit = evtribo.compare(results)
    assert results.fit is fit
    assert fit.fitted == ("h_L",)
    assert list(fit.table["subject"]) == ["S1", "S2"]
    # the air gaps the simulator was given, within their intervals' reach
    h = dict(zip(fit.table["subject"], fit.table["value"], strict=True))
    assert h["S1"] == pytest.approx(4e-6, rel=0.15) and h["S2"] == pytest.approx(7e-6, rel=0.15)
    assert {"electrostatic_force_S1", "electrostatic_force_S2", "area_increase",
            "friction_time"} <= set(fit.figures)
    assert all(isinstance(f, Figure) and f.axes for f in fit.figures.values())
    assert [r["stem"] for r in fit.records] == list(fit.figures)
    assert fit.out is None and fit.files == {}
    with pytest.raises(UserInputError, match=r"results.save\(OUT\)"):
        fit.save()

    out = tmp_path / "out"
    results.save(out)
    assert results.fit is fit  # an unsaved fit stays the results' fit
    assert main(["compare", str(out)]) == 0
    _same_as_csv(fit.table, out / "fit.csv", text=evtribo.api.fit.FIT_TEXT_COLUMNS)
    loaded = evtribo.load_results(out)
    assert loaded.fit is not None and loaded.fit.figures == {}
    pd.testing.assert_frame_equal(loaded.fit.table, fit.table)
    assert all(files for files in loaded.fit.files.values())


def test_fit_save_writes_what_compare_writes(simulated, tmp_path):
    results = evtribo.analyze(simulated, jobs=1)
    out = tmp_path / "out"
    results.save(out)
    fit = evtribo.compare(results, "h_L")
    assert fit.save() == out
    assert fit.out == out and (out / "fit.json").is_file()
    assert all(p.is_file() for files in fit.files.values() for p in files)
    pd.testing.assert_frame_equal(evtribo.load_results(out).fit.table, fit.table)
    with pytest.raises(OutputExistsError):
        fit.save()
    fit.save(force=True)


def test_a_fit_of_another_analysis_is_not_loaded(simulated, tmp_path):
    out = tmp_path / "out"
    results = evtribo.analyze(simulated, jobs=1)
    results.save(out)
    evtribo.compare(results).save()
    doc = json.loads((out / "fit.json").read_text(encoding="utf-8"))
    doc["run_id"] = "0" * 32
    (out / "fit.json").write_text(json.dumps(doc), encoding="utf-8")
    with pytest.warns(UserWarning, match="not these results"):
        loaded = evtribo.load_results(out)
    assert loaded.fit is None


def test_compare_refuses_unknown_parameters_and_empty_results(simulated):
    results = evtribo.analyze(simulated, jobs=1)
    with pytest.raises(ConfigError, match="h_X"):
        evtribo.compare(results, fit="h_X")
    results.electrostatic = results.electrostatic.iloc[:0]
    only_mu = evtribo.compare(results)  # OFF windows still give each subject's friction
    assert only_mu.fits == [] and any(s.startswith("friction_normal_force")
                                      for s in only_mu.figures)
    results.windows = results.windows.iloc[:0]
    with pytest.raises(UserInputError, match="nothing to compare"):
        evtribo.compare(results)


def test_the_api_page_is_up_to_date():
    import importlib.util

    script = Path(__file__).parents[1] / "scripts" / "api_doc.py"
    spec = importlib.util.spec_from_file_location("api_doc", script)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    page = module.PAGE.read_text(encoding="utf-8")
    assert page == module.page(), "docs/api.md is out of date: python scripts/api_doc.py"
    for name in evtribo.api.__all__:
        assert f"## `evtribo.{name}`" in page


def test_a_trials_table_of_an_earlier_version_is_read_with_the_newer_columns_empty(tmp_path):
    """trials.csv as evtribo 0.2.0 wrote it (no seconds analysed and left out, no duplicate
    frames): read, those columns empty; a column 0.2.0 wrote missing is still refused."""
    from evtribo.analysis.trial import TRIAL_COLUMNS
    from evtribo.api.results import NEWER_COLUMNS, read_table
    from evtribo.errors import UserInputError

    newer = sorted(NEWER_COLUMNS & set(TRIAL_COLUMNS))
    assert "analysed_s" in newer
    old = [c for c in TRIAL_COLUMNS if c not in NEWER_COLUMNS]
    row = {c: ("P01" if c == "subject" else "run-01" if c == "trial" else "1") for c in old}
    path = tmp_path / "trials.csv"
    pd.DataFrame([row], columns=old).to_csv(path, index=False)
    table = read_table(path, TRIAL_COLUMNS)
    assert set(newer) <= set(table.columns)
    assert table[newer].isna().all().all()
    pd.DataFrame([row], columns=old).drop(columns="frames").to_csv(path, index=False)
    with pytest.raises(UserInputError, match="frames"):
        read_table(path, TRIAL_COLUMNS)
