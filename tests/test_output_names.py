"""Any name a user can give an output is written and recorded, or refused before anything is
written.

A property over the commands that write where the user says (``decode -o``, ``plot -o``,
``export -o``, ``report -o``, ``analyze --out``, ``compare OUT``): the name is any a Linux
file name may hold (any bytes but ``/`` and NUL: text that is not UTF-8, spaces, tabs,
newlines, backslashes, a leading ``.`` or ``-`` or ``.evtribo-``, up to and past 255 bytes),
in a folder that exists or one to create. The command either exits 0, and the output is
there and listed in its folder's manifest with its bytes, the manifest reads back every name
it holds, no working file of evtribo's (a lock, a new folder) is left, and an earlier output
in the same folder is still evtribo's to replace with ``--force``; or it exits 2 and nothing
under the test's folder changed. ``model --figures`` and ``demo --out`` (whose runs take
tens of seconds) are held to the same check of the name, before their work, by examples.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from _outputs import World, make_template
from _outputs import run as _run
from _outputs import tree as _tree
from _outputs import working_files as _working_files
from _outputs import world as _world
from evtribo.store.owned import MANIFEST, owned, read_manifest

#: Pieces of a name a file system holds and evtribo writes: a leading dot or dash, white
#: space, a backslash, bytes that are not UTF-8, characters a shell would read.
_LEGAL = [b".", b"..", b"-", b" ", b"\\", b"\xe9", b"\xff\xfe", "é".encode(), "\u00a0".encode(),
          b"~", b"*", b"'", b'"', b"$HOME", b"%s", b".x.evtribo", b"evtribo-"]
#: Pieces of a name evtribo refuses: control characters, a line separator, the names of its
#: own working files.
_REFUSED = [b"\t", b"\n", b"\r", b"\x7f", b"\x1b", "\u2028".encode(), b".evtribo-",
            b".x.evtribo-lock", b".evtribo-manifest.json"]
_WORDS = st.text(alphabet="abcdefghijklmnopqrstuvwxyz0123456789_", min_size=1, max_size=10)
_WRITTEN = st.one_of(st.sampled_from(_LEGAL), _WORDS.map(str.encode),
                    st.integers(min_value=200, max_value=245).map(lambda n: b"r" * n))
_ANY = st.one_of(
    _WRITTEN, st.sampled_from(_REFUSED),
    st.binary(min_size=1, max_size=6).map(lambda b: b.replace(b"/", b"_").replace(b"\0", b"_")),
    st.integers(min_value=246, max_value=262).map(lambda n: b"r" * n))
#: A name's bytes (a stem: a suffix may follow): as often one made of pieces that are
#: written as one made of any.
NAMES = st.one_of(st.lists(_WRITTEN, min_size=1, max_size=3),
                  st.lists(_ANY, min_size=1, max_size=3)).map(b"".join)


@pytest.fixture(scope="module")
def template(tmp_path_factory):
    return make_template(tmp_path_factory.mktemp("names"))


def _manifest_reads_back(folder: Path) -> None:
    """Every name the manifest of *folder* holds is read back."""
    doc = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
    assert set(read_manifest(folder)) == set(doc["files"]), folder


def _written(path: Path, by: str) -> None:
    """*path*, a file evtribo wrote, is listed with its bytes in its folder's manifest."""
    assert path.is_file() and not path.is_symlink(), path
    assert owned(path.parent, path.name, {by}) == hashlib.sha256(path.read_bytes()).hexdigest()
    _manifest_reads_back(path.parent)
    assert not _working_files(path.parent), _working_files(path.parent)


def _name(data: st.DataObject, suffix: str) -> str:
    stem = data.draw(NAMES, label="name")
    with_suffix = data.draw(st.integers(0, 4), label="suffix (not if 0)") > 0
    return os.fsdecode(stem + (suffix.encode() if with_suffix else b""))


def _where(data: st.DataObject, world: World, suffix: str) -> Path:
    """The output: a drawn name in ``work``, or in a drawn folder to create there."""
    name = _name(data, suffix)
    if data.draw(st.integers(0, 2), label="in a new folder (if 0)") == 0:
        return world.work / os.fsdecode(data.draw(NAMES, label="folder")) / name
    return world.work / name


