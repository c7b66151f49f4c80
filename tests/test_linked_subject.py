"""A subject folder that is a link to a folder outside the study (supported, with a
warning) is the study's: what the study holds through it is protected as if it were in the
study folder itself, however the path that names it is spelt."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, write_trial
from evtribo.cli import main


@pytest.fixture(scope="module")
def linked(tmp_path_factory):
    """A study whose subject P02 is a link to a folder elsewhere, and its results."""
    base = tmp_path_factory.mktemp("linked")
    study = base / "study"
    for subject in ("P01", "P02"):
        write_trial(study, "run-01", SubjectParams(name=subject), TrialConfig(duration_s=3.0))
    elsewhere = base / "elsewhere"
    (study / "P02").rename(elsewhere)
    (study / "P02").symlink_to(elsewhere, target_is_directory=True)
    out = base / "out"
    assert main(["analyze", str(study), "--out", str(out), "--jobs", "1"]) == 0
    return study, elsewhere, out


def _files(folder):
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in folder.rglob("*")
            if p.is_file()}


def test_outputs_into_a_linked_subject_folder_are_refused(linked, tmp_path, capsys):
    study, elsewhere, out = linked
    before = _files(elsewhere)
    dbc = str(study / "rig" / "default.dbc")
    commands = {
        "report over its sidecar": ["report", str(out), "-o",
                                    str(study / "P02" / "run-01.json"), "--force"],
        "report as a new sidecar": ["report", str(out), "-o",
                                    str(study / "P02" / "run-02.json")],
        "decode beside its trial": ["decode", str(study / "P01" / "run-01.log"), "--dbc", dbc,
                                    "-o", str(study / "P02" / "run-02.csv")],
        "analyze into it": ["analyze", str(study), "--out", str(study / "P02" / "results")],
        "export beside its trial": ["export", str(study), "-o", str(study / "P02" / "x.mf4")],
        "compare a result folder in it": ["compare", str(study / "P02")],
    }
    for what, argv in commands.items():
        capsys.readouterr()
        try:
            code = main(argv)
        except SystemExit as exc:
            code = int(exc.code or 0)
        err = capsys.readouterr().err
        assert code == 2, (what, err)
        assert str(study / "P02") in err, (what, err)
    assert _files(elsewhere) == before
    assert sorted(p.name for p in elsewhere.iterdir()) == sorted(before)


_STEMS = st.text(alphabet="abcdefghijklmnopqrstuvwxyz0123456789_-", min_size=1, max_size=12)
_SUFFIXES = [".csv", ".mf4", ".log", ".asc", ".log.gz", ".json", "session.json"]


@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_a_trials_folder_is_a_trials_folder_however_it_is_reached(linked, tmp_path_factory,
                                                                   capsys, data):
    """A folder holding a trial's sidecar and log (P02's, a link to a folder elsewhere) is
    protected as the study's whether the output is named through the study, by the folder's
    own path, or through another link to it: a file analyze would read as a log or a
    sidecar there is refused (exit 2), and the folder keeps its files."""
    study, elsewhere, out = linked
    command = data.draw(st.sampled_from(["decode", "report"]), label="command")
    spelling = data.draw(st.sampled_from(["study", "real", "another link"]), label="spelling")
    stem, suffix = data.draw(_STEMS, label="stem"), data.draw(st.sampled_from(_SUFFIXES))
    folder = {"study": study / "P02", "real": elsewhere}.get(spelling)
    if folder is None:
        folder = tmp_path_factory.mktemp("spelling") / "P02"
        folder.symlink_to(elsewhere, target_is_directory=True)
    name = "session.json" if suffix == "session.json" else stem + suffix
    if command == "decode" and suffix not in (".csv", ".mf4"):
        name = f"{stem}.csv"
    before = _files(elsewhere)
    argv = (["decode", str(study / "P01" / "run-01.log"), "--dbc",
             str(study / "rig" / "default.dbc"), "-o", str(folder / name)]
            if command == "decode" else ["report", str(out), "-o", str(folder / name)])
    capsys.readouterr()
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    assert str(folder / name) in err and "by evtribo analyze" in err, err
    assert _files(elsewhere) == before
