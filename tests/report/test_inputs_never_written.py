"""No command writes over a study's input or a raw CAN log, ``--force`` or not: report,
compare, decode, plot and the report's tables refuse (exit 2, naming the file) and leave
every input byte for byte as it was."""

from __future__ import annotations

import shutil

import pytest

from analysed import analysed_study
from evtribo.cli import main


@pytest.fixture(scope="module")
def analysed(tmp_path_factory):
    return analysed_study(tmp_path_factory.mktemp("inputs"))


def _inputs(study):
    return {p: p.read_bytes() for p in sorted(study.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("target", ["P01/run-01.log", "P01/run-01.json", "study.toml",
                                    "rig/default.dbc"])
def test_report_compare_decode_and_plot_never_write_over_a_study_input(
        analysed, target, tmp_path, capsys):
    study, out = analysed
    assert (study / target).is_file()
    before = _inputs(study)
    links = {}
    for suffix in (".html", ".csv", ".parquet", ".png"):  # a link to the input is the input
        links[suffix] = tmp_path / f"output{suffix}"
        links[suffix].symlink_to(study / target)
    dbc = str(study / "rig" / "default.dbc")
    commands = [
        ["report", str(out), "-o", str(study / target), "--force"],
        ["report", str(out), "-o", str(links[".html"]), "--force"],
        ["decode", str(study / "P01" / "run-02.log"), "--dbc", dbc, "-o", str(links[".csv"]),
         "--force"],
        ["decode", str(study / "P01" / "run-02.log"), "--dbc", dbc, "-o",
         str(links[".parquet"]), "--force"],
        ["plot", "trial", str(study), "P01", "run-01", "-o", str(links[".png"]), "--force"],
    ]
    for argv in commands:
        capsys.readouterr()
        try:
            code = main(argv)
        except SystemExit as exc:
            code = int(exc.code or 0)
        err = capsys.readouterr().err
        assert code == 2, (argv, err)
        assert f"{argv[argv.index('-o') + 1]}: key '-o': is " in err, err
        assert "never writes over a study's input or a raw CAN log, --force included" in err
        assert _inputs(study) == before, argv


def test_compare_refuses_a_result_folder_inside_the_study(analysed, tmp_path):
    study, out = analysed
    copy = tmp_path / "study"
    shutil.copytree(study, copy)
    shutil.copytree(out, copy / "results")
    before = _inputs(copy)
    assert main(["compare", str(copy / "results"), "--force"]) == 2
    assert main(["report", str(copy / "results"), "--force"]) == 2
    assert _inputs(copy) == before
