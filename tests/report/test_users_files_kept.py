"""A report never deletes or replaces a file it did not write, ``--force`` or not: the files
it may remove or replace are those its folder's manifest lists with the bytes they have
now (evtribo.store.owned)."""

from __future__ import annotations

from pathlib import Path

import pytest

from evtribo.cli import main
from evtribo.report.compare import compare
from synthetic import make_out

#: A user's files where a report keeps its tables and figures.
PLANTED = {"tables/friction.tex": b"\\begin{table}mine\\end{table}\n",
           "tables/fit.md": b"| my | table |\n",
           "report_files/photo.png": b"\x89PNG my photo",
           "report_files/fig1.svg": b"<svg>my figure</svg>"}


@pytest.fixture(scope="module")
def compared(tmp_path_factory):
    out = make_out(tmp_path_factory.mktemp("kept") / "out")
    compare(out, dpi=30, formats=("png",))
    return out


def _run(argv: list[str], capsys) -> tuple[int, str]:
    capsys.readouterr()
    try:
        code = main(argv)
    except SystemExit as exc:
        code = int(exc.code or 0)
    return code, capsys.readouterr().err


def _plant(folder: Path) -> None:
    for rel, data in PLANTED.items():
        (folder / rel).parent.mkdir(parents=True, exist_ok=True)
        (folder / rel).write_bytes(data)


def _kept(folder: Path) -> None:
    for rel, data in PLANTED.items():
        assert (folder / rel).is_file(), f"{rel} was deleted"
        assert (folder / rel).read_bytes() == data, f"{rel} was changed"


def test_a_new_report_leaves_the_users_files_beside_it(compared, tmp_path, capsys):
    paper = tmp_path / "paper"
    _plant(paper)
    code, err = _run(["report", str(compared), "-o", str(paper / "report.html")], capsys)
    assert code == 0, err
    _kept(paper)
    # again with --force, and with the tables: the user's tables are not the report's
    code, err = _run(["report", str(compared), "-o", str(paper / "report.html"), "--force"],
                     capsys)
    assert code == 0, err
    _kept(paper)
    code, err = _run(["report", str(compared), "-o", str(paper / "report.html"), "--force",
                      "--tables", "md,tex"], capsys)
    assert code == 2, err
    assert f"{paper / 'tables'}" in err and "not a file evtribo wrote" in err, err
    _kept(paper)


def test_a_report_replaces_its_own_files_and_no_other(compared, tmp_path, capsys):
    paper = tmp_path / "paper"
    html = paper / "report.html"
    code, err = _run(["report", str(compared), "-o", str(html), "--tables", "md"], capsys)
    assert code == 0, err
    ours = (paper / "tables" / "fit.md").read_bytes()
    code, err = _run(["report", str(compared), "-o", str(html), "--force", "--tables", "md"],
                     capsys)
    assert code == 0, err  # its own tables: replaced
    assert (paper / "tables" / "fit.md").read_bytes() == ours
    # a table the user edited is no longer the report's: kept, and the report says so
    (paper / "tables" / "fit.md").write_bytes(ours + b"my edit\n")
    code, err = _run(["report", str(compared), "-o", str(html), "--force", "--tables", "md"],
                     capsys)
    assert code == 2 and "fit.md" in err and "not a file evtribo wrote" in err, err
    assert (paper / "tables" / "fit.md").read_bytes() == ours + b"my edit\n"
    # without --tables, the report's own old tables go; the edited one stays
    code, err = _run(["report", str(compared), "-o", str(html), "--force"], capsys)
    assert code == 0, err
    assert (paper / "tables" / "fit.md").read_bytes() == ours + b"my edit\n"
    assert not (paper / "tables" / "electrostatic_force.md").exists()


@pytest.mark.parametrize("name", ["trials.csv", "summary.json", "fit.csv", "fit.json",
                                  "figures/area_increase.png"])
def test_report_decode_and_plot_never_replace_a_result_folder_s_files(
        compared, name, tmp_path, capsys):
    from evtribo.acquisition.simulator import SubjectParams, TrialConfig, write_trial

    study = tmp_path / "study"
    write_trial(study, "run-01", SubjectParams(), TrialConfig(duration_s=2.0))
    before = {p: p.read_bytes() for p in compared.rglob("*") if p.is_file()}
    target = compared / name
    commands = [["report", str(compared), "-o", str(target), "--force"]]
    if target.suffix == ".csv":
        commands.append(["decode", str(study / "P01" / "run-01.log"), "--dbc",
                         str(study / "rig" / "default.dbc"), "-o", str(target), "--force"])
    if target.suffix == ".png":
        commands.append(["plot", "trial", str(study), "P01", "run-01", "-o", str(target),
                         "--force"])
    for argv in commands:
        code, err = _run(argv, capsys)
        assert code == 2 and str(target) in err, (argv, err)
        assert {p: p.read_bytes() for p in compared.rglob("*") if p.is_file()} == before


