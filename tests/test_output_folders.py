"""A folder evtribo writes into that is not what evtribo made of it: its manifest's name
taken by a folder, a link or a FIFO (exit 2, naming it), a part of it that is a link to the
user's own files (exit 2, naming the link and where it leads), a folder whose files another
command writes (compare's figures/: exit 2, naming it), or a folder this process cannot
write (exit 1, naming it). Every command that would write there refuses before anything is
written, and nothing changes: nothing is left half-installed, to be finished later."""

from __future__ import annotations

import base64
import os
import shutil

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import _forked
from _outputs import World, make_template, run, tree, working_files, world
from evtribo.store.owned import MANIFEST
from evtribo.store.resultdir import pending


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


#: Folders a command may find it cannot write.
READ_ONLY = ("out", "out/figures", "work")
#: Commands that write into them, with --force (each has something there to replace).
WRITING = {
    "analyze": lambda w: ["analyze", str(w.study), "--out", str(w.out), "--force", "--jobs",
                          "1", "--cache-dir", str(w.cache)],
    "compare": lambda w: ["compare", str(w.out), "--force", "--dpi", "21", "--figure-format",
                          "png", "--no-trial-checks", "--cache-dir", str(w.cache)],
    "report-in-out": lambda w: ["report", str(w.out), "--force"],
    "report": lambda w: ["report", str(w.out), "-o", str(w.work / "report.html"), "--force"],
    "decode": lambda w: ["decode", str(w.log), "--dbc", str(w.dbc), "-o",
                         str(w.work / "run-01.csv"), "--force"],
}


