"""ResultFolder, the one object of a result folder: a subject's cell found by key whatever
the rows' order, names read as they are written, compare's documents read when first asked
for and refused when they are not those of the analysis in the folder."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st

from evtribo.cli import main
from evtribo.documents.population_table import PRIMARY, Drive
from evtribo.documents.result_folder import ResultFolder
from evtribo.documents.tables import ELECTROSTATIC, TRIALS, WINDOWS
from evtribo.errors import ResultFolderError
from evtribo.fit.tables import read_results

REFERENCE = Path(__file__).parents[2] / "data" / "reference-study"


def _electrostatic(rows: list[dict]) -> pd.DataFrame:
    base = {**dict.fromkeys(ELECTROSTATIC.names(), 0.1), "n_on": 3, "n_off": 4,
            "friction_law": "amontons"}
    return pd.DataFrame([{**base, **r} for r in rows], columns=list(ELECTROSTATIC.names()))


def _folder(tmp: Path, electrostatic: pd.DataFrame) -> Path:
    """A result folder of an older evtribo (no run_id in summary.json): read as it is."""
    tmp.mkdir(parents=True, exist_ok=True)
    (tmp / "summary.json").write_text('{"study": "older"}\n')
    (tmp / ELECTROSTATIC.file).write_text(ELECTROSTATIC.text(electrostatic))
    windows = pd.DataFrame([{"subject": s, "trial": "run-01", "condition": "on",
                             "amplitude_V": 80.0, "waveform": "square",
                             "normal_force_N": 0.5, "friction_force_N": 0.3}
                            for s in electrostatic["subject"]])
    (tmp / WINDOWS.file).write_text(WINDOWS.text(windows))
    (tmp / TRIALS.file).write_text(TRIALS.text(windows[["subject", "trial"]]))
    return tmp


def test_a_subject_named_na_is_read_as_its_name(tmp_path):
    """A subject named ``NA`` (or ``None``, ``null``) is that subject, not a missing name,
    in every table compare and report read."""
    es = _electrostatic([{"subject": name, "waveform": "square", "frequency_Hz": 10000.0,
                          "amplitude_V": 80.0} for name in ("NA", "None", "null", "P04")])
    tables = read_results(_folder(tmp_path / "out", es))
    assert tables.subjects == ["NA", "None", "null", "P04"]
    assert tables.all_subjects == ["NA", "None", "null", "P04"]
    assert list(tables.trials["subject"]) == ["NA", "None", "null", "P04"]


_SUBJECTS = ("P01", "P02", "NA")
_DRIVES = (("square", 10000.0), ("square", 250.0), ("sine", 10.0), ("sine", None))
_AMPLITUDES = (60.0, 80.0, 142.5)


@given(st.lists(st.tuples(st.sampled_from(_SUBJECTS), st.sampled_from(_DRIVES),
                          st.sampled_from(_AMPLITUDES)), min_size=1, max_size=20,
                unique=True),
       st.randoms(use_true_random=False), st.floats(-4e-7, 4e-7))
def test_a_cell_is_found_by_its_key_whatever_the_order(keys, rnd, jitter):
    """Each row of electrostatic.csv is the cell of its subject, drive and amplitude, in any
    order of the rows, its frequency and amplitude as written (to a millionth); a key the
    table lacks has no cell."""
    rows = [{"subject": s, "waveform": w, "frequency_Hz": f, "amplitude_V": a,
             "electrostatic_force_N": i / 10} for i, (s, (w, f), a) in enumerate(keys)]
    rnd.shuffle(rows)
    folder = ResultFolder.in_memory({"electrostatic": _electrostatic(rows),
                                     "windows": WINDOWS.empty(), "trials": TRIALS.empty(),
                                     "exponents": pd.DataFrame()}, {})
    for i, (s, (w, f), a) in enumerate(keys):
        cell = folder.cell(s, Drive(w, None if f is None else f + jitter), a + jitter)
        assert cell is not None and cell["electrostatic_force_N"] == i / 10
    assert folder.drives == sorted({Drive(w, f) for _, (w, f), _ in keys})
    absent = next((k for k in ((s, d, a) for s in _SUBJECTS for d in _DRIVES
                               for a in _AMPLITUDES) if k not in keys), None)
    if absent is not None:
        assert folder.cell(absent[0], Drive(*absent[1]), absent[2]) is None


def test_two_rows_of_one_cell_are_refused(tmp_path):
    row = {"subject": "P01", "waveform": "square", "frequency_Hz": 10000.0,
           "amplitude_V": 80.0}
    tables = read_results(_folder(tmp_path / "out", _electrostatic([row, row])))
    with pytest.raises(ResultFolderError, match="2 rows of P01"):
        tables.cell("P01", Drive("square", 10000.0), 80.0)


@pytest.fixture(scope="module")
def compared(tmp_path_factory) -> Path:
    """The recorded study of data/ analysed and compared."""
    base = tmp_path_factory.mktemp("folder")
    study, out, cache = base / "study", base / "out", base / "cache"
    shutil.copytree(REFERENCE, study)
    assert main(["analyze", str(study), "--out", str(out), "--jobs", "1", "--cache-dir",
                 str(cache)]) == 0
    assert main(["compare", str(out), "--jobs", "1", "--no-trial-checks", "--dpi", "20",
                 "--cache-dir", str(cache)]) == 0
    return out


def test_compares_documents_are_read_when_asked_for(compared):
    folder = ResultFolder.open(compared)
    assert "fit_doc" not in vars(folder)  # nothing of compare's read yet
    assert folder.fit_doc.run_id == folder.summary.run_id
    assert folder.fit_table is not None and set(folder.fit_table["subject"]) == \
        set(folder.subjects)
    assert folder.models is None  # compare was not asked for the models
    drive = Drive("square", 10000.0)
    assert folder.population is not None and drive in folder.population.drives()
    row = folder.population.row("exponent", drive, analysis=PRIMARY)
    assert row is not None and row.n_subjects == 3
    assert folder.contrasts is not None and folder.population_subjects is not None
    folder.check_fit()
    memory = ResultFolder.in_memory(folder.tables, folder.summary)
    assert not memory.fit_doc and memory.population is None and memory.fit_table is None


def test_a_table_of_compare_not_the_one_it_wrote_is_refused(compared, tmp_path):
    out = shutil.copytree(compared, tmp_path / "out", symlinks=True)
    population = out / "population.csv"
    population.write_text(population.read_text().replace("primary", "primary ", 1))
    with pytest.raises(ResultFolderError, match="not the file compare wrote") as err:
        ResultFolder.open(out).population  # noqa: B018
    assert err.value.path == str(population)
    assert "evtribo compare" in str(err.value)


def test_compares_documents_of_another_analysis_are_refused(compared, tmp_path):
    out = shutil.copytree(compared, tmp_path / "out", symlinks=True)
    fit = json.loads((out / "fit.json").read_text())
    fit["run_id"] = "0" * 32
    (out / "fit.json").write_text(json.dumps(fit))
    folder = ResultFolder.open(out)
    with pytest.raises(ResultFolderError, match="another analysis") as err:
        folder.fit_table  # noqa: B018
    assert err.value.path == str(out / "fit.csv")
    with pytest.raises(ResultFolderError, match="another analysis"):
        folder.check_fit()


def test_an_older_folder_without_trials_is_read(tmp_path):
    es = _electrostatic([{"subject": "P01", "waveform": "square", "frequency_Hz": 10000.0,
                          "amplitude_V": 80.0}])
    out = _folder(tmp_path / "out", es)
    (out / TRIALS.file).unlink()
    es.drop(columns=sorted(ELECTROSTATIC.newer)).to_csv(out / ELECTROSTATIC.file, index=False)
    tables = read_results(out)
    assert tables.trials.empty and list(tables.trials.columns) == list(TRIALS.required)
    assert tables.electrostatic["friction_law"].isna().all()  # not written: read as empty