def test_decode_and_plot_make_the_output_s_folder(tmp_path, capsys):
    from evtribo.acquisition.simulator import SubjectParams, TrialConfig, write_trial

    study = tmp_path / "study"
    write_trial(study, "run-01", SubjectParams(), TrialConfig(duration_s=2.0))
    table = tmp_path / "new" / "folder" / "run-01.csv"
    code, err = _run(["decode", str(study / "P01" / "run-01.log"), "--dbc",
                      str(study / "rig" / "default.dbc"), "-o", str(table)], capsys)
    assert code == 0 and table.is_file(), err
    figure = tmp_path / "figs" / "check.png"
    code, err = _run(["plot", "trial", str(study), "P01", "run-01", "-o", str(figure)], capsys)
    assert code == 0 and figure.is_file(), err
    # their own outputs: replaced with --force
    for argv in (["decode", str(study / "P01" / "run-01.log"), "--dbc",
                  str(study / "rig" / "default.dbc"), "-o", str(table), "--force"],
                 ["plot", "trial", str(study), "P01", "run-01", "-o", str(figure), "--force"]):
        code, err = _run(argv, capsys)
        assert code == 0, err


def test_results_of_an_older_evtribo_are_replaced_as_their_documents_vouch(tmp_path, capsys):
    """A result folder written before manifests: summary.json and fit.json record the
    SHA-256 of what analyze and compare wrote, which makes those files evtribo's (and
    --force replaces them); a table edited since is not, and stays."""
    from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_study
    from evtribo.store.owned import MANIFEST

    study, out = tmp_path / "study", tmp_path / "out"
    simulate_study(study, [SubjectParams(name="P01")], amplitudes=(80.0, 140.0),
                   config=TrialConfig(duration_s=3.0), sine_trial=False)
    assert main(["analyze", str(study), "--out", str(out), "--jobs", "1"]) == 0
    assert main(["compare", str(out), "--dpi", "20", "--no-trial-checks"]) == 0
    (out / MANIFEST).unlink()  # as an older evtribo left it
    (out / "notes.txt").write_text("mine\n")
    assert main(["analyze", str(study), "--out", str(out), "--jobs", "1", "--force",
                 "--set", "seed=2"]) == 0
    assert not (out / "fit.csv").exists()  # compare's, as fit.json vouched: stale, removed
    assert (out / "notes.txt").read_text() == "mine\n"
    (out / MANIFEST).unlink()
    edited = (out / "windows.csv").read_bytes() + b"# checked\n"
    (out / "windows.csv").write_bytes(edited)
    capsys.readouterr()
    assert main(["analyze", str(study), "--out", str(out), "--jobs", "1", "--force"]) == 2
    assert f"{out / 'windows.csv'}: key '--out': is not a file evtribo wrote" in \
        capsys.readouterr().err
    assert (out / "windows.csv").read_bytes() == edited


def test_an_older_result_s_document_vouches_only_for_its_command_s_names(tmp_path):
    """summary.json and fit.json of a folder without a manifest make evtribo's only files
    of analyze's and compare's names with the bytes they list: a user's file they name
    (a hand-edited or planted document) is never adopted, so never removed as stale."""
    import hashlib
    import json

    from evtribo.results.outputs import earlier_results

    def sha(data: bytes) -> str:
        return hashlib.sha256(data).hexdigest()

    (tmp_path / "figures").mkdir()
    files = {"windows.csv": b"a,b\n", "notes.txt": b"mine\n", "fit.csv": b"x\n",
             "figures/trial_P01_run-01.png": b"png", "figures/photo.png": b"mine too"}
    for rel, data in files.items():
        (tmp_path / rel).write_bytes(data)
    listed = {rel: sha(data) for rel, data in files.items()}
    (tmp_path / "summary.json").write_text(json.dumps({"output_sha256": listed}))
    (tmp_path / "fit.json").write_text(json.dumps({"output_sha256": listed}))
    adopted = earlier_results(tmp_path)
    assert {rel: e.by for rel, e in adopted.items()} == {
        "windows.csv": "analyze", "fit.csv": "compare",
        "figures/trial_P01_run-01.png": "compare"}
    (tmp_path / ".evtribo-manifest.json").write_text("{}")
    assert earlier_results(tmp_path) == {}  # a manifest says what is evtribo's
