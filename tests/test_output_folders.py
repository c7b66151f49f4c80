"""A folder evtribo writes into whose own parts are not what evtribo made: its manifest's
name taken by a folder, a link or a FIFO. Every command that would write there refuses
(exit 2, naming what is wrong) before anything is written, and nothing changes."""

from __future__ import annotations

import os

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from _outputs import World, make_template, run, tree, world
from evtribo.store.owned import MANIFEST


@pytest.fixture(scope="module")
def template(tmp_path_factory):
    return make_template(tmp_path_factory.mktemp("folders"))


#: What a command writes into (``work`` or the result folder), and its arguments.
COMMANDS = {
    "decode": ("work", lambda w: ["decode", str(w.log), "--dbc", str(w.dbc), "-o",
                                  str(w.work / "run-01.csv")]),
    "plot": ("work", lambda w: ["plot", "trial", str(w.study), "P01", "run-01", "-o",
                                str(w.work / "check.png"), "--cache-dir", str(w.cache)]),
    "report": ("work", lambda w: ["report", str(w.out), "-o", str(w.work / "report.html")]),
    "report-in-out": ("out", lambda w: ["report", str(w.out), "--force"]),
    "compare": ("out", lambda w: ["compare", str(w.out), "--force", "--dpi", "21",
                                  "--figure-format", "png", "--no-trial-checks",
                                  "--cache-dir", str(w.cache)]),
    "analyze": ("out", lambda w: ["analyze", str(w.study), "--out", str(w.out), "--force",
                                  "--jobs", "1", "--cache-dir", str(w.cache)]),
}


def _manifest_taken(w: World, folder: str, kind: str) -> None:
    """The manifest's name in *folder* taken by something that is not a regular file."""
    path = (w.work if folder == "work" else w.out) / MANIFEST
    if path.exists():
        path.unlink()
    elsewhere = w.root / "elsewhere"
    elsewhere.mkdir(exist_ok=True)
    if kind == "folder":
        path.mkdir()
    elif kind == "fifo":
        os.mkfifo(path)
    elif kind == "link to a file":
        (elsewhere / "notes.json").write_text("{}\n")
        path.symlink_to(elsewhere / "notes.json")
    elif kind == "link to a folder":
        path.symlink_to(elsewhere, target_is_directory=True)
    else:
        path.symlink_to(elsewhere / "nothing")


@settings(max_examples=15, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(command=st.sampled_from(sorted(COMMANDS)),
       kind=st.sampled_from(["folder", "fifo", "link to a file", "link to a folder",
                             "dangling link"]))
def test_a_manifest_that_is_not_a_file_stops_the_command_before_it_writes(
        template, tmp_path_factory, capsys, command, kind):
    w = world(template, tmp_path_factory.mktemp(command))
    folder, argv = COMMANDS[command]
    _manifest_taken(w, folder, kind)
    before = tree(w.root)
    capsys.readouterr()
    assert run(argv(w)) == 2
    err = capsys.readouterr().err
    assert f"{MANIFEST}: is a " in err and "not evtribo's manifest" in err, err
    assert tree(w.root) == before
