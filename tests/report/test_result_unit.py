"""``compare`` and ``report`` read a result folder only as one analysis's complete results.

A table half-written, missing, changed or left by another analysis, a summary.json cut short
or absent, a fit whose files are not those compare wrote: refused with exit 2 and a message
naming the file and the command that mends it; nothing is written. A summary.json naming
files outside the study does not make the report read or list them.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import pytest

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_study
from evtribo.cli import main
from evtribo.documents import result_folder
from evtribo.report import study_files
from evtribo.report.compare import compare
from evtribo.results.pipeline import analyze_study


def tree(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def analysed(tmp_path_factory):
    """A study, its analysis with a fit, and an analysis of it with another seed."""
    base = tmp_path_factory.mktemp("unit")
    study = base / "study"
    simulate_study(study, [SubjectParams(name="P01")], amplitudes=(80.0, 140.0),
                   config=TrialConfig(duration_s=6.0), sine_trial=False)
    analyze_study(study, base / "out", jobs=1)
    compare(base / "out", dpi=30, formats=("png",))
    analyze_study(study, base / "other", jobs=1, overrides={"seed": 7})
    return study, base / "out", base / "other"


def _copy(analysed, tmp_path) -> Path:
    return shutil.copytree(analysed[1], tmp_path / "out")


def _half(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


DAMAGE = {
    "a table half-written": ("electrostatic.csv", lambda out, other: _half(
        out / "electrostatic.csv"), "not the file analysis"),
    "a table of another analysis": ("electrostatic_bootstrap.csv", lambda out, other: (
        shutil.copy(other / "electrostatic_bootstrap.csv", out)), "not the file analysis"),
    "a table missing": ("exponents.csv", lambda out, other: (out / "exponents.csv").unlink(),
                        "holds part of analysis"),
    "a table no analysis of it wrote": ("sine_trace.csv", lambda out, other: shutil.copy(
        out / "windows.csv", out / "sine_trace.csv"), "not written by analysis"),
    "summary.json half-written": ("summary.json", lambda out, other: _half(
        out / "summary.json"), "not valid JSON"),
    "summary.json missing": ("summary.json", lambda out, other: (
        out / "summary.json").unlink(), "missing beside"),
}


@pytest.mark.parametrize("case", list(DAMAGE))
@pytest.mark.parametrize("command", ["compare", "report"])
def test_a_partial_or_mixed_folder_is_refused(analysed, tmp_path, capsys, case, command):
    out = _copy(analysed, tmp_path)
    name, damage, says = DAMAGE[case]
    damage(out, analysed[2])
    before = tree(out)
    argv = [command, str(out), "--force"]
    argv += ["-o", str(tmp_path / "r.html")] if command == "report" else ["--dpi", "30"]
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"{out / name}: " in err and says in err, err
    assert "--force" in err and "Traceback" not in err
    assert tree(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


@pytest.mark.parametrize("case", ["fit.csv half-written", "a figure changed",
                                  "fit.json missing", "fit.csv missing"])
def test_report_refuses_a_fit_that_is_not_compare_s(analysed, tmp_path, capsys, case):
    out = _copy(analysed, tmp_path)
    if case == "fit.csv half-written":
        _half(out / "fit.csv")
    elif case == "a figure changed":
        (out / "figures" / "area_increase.png").write_bytes(b"\x89PNG other")
    else:
        (out / case.split()[0]).unlink()
    capsys.readouterr()
    assert main(["report", str(out), "-o", str(tmp_path / "r.html")]) == 2
    err = capsys.readouterr().err
    assert f"run `evtribo compare {out} --force`" in err and "Traceback" not in err, err
    assert not (tmp_path / "r.html").exists()
    changed = {"fit.csv half-written": "fit.csv",
               "a figure changed": "figures/area_increase.png"}.get(case)
    if changed is not None:  # not the file compare wrote: never replaced, --force or not
        kept = (out / changed).read_bytes()
        assert main(["compare", str(out), "--force", "--dpi", "30"]) == 2
        assert f"{out / changed}: is not a file evtribo wrote" in capsys.readouterr().err
        assert (out / changed).read_bytes() == kept
        (out / changed).unlink()  # the user's to remove
    assert main(["compare", str(out), "--force", "--dpi", "30"]) == 0
    assert main(["report", str(out), "-o", str(tmp_path / "r.html")]) == 0


def test_a_doctored_summary_does_not_make_the_report_read_files_outside_the_study(
        analysed, tmp_path, monkeypatch):
    study, _, _ = analysed
    out = _copy(analysed, tmp_path)
    secret = tmp_path / "secret.txt"
    secret.write_text("not for the report\n")
    summary = json.loads((out / "summary.json").read_text())
    real_hash = hashlib.sha256(secret.read_bytes()).hexdigest()
    rel = Path("..") / ".." / secret.relative_to(tmp_path.parent)
    summary["inputs"] += [
        {"file": "../../etc/passwd", "role": "log", "bytes": 1, "sha256": "0" * 64},
        {"file": str(secret), "role": "dbc", "bytes": 1, "sha256": "1" * 64},
        {"file": str(Path("P01") / ".." / rel), "role": "sidecar", "bytes": 1,
         "sha256": real_hash}]
    (out / "summary.json").write_text(json.dumps(summary))
    read = []
    real_sha = study_files.sha256_file

    def recording(path, *args, **kwargs):
        read.append(Path(path).resolve())
        return real_sha(path, *args, **kwargs)

    for module in (study_files, result_folder):  # the inputs, compare's files
        monkeypatch.setattr(module, "sha256_file", recording)
    report = tmp_path / "r.html"
    assert main(["report", str(out), "-o", str(report)]) == 0
    html = report.read_text()
    for name in ("passwd", "secret.txt", "0" * 64, "1" * 64):
        assert name not in html, name
    assert "names 3 input file(s) outside the study folder" in html
    assert read and all(p.is_relative_to(study.resolve()) or p.is_relative_to(out.resolve())
                        for p in read), read
    assert hashlib.sha256((study / "P01" / "run-01.log").read_bytes()).hexdigest() in html


def test_a_doctored_figure_name_is_not_read(analysed, tmp_path, capsys):
    out = _copy(analysed, tmp_path)
    (tmp_path / "outside.png").write_bytes((out / "figures" / "area_increase.png").read_bytes())
    doc = json.loads((out / "fit.json").read_text())
    doc["figures"][0]["stem"] = "../../outside"
    (out / "fit.json").write_text(json.dumps(doc))
    assert main(["report", str(out), "-o", str(tmp_path / "r.html")]) == 2
    assert "figure missing" in capsys.readouterr().err
