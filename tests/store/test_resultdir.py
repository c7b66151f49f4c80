"""An output written as one unit (evtribo.store.resultdir): the lock, the staged commit, recovery.

The kill tests fork a process that writes a folder and kill it with SIGKILL at a chosen
moment (the k-th file-system step of the commit, for every k): the folder must then hold
the old files or the new ones (after :func:`recover` when the commit was written), never a
mix, and the files that are not the command's are never touched.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import shutil
import signal
import threading
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.errors import OutputBusyError, OutputWriteError
from evtribo.store import commit_record, resultdir
from evtribo.store.owned import MANIFEST
from evtribo.store.resultdir import (
    COMMIT_RECORD,
    Staging,
    holder,
    lock_path,
    locked,
    pending,
    recover,
)

FORK = multiprocessing.get_context("fork")


def tree(folder: Path) -> dict[str, bytes]:
    """Every file under *folder* but its manifest, relative name -> bytes."""
    if not folder.is_dir():
        return {}
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file() and p.name != MANIFEST}


def write_tree(folder: Path, files: dict[str, bytes]) -> None:
    for rel, data in files.items():
        (folder / rel).parent.mkdir(parents=True, exist_ok=True)
        (folder / rel).write_bytes(data)


def committed(folder: Path, files: dict[str, bytes], by: str = "t") -> None:
    """*files* written into *folder* by a commit (its manifest records them)."""
    if not files:
        return
    with locked(folder, by), Staging(folder, by=by) as stage:
        write_tree(stage.folder, files)
        stage.commit()


def _hold(out: Path, ready, release) -> None:  # in a forked process
    with locked(out, "evtribo analyze"):
        ready.set()
        release.wait(30)


def test_a_second_process_is_refused_naming_the_holder(tmp_path):
    out = tmp_path / "out"
    ready, release = FORK.Event(), FORK.Event()
    proc = FORK.Process(target=_hold, args=(out, ready, release))
    proc.start()
    try:
        assert ready.wait(30)
        with pytest.raises(OutputBusyError) as info:
            with locked(out, "evtribo compare"):
                pass
        msg = str(info.value)
        assert f"process {proc.pid}" in msg and "evtribo analyze" in msg
        assert msg.startswith(str(out)) and info.value.exit_code == 2
        assert holder(out)["pid"] == proc.pid
    finally:
        release.set()
        proc.join(30)
    with locked(out, "evtribo compare"):  # free once the holder is done
        assert holder(out)["pid"] == os.getpid()
    assert not lock_path(out).exists()  # removed with the lock


def test_a_lock_file_left_by_a_dead_process_is_taken_over(tmp_path):
    out = tmp_path / "out"
    dead = FORK.Process(target=os._exit, args=(0,))
    dead.start()
    dead.join()
    lock_path(out).write_text(json.dumps({"pid": dead.pid, "command": "evtribo analyze"}))
    with locked(out, "evtribo analyze"):
        assert holder(out)["pid"] == os.getpid()
    assert not lock_path(out).exists()


def test_the_lock_is_reentrant_in_a_thread_and_refused_to_another_thread(tmp_path):
    out = tmp_path / "out"
    errors = []

    def other():
        try:
            with locked(out, "x"):
                pass
        except OutputBusyError as err:
            errors.append(err)

    with locked(out, "evtribo report"), locked(out, "evtribo compare"):
        t = threading.Thread(target=other)
        t.start()
        t.join()
        assert lock_path(out).exists()
    assert len(errors) == 1 and not lock_path(out).exists()


def test_a_staging_left_without_commit_changes_nothing(tmp_path):
    out = tmp_path / "out"
    committed(out, {"a.csv": b"old"})
    write_tree(out, {"notes.txt": b"mine"})
    with pytest.raises(RuntimeError), locked(out, "t"), Staging(out, by="t") as stage:
        stage.path("a.csv").write_bytes(b"new")
        raise RuntimeError("boom")
    assert tree(out) == {"a.csv": b"old", "notes.txt": b"mine"}
    assert [p.name for p in tmp_path.iterdir()] == ["out"]


def test_a_write_error_becomes_output_write_error_and_changes_nothing(tmp_path):
    out = tmp_path / "out"
    committed(out, {"a.csv": b"old"})
    with pytest.raises(OutputWriteError, match="disk is full") as info, \
            locked(out, "t"), Staging(out, by="t") as stage:
        stage.path("a.csv").write_bytes(b"new")
        raise OSError(28, "No space left on device", str(stage.path("b.csv")))
    assert info.value.exit_code == 1
    assert tree(out) == {"a.csv": b"old"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def _commit_into_read_only(out: Path) -> None:  # in a forked process, root's overrides dropped
    import _forked

    _forked.modes_apply()
    code = 0
    try:
        with locked(out, "t"), Staging(out, by="t") as stage:
            stage.path("a.csv").write_bytes(b"new")
            (out / "figures").chmod(0o555)  # made read-only while the work went on
            stage.commit(remove=["figures/a.png"])
    except OutputWriteError as err:
        code = 3 if "figures: cannot be written" in str(err) else 4
    os._exit(code)


def test_a_folder_that_cannot_be_written_is_refused_before_the_commit(tmp_path):
    """The check made before the work passed; the commit checks again, before its record is
    written: nothing is left to be installed later."""
    out = tmp_path / "out"
    committed(out, {"a.csv": b"old", "figures/a.png": b"old figure"})
    proc = FORK.Process(target=_commit_into_read_only, args=(out,))
    proc.start()
    proc.join(60)
    (out / "figures").chmod(0o755)
    assert proc.exitcode == 3
    assert pending(out) == [] and sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    assert tree(out) == {"a.csv": b"old", "figures/a.png": b"old figure"}


@pytest.mark.parametrize("moved", [0, 1])
def test_a_commit_that_fails_is_taken_back_unless_part_of_it_is_done(tmp_path, monkeypatch,
                                                                     moved):
    """Its carrying out fails (EACCES, EIO) after *moved* files were put in place: with none,
    the record is taken back (the output as it was, nothing installed later); with some, it
    stays, and the next command on the output finishes it."""
    out = tmp_path / "out"
    committed(out, {"a.csv": b"old", "b.csv": b"old"})
    real_replace = os.replace

    def replace(src, dst, *args, **kwargs):
        if Path(src).parent.name.startswith(".out.evtribo-new-") and Path(dst).parent == out:
            if len([p for p in out.iterdir() if p.read_bytes() == b"new"]) >= moved:
                raise PermissionError(13, "Permission denied", os.fspath(dst))
        return real_replace(src, dst, *args, **kwargs)

    monkeypatch.setattr(commit_record.os, "replace", replace)
    with pytest.raises(OutputWriteError) as info, locked(out, "t"), \
            Staging(out, by="t") as stage:
        stage.path("a.csv").write_bytes(b"new")
        stage.path("b.csv").write_bytes(b"new")
        stage.commit()
    monkeypatch.undo()
    if moved == 0:
        assert "is left as it was" in str(info.value)
        assert pending(out) == [] and sorted(p.name for p in tmp_path.iterdir()) == ["out"]
        assert tree(out) == {"a.csv": b"old", "b.csv": b"old"}
    else:
        assert "the next evtribo command on it finishes" in str(info.value)
        assert len(pending(out)) == 1
        with locked(out, "t"):
            recover(out)
        assert tree(out) == {"a.csv": b"new", "b.csv": b"new"}


def test_recover_needs_the_lock(tmp_path):
    with pytest.raises(RuntimeError):
        recover(tmp_path / "out")


# --- killed at every step of a commit ------------------------------------------------------

_STEPS = ("replace", "unlink", "rmdir", "fsync", "rmtree")


def _counting(stop_at: int | None):
    """Patch the file-system calls a commit makes; SIGKILL this process at the stop_at-th."""
    count = [0]
    originals = {}
    steps: list[str] = []

    def wrap(owner, name):
        real = getattr(owner, name)
        originals[(owner, name)] = real

        def step(*args, **kwargs):
            count[0] += 1
            steps.append(f"{name} {args[-1] if name == 'replace' else ''}")
            if stop_at is not None and count[0] == stop_at:
                os.kill(os.getpid(), signal.SIGKILL)
            return real(*args, **kwargs)
        setattr(owner, name, step)

    for name in ("replace", "unlink", "rmdir", "fsync"):
        wrap(os, name)
    wrap(shutil, "rmtree")
    wrap(Path, "unlink")
    wrap(Path, "rmdir")
    return count, originals, steps


def _commit(out: Path, new: dict[str, bytes], remove: list[str], stop_at: int | None,
            report: tuple = (None, None)) -> None:
    """Commit *new* into *out* (removing *remove*), killed at step *stop_at*; *report*:
    (a shared value for the number of steps, a file for their names)."""
    counted, log = report
    count, originals, steps = _counting(stop_at)
    try:
        with locked(out, "t"), Staging(out, by="t") as stage:
            write_tree(stage.folder, new)
            stage.commit(remove=remove, last=["summary.json"])
    finally:
        for (owner, name), real in originals.items():
            setattr(owner, name, real)
    if counted is not None:
        counted.value = count[0]
    if log is not None:
        log.write_text("\n".join(steps))


def _run(target, *args) -> int:
    proc = FORK.Process(target=target, args=args)
    proc.start()
    proc.join(60)
    return proc.exitcode


names = st.sampled_from(["trials.csv", "windows.csv", "summary.json", "fit.csv", "fit.json",
                         "figures/a.png", "figures/b.svg", "report.html", "report_files/x.png"])
contents = st.binary(min_size=0, max_size=8)


@settings(max_examples=40, deadline=None)
@given(old=st.dictionaries(names, contents, max_size=6),
       new=st.dictionaries(names, contents, min_size=1, max_size=6),
       user=st.dictionaries(st.sampled_from(["notes.txt", "figures/mine.png", "old/x.csv"]),
                            contents, max_size=3),
       fraction=st.floats(0, 1))
@pytest.mark.slow
def test_killed_at_any_step_the_folder_is_old_or_new(tmp_path_factory, old, new, user,
                                                     fraction):
    root = tmp_path_factory.mktemp("kill")
    out = root / "out"
    committed(out, old)  # the command's old files, as a commit wrote them
    write_tree(out, user)
    before = tree(out)
    stale = [n for n in old if n not in new]  # the command's old files the new run lacks
    expected_new = {**user, **new}
    # how many steps a commit takes here (a dry run in another folder), then kill at one
    dry = root / "dry"
    committed(dry / "out", old)
    write_tree(dry / "out", user)
    counted = FORK.Value("i", 0)
    assert _run(_commit, dry / "out", new, stale, None, (counted, None)) == 0
    assert tree(dry / "out") == expected_new
    stop_at = 1 + int(fraction * counted.value)
    code = _run(_commit, out, new, stale, stop_at)
    assert code in (-signal.SIGKILL, 0)
    now = tree(out)
    was_committed = bool(pending(out))
    if not was_committed:  # killed before the commit, or after the swap: nothing to finish
        assert now in (before, expected_new), (stop_at, counted.value)
    with locked(out, "t"):
        recover(out)
    assert tree(out) in (before, expected_new)
    if code == 0 or was_committed:
        assert tree(out) == expected_new
    # nothing of the write is left beside the folder
    assert sorted(p.name for p in root.iterdir()) == sorted(["dry", *(["out"] if (
        before or out.exists()) else [])])
    assert all(not (out / n).exists() for n in (COMMIT_RECORD,))


def test_a_kill_after_the_commit_is_finished_by_the_next_reader(tmp_path):
    out = tmp_path / "out"
    dry = tmp_path / "dry" / "out"
    for folder in (out, dry):
        committed(folder, {"trials.csv": b"old", "fit.csv": b"old fit"})
        write_tree(folder, {"notes.txt": b"mine"})
    counted = FORK.Value("i", 0)
    new = {"trials.csv": b"new", "summary.json": b"{}"}
    _run(_commit, dry, new, ["fit.csv"], None, (counted, tmp_path / "steps"))
    steps = (tmp_path / "steps").read_text().splitlines()
    # kill at the second rename into the folder: trials.csv is new, summary.json not yet
    swap = [i for i, s in enumerate(steps) if s.startswith("replace") and COMMIT_RECORD not in s]
    code = _run(_commit, out, new, ["fit.csv"], swap[1] + 1)
    assert code == -signal.SIGKILL
    assert pending(out)
    assert tree(out) == {"trials.csv": b"new", "notes.txt": b"mine"}  # a mix, until...
    with locked(out, "evtribo compare"):
        done = recover(out)
    assert done and "finished writing" in done[0]
    assert tree(out) == {"trials.csv": b"new", "summary.json": b"{}", "notes.txt": b"mine"}
    assert not pending(out) and not list(tmp_path.glob(".out.evtribo-new-*"))


def test_the_module_names_each_step_it_counts():
    # the kill tests count these calls: a commit must use no other way to change files
    source = "".join(Path(m.__file__).read_text(encoding="utf-8")
                     for m in (resultdir, commit_record))
    for call in ("os.rename(", "shutil.move(", "os.remove(", ".rename("):
        assert call not in source, call
    assert all(s in source for s in _STEPS)


def test_an_output_on_its_own_file_system_is_written_from_inside(tmp_path, monkeypatch):
    # a mount point: a rename from beside it would cross file systems
    out = tmp_path / "usb"
    committed(out, {"a.csv": b"old"})
    write_tree(out, {"notes.txt": b"mine"})
    real = os.path.ismount
    monkeypatch.setattr(os.path, "ismount", lambda p: Path(p) == out or real(p))
    assert lock_path(out).parent == out
    with locked(out, "t"), Staging(out, by="t") as stage:
        assert stage.folder.parent == out
        stage.path("a.csv").write_bytes(b"new")
        stage.path("figures/f.png").write_bytes(b"png")
        stage.commit()
    assert tree(out) == {"a.csv": b"new", "figures/f.png": b"png", "notes.txt": b"mine"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["usb"]
    # an interrupted one is found there too
    with locked(out, "t"):
        stage = Staging(out, by="t").__enter__()
        stage.path("b.csv").write_bytes(b"b")
        assert not pending(out)
        recover(out)
    assert not stage.folder.exists()


@pytest.mark.parametrize(("cls", "builtin", "code"), [
    (OutputBusyError, BlockingIOError, 2), (OutputWriteError, OSError, 1)])
def test_the_errors_are_in_the_tree(cls, builtin, code):
    import pickle

    from evtribo.errors import EvtriboError, ResultFolderError, UserInputError

    err = cls("x", path="OUT")
    assert isinstance(err, EvtriboError) and isinstance(err, builtin)
    assert err.exit_code == code and str(pickle.loads(pickle.dumps(err))) == "OUT: x"
    assert issubclass(ResultFolderError, UserInputError) and ResultFolderError("x").exit_code == 2