def _check(world: World, before: dict, code: int, ok: Callable[[], None]) -> None:
    assert code in (0, 2), code
    event(f"exit {code}")
    if code == 2:
        assert _tree(world.root) == before, "a refused command changed files"
    else:
        ok()


def _earlier_output_still_replaceable(world: World, folder: Path) -> None:
    """An output decode wrote into *folder* before is still replaced with --force: the
    manifest was not spoiled."""
    log, dbc = world.study / "P01" / "run-01.log", world.study / "rig" / "default.dbc"
    assert _run(["decode", str(log), "--dbc", str(dbc), "-o", str(folder / "x.csv"),
                 "--force"]) == 0
    _written(folder / "x.csv", "decode")


_SETTINGS = {"deadline": None,
             "suppress_health_check": [HealthCheck.function_scoped_fixture, HealthCheck.too_slow]}


@settings(max_examples=40, **_SETTINGS)
@given(data=st.data())
def test_any_name_for_decode_is_written_and_recorded_or_refused(template, tmp_path_factory,
                                                                data):
    world = _world(template, tmp_path_factory.mktemp("decode"))
    log, dbc = world.study / "P01" / "run-01.log", world.study / "rig" / "default.dbc"
    assert _run(["decode", str(log), "--dbc", str(dbc), "-o", str(world.work / "x.csv")]) == 0
    path = _where(data, world, data.draw(st.sampled_from([".csv", ".parquet"])))
    before = _tree(world.root)
    code = _run(["decode", str(log), "--dbc", str(dbc), "-o", str(path)])

    def ok() -> None:
        _written(path, "decode")
        _earlier_output_still_replaceable(world, world.work)

    _check(world, before, code, ok)


@settings(max_examples=12, **_SETTINGS)
@given(data=st.data())
def test_any_name_for_plot_is_written_and_recorded_or_refused(template, tmp_path_factory,
                                                              data):
    world = _world(template, tmp_path_factory.mktemp("plot"))
    path = _where(data, world, data.draw(st.sampled_from([".png", ".svg"])))
    before = _tree(world.root)
    code = _run(["plot", "trial", str(world.study), "P01", "run-01", "-o", str(path),
                 "--cache-dir", str(world.cache)])
    _check(world, before, code, lambda: _written(path, "plot"))


@settings(max_examples=12, **_SETTINGS)
@given(data=st.data())
def test_any_name_for_report_is_written_and_recorded_or_refused(template, tmp_path_factory,
                                                                data):
    world = _world(template, tmp_path_factory.mktemp("report"))
    path = _where(data, world, ".html")
    if data.draw(st.booleans(), label="inside the result folder"):
        path = world.out / path.name
    before = _tree(world.root)
    code = _run(["report", str(world.out), "-o", str(path)])

    def ok() -> None:
        _written(path, "report")
        _manifest_reads_back(world.out)
        assert not _working_files(world.root) and not _working_files(world.work)

    _check(world, before, code, ok)


@settings(max_examples=10, **_SETTINGS)
@given(data=st.data())
def test_any_name_for_analyze_is_written_and_recorded_or_refused(template, tmp_path_factory,
                                                                 data):
    world = _world(template, tmp_path_factory.mktemp("analyze"))
    out = _where(data, world, "")
    before = _tree(world.root)
    code = _run(["analyze", str(world.study), "--out", str(out), "--jobs", "1",
                 "--cache-dir", str(world.cache)])

    def ok() -> None:
        _written(out / "summary.json", "analyze")
        assert not _working_files(out.parent)

    _check(world, before, code, ok)


@settings(max_examples=6, **_SETTINGS)
@given(data=st.data())
def test_any_name_of_a_result_folder_is_compared_or_refused(template, tmp_path_factory, data):
    world = _world(template, tmp_path_factory.mktemp("compare"))
    out = world.work / os.fsdecode(data.draw(NAMES, label="name"))
    try:
        shutil.copytree(world.out, out, symlinks=True)
    except OSError:  # a name no file system holds (past 255 bytes): nothing to compare
        return
    before = _tree(world.root)
    code = _run(["compare", str(out), "--force", "--dpi", "21", "--figure-format", "png",
                 "--no-trial-checks", "--cache-dir", str(world.cache)])

    def ok() -> None:
        _written(out / "fit.csv", "compare")
        assert not _working_files(world.work)

    _check(world, before, code, ok)


