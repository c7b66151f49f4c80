"""The demo end to end: simulated rig -> virtual bus -> acquire -> analyze -> compare -> report."""

import json
from html.parser import HTMLParser

import pytest

from evtribo.cli import main
from evtribo.demo import run_demo
from evtribo.errors import OutputExistsError
from evtribo.study import load_study


@pytest.mark.slow
def test_demo_end_to_end(tmp_path):
    lines = []
    res = run_demo(tmp_path / "demo", subjects=1, amplitudes=(80.0, 140.0), trial_s=8.0,
                   speed=8.0, jobs=1, progress=lines.append)
    study = load_study(res.study)
    assert [t.name for t in study.trials] == ["run-01", "run-02", "run-03"]
    for t in study.trials:  # recorded by the acquisition code, every frame kept
        side = json.loads(t.sidecar_path.read_text())
        assert side["ended"] == "completed" and side["dropped_frames"] == 0
        assert side["frames"] == res.truth["trials"][t.key]["frames"] > 10_000
    truth_gap = res.truth["subjects"]["P01"]["h_L"]
    value, low, high = res.fitted_air_gaps["P01"]
    assert value == pytest.approx(truth_gap, rel=0.1)
    assert low < value < high
    HTMLParser().feed(res.report.read_text(encoding="utf-8"))
    assert res.report.stat().st_size > 50_000
    assert any("air gap fitted" in line for line in lines)
    # compare says what it is doing, trial by trial for the checks
    assert any(line.startswith("fitting h_L") for line in lines)
    checks = [line for line in lines if " check of " in line]
    assert checks[0].startswith("drawing the check of 3 trial(s) from what analyze kept")
    assert sorted(checks[1:]) == [f"[{k}/3] check of P01/run-0{k}" for k in (1, 2, 3)]
    with pytest.raises(OutputExistsError):
        run_demo(tmp_path / "demo", subjects=1, amplitudes=(80.0,), trial_s=8.0)
    again = run_demo(tmp_path / "demo", subjects=1, amplitudes=(80.0,), trial_s=8.0,
                     speed=8.0, jobs=1, force=True)   # its own previous demo: replaced
    assert [t.name for t in load_study(again.study).trials] == ["run-01", "run-02"]


def test_demo_never_replaces_a_folder_it_did_not_write(tmp_path):
    lab = tmp_path / "lab"
    (lab / "study" / "P01").mkdir(parents=True)
    recorded = lab / "study" / "P01" / "run-01.log"
    recorded.write_text("(1.000000) vcan0 0C1#00\n")
    with pytest.raises(OutputExistsError, match="not written by evtribo demo"):
        run_demo(lab, subjects=1, amplitudes=(80.0,), trial_s=8.0, force=True)
    assert recorded.read_text() == "(1.000000) vcan0 0C1#00\n"


def test_demo_cli_refuses_bad_options(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path / "d"), "--subjects", "0"]) == 2
    assert "--subjects" in capsys.readouterr().err
    assert not (tmp_path / "d").exists()


def test_demo_force_never_deletes_a_users_file_in_its_study(tmp_path):
    """A previous demo's folder (its mark, truth.json) whose study holds a file the demo did
    not write: --force deletes nothing of it."""
    from evtribo.demo import MARKER

    demo = tmp_path / "demo"
    (demo / "study" / "P01").mkdir(parents=True)
    (demo / MARKER).write_text("written by evtribo demo\n")
    (demo / "truth.json").write_text(json.dumps({"trials": {"P01/run-01": {}}}))
    for rel in ("study/study.toml", "study/P01/run-01.log", "study/P01/run-01.json"):
        (demo / rel).write_text("the demo's\n")
    notes = demo / "study" / "P01" / "notes.txt"
    notes.write_text("the subject said the screen felt warm\n")
    before = {p: p.read_bytes() for p in demo.rglob("*") if p.is_file()}
    with pytest.raises(OutputExistsError, match="did not write"):
        run_demo(demo, subjects=1, amplitudes=(80.0,), trial_s=8.0, force=True)
    assert {p: p.read_bytes() for p in demo.rglob("*") if p.is_file()} == before
