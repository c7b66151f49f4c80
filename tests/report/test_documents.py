"""summary.json and fit.json through their document modules: the writers reproduce what
analyze and compare write, byte for byte; the readers refuse a file that is not whole or a
key of the wrong kind, naming the file and the key; compare writes fit.csv atomically."""

from __future__ import annotations

import json

import pytest

from analysed import analysed_study
from evtribo.cli import main
from evtribo.documents.fit import FIT_KEYS, fit_text, read_fit
from evtribo.documents.summary import SUMMARY_KEYS, read_summary, summary_text
from evtribo.errors import ResultFolderError
from evtribo.report import compare as compare_run
from evtribo.report.compare import compare


@pytest.fixture(scope="module")
def compared(tmp_path_factory):
    _, out = analysed_study(tmp_path_factory.mktemp("doc"))
    compare(out, dpi=30, formats=("png",))
    return out


def test_summary_writer_reproduces_what_analyze_writes(compared):
    raw = (compared / "summary.json").read_text(encoding="utf-8")
    summary = read_summary(compared / "summary.json")
    assert tuple(summary) == SUMMARY_KEYS
    assert summary_text(summary.data) == raw
    assert summary.run_id and summary.study_dir and summary.inputs[0].role == "study"
    assert any(w.kind == "damaged-line" and "skipped damaged line" in w.text
               for w in summary.warnings)


def test_fit_writer_reproduces_what_compare_writes(compared):
    raw = (compared / "fit.json").read_text(encoding="utf-8")
    doc = read_fit(compared / "fit.json")
    assert tuple(doc) == FIT_KEYS
    assert fit_text(doc.data) == raw
    assert doc.run_id == read_summary(compared / "summary.json").run_id
    assert doc.fit == ["h_L"] and set(doc.subjects) == {"P01", "P02"}


@pytest.mark.parametrize("case", [
    ("study", {"name": "s"}, "key 'study'"),
    ("inputs", [{"file": "study.toml"}], "key 'inputs'"),
    ("warnings", "one", "key 'warnings'"),
])
def test_report_refuses_a_summary_key_of_the_wrong_kind(compared, tmp_path, capsys, case):
    key, value, named = case
    path = compared / "summary.json"
    before = path.read_bytes()
    try:
        doc = json.loads(before)
        doc[key] = value
        path.write_text(json.dumps(doc), encoding="utf-8")
        assert main(["report", str(compared), "-o", str(tmp_path / "r.html")]) == 2
        err = capsys.readouterr().err
        assert named in err and "summary.json" in err and "Traceback" not in err, err
        assert not (tmp_path / "r.html").exists()
    finally:
        path.write_bytes(before)


def test_fit_reader_names_the_file(tmp_path):
    (tmp_path / "fit.json").write_text("[1]", encoding="utf-8")
    with pytest.raises(ResultFolderError, match="not a model fit"):
        read_fit(tmp_path / "fit.json", again="; again")
    (tmp_path / "fit.json").write_text('{"fit": "h_L"}', encoding="utf-8")
    with pytest.raises(ResultFolderError, match="key 'fit'"):
        read_fit(tmp_path / "fit.json").fit  # noqa: B018


def test_fit_csv_is_written_atomically(compared, monkeypatch):
    written = []
    real = compare_run.atomic_write

    def recording(path, data, **kw):
        written.append(path.name)
        return real(path, data, **kw)

    monkeypatch.setattr(compare_run, "atomic_write", recording)
    before = (compared / "fit.csv").read_bytes()
    compare(compared, dpi=30, formats=("png",), force=True)
    assert "fit.csv" in written
    assert (compared / "fit.csv").read_bytes() == before