@settings(max_examples=10, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(command=st.sampled_from(sorted(WRITING)),
       read_only=st.sets(st.sampled_from(READ_ONLY), min_size=1))
def test_a_folder_that_cannot_be_written_is_refused_before_anything_is_written(
        template, tmp_path_factory, command, read_only):
    """Folders of mode 555 (root's overrides dropped, as a user's process has none): the
    command exits 0 (none of them was its to write) or 1 naming the folder, with nothing
    written; nothing is left to be finished later, and once the folders can be written
    again the result folder is whole (a report of it is written)."""
    w = world(template, tmp_path_factory.mktemp(command))
    assert run(["report", str(w.out), "-o", str(w.work / "report.html")]) == 0
    assert run(["decode", str(w.log), "--dbc", str(w.dbc), "-o",
                str(w.work / "run-01.csv")]) == 0
    folders = [w.root / rel for rel in sorted(read_only)]
    log = tmp_path_factory.mktemp("log") / "out.txt"
    try:
        for folder in folders:
            folder.chmod(0o555)
        before = tree(w.root)
        code, text = _forked.run(WRITING[command](w), log, _forked.modes_apply)
        after = tree(w.root)
    finally:
        for folder in folders:
            folder.chmod(0o755)
    assert code in (0, 1), text
    event(f"{command}: exit {code}")
    if code == 1:
        assert "cannot be written" in text and "nothing was written" in text, text
        assert after == before
    assert pending(w.out) == [] and working_files(w.root) == [], text
    assert run(["report", str(w.out), "-o", str(w.work / "after.html")]) == 0


#: Where a link may stand on the way to an output: the command, and the link's path.
LINKED = {
    "compare": (COMMANDS["compare"][1], lambda w: w.out / "figures"),
    "compare-fit": (COMMANDS["compare"][1], lambda w: w.out / "fit.csv"),
    "report-tables-in-out": (
        lambda w: ["report", str(w.out), "--tables", "md", "--force"], lambda w: w.out / "tables"),
    "report-tables": (
        lambda w: ["report", str(w.out), "-o", str(w.work / "report.html"), "--tables", "md"],
        lambda w: w.work / "tables"),
}


@settings(max_examples=12, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(case=st.sampled_from(sorted(LINKED)), filled=st.booleans())
def test_a_link_on_the_way_to_an_output_is_named_with_where_it_leads(
        template, tmp_path_factory, capsys, case, filled):
    """A folder (or file) of an output that is a link to the user's own (their paper's
    figures, filled or empty): refused (exit 2) in so many words, the link named with where it
    leads, and nothing written, through the link or beside it."""
    w = world(template, tmp_path_factory.mktemp(case))
    argv, where = LINKED[case]
    link = where(w)
    mine = w.root / "paper" / link.name
    if link.is_dir():
        shutil.copytree(link, mine) if filled else mine.mkdir(parents=True)
        shutil.rmtree(link)
    else:
        mine.parent.mkdir()
        if link.exists():
            link.rename(mine)
        else:
            mine.write_text("the user's own\n") if filled else mine.mkdir()
    link.symlink_to(mine)
    before = tree(w.root)
    capsys.readouterr()
    assert run(argv(w)) == 2
    err = capsys.readouterr().err
    assert f"error: {link}: " in err and f"is a symbolic link (to {mine})" in err, err
    assert tree(w.root) == before


#: Commands that write one file where the user says.
ONE_FILE = {
    "decode": (".csv", lambda w, path: ["decode", str(w.log), "--dbc", str(w.dbc), "-o",
                                        str(path), "--force"]),
    "plot": (".png", lambda w, path: ["plot", "trial", str(w.study), "P01", "run-01", "-o",
                                      str(path), "--force", "--cache-dir", str(w.cache)]),
    "report": (".html", lambda w, path: ["report", str(w.out), "-o", str(path), "--force"]),
}


@settings(max_examples=12, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(command=st.sampled_from(sorted(ONE_FILE)),
       where=st.tuples(st.sampled_from(["figures", "tables"]), st.booleans()))
def test_a_file_is_not_written_into_a_folder_of_another_commands_files(
        template, tmp_path_factory, capsys, command, where):
    """``plot -o OUT/figures/x.png`` (or decode, or report -o, into compare's figures/ or
    report's tables/ of a result folder), over a file of the folder's or beside them: refused
    (exit 2) naming the folder and whose files it holds, nothing written, and the result
    folder's report is still written."""
    folder, existing = where
    w = world(template, tmp_path_factory.mktemp(command))
    if folder == "tables":
        assert run(["report", str(w.out), "--tables", "md"]) == 0
    suffix, argv = ONE_FILE[command]
    theirs = sorted((w.out / folder).iterdir())
    path = theirs[0].with_suffix(suffix) if existing else w.out / folder / f"mine{suffix}"
    if existing:
        theirs[0].rename(path)  # a file of the folder's of the name given
    before = tree(w.root)
    capsys.readouterr()
    assert run(argv(w, path)) == 2
    err = capsys.readouterr().err
    assert f"is inside {w.out / folder}, a folder of {w.out}" in err, err
    assert tree(w.root) == before
    if not existing:
        assert run(["report", str(w.out), "--force"]) == 0


def test_the_report_shows_the_figure_compare_wrote_not_another_file_of_its_name(template,
                                                                                tmp_path):
    """compare wrote its figures as SVG; a PNG of a figure's name put beside them (by hand)
    is not what the report shows: the SVG compare wrote is."""
    w = world(template, tmp_path)
    other = (w.out / "figures" / "area_increase.png").read_bytes()
    assert run(["compare", str(w.out), "--force", "--dpi", "20", "--figure-format", "svg",
                "--no-trial-checks", "--cache-dir", str(w.cache)]) == 0
    (w.out / "figures" / "friction_time.png").write_bytes(other)
    assert run(["report", str(w.out), "--force"]) == 0
    page = (w.out / "report.html").read_text(encoding="utf-8")
    assert base64.b64encode(other).decode()[:200] not in page
    svg = (w.out / "figures" / "friction_time.svg").read_bytes()
    assert base64.b64encode(svg).decode() in page