@settings(max_examples=5, **_SETTINGS)
@given(data=st.data())
def test_any_name_for_export_is_written_and_recorded_or_refused(template, tmp_path_factory,
                                                                data):
    pytest.importorskip("asammdf")
    world = _world(template, tmp_path_factory.mktemp("export"))
    path = _where(data, world, ".mf4")
    before = _tree(world.root)
    code = _run(["export", str(world.study), "-o", str(path)])
    _check(world, before, code, lambda: _written(path, "export"))


@pytest.mark.parametrize(("command", "name", "code"), [
    ("report", ".report.html", 0), ("report", "a\\b.html", 0),
    ("report", "r" * 250 + ".html", 0), ("report", "r" * 300 + ".html", 2),
    ("report", "a\tb.html", 2), ("report", ".evtribo-x.html", 2),
    ("analyze", "o" * 240, 0), ("analyze", ".evtribo-manifest.json", 2),
    ("decode", "a\tb.csv", 2), ("decode", "a\nb.csv", 2), ("decode", ".evtribo-x.csv", 2)])
def test_the_names_users_gave(template, tmp_path, command, name, code):
    """Names users give: each written and recorded (a hidden report, one with a backslash,
    a long one; an analysis whose new folder beside its output would pass 255 bytes), or
    refused before anything is written, the folder's manifest still evtribo's."""
    world = _world(template, tmp_path)
    log, dbc = world.study / "P01" / "run-01.log", world.study / "rig" / "default.dbc"
    assert _run(["decode", str(log), "--dbc", str(dbc), "-o", str(world.work / "x.csv")]) == 0
    path = world.work / name
    argv = {"report": ["report", str(world.out), "-o", str(path)],
            "analyze": ["analyze", str(world.study), "--out", str(path), "--jobs", "1",
                        "--cache-dir", str(world.cache)],
            "decode": ["decode", str(log), "--dbc", str(dbc), "-o", str(path)]}[command]
    before = _tree(world.root)
    assert _run(argv) == code
    if code == 2:
        assert _tree(world.root) == before
    else:
        _written(path / "summary.json" if command == "analyze" else path, command)
        assert not _working_files(world.work)
    _earlier_output_still_replaceable(world, world.work)


def test_a_manifest_with_a_name_evtribo_no_longer_writes_still_lists_the_others(template,
                                                                               tmp_path):
    """A manifest an earlier evtribo wrote with a name it now refuses (``a<TAB>b.csv``): the
    other names are still evtribo's (``--force`` replaces them), and the next record drops
    the one no command can name."""
    world = _world(template, tmp_path)
    log, dbc = world.study / "P01" / "run-01.log", world.study / "rig" / "default.dbc"
    assert _run(["decode", str(log), "--dbc", str(dbc), "-o", str(world.work / "x.csv")]) == 0
    doc = json.loads((world.work / MANIFEST).read_text(encoding="utf-8"))
    doc["files"]["a\tb.csv"] = doc["files"]["x.csv"]
    (world.work / MANIFEST).write_text(json.dumps(doc), encoding="utf-8")
    assert set(read_manifest(world.work)) == {"x.csv"}
    _earlier_output_still_replaceable(world, world.work)
    assert set(json.loads((world.work / MANIFEST).read_text(encoding="utf-8"))["files"]) == \
        {"x.csv"}


@pytest.mark.parametrize("argv", [
    ["model", "--figures", "{work}/a\tb"], ["model", "--figures", "{work}/.evtribo-figs"],
    ["model", "--figures", "{work}/" + "f" * 256],
    ["demo", "--out", "{work}/demo\n"], ["demo", "--out", "{work}/.evtribo-demo"]])
def test_model_and_demo_refuse_such_names_before_their_work(tmp_path, capsys, argv):
    (tmp_path / "work").mkdir()
    before = _tree(tmp_path)
    assert _run([a.format(work=tmp_path / "work") for a in argv]) == 2
    assert "choose" in capsys.readouterr().err
    assert _tree(tmp_path) == before
