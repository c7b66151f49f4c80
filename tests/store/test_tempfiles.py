"""Temporary files (evtribo.store.tempfiles): created exclusively under names nobody can
foresee, never through a link planted in advance, and none left behind by ``kill -9``."""

from __future__ import annotations

import multiprocessing
import os
import signal
from pathlib import Path

import pytest

from evtribo.store import tempfiles
from evtribo.store.files import atomic_open, atomic_write
from evtribo.store.owned import MANIFEST

FORK = multiprocessing.get_context("fork")
LOG = "(1763700000.000000) vcan0 0C1#0000000000000000\n"


def _plant_links(folder: Path, name: str, victim: Path) -> list[Path]:
    """Links at every temporary name a writer could be expected to use: the process's id
    and the next ones, with the suffixes writers used."""
    links = [folder / f".{name}.{pid}.{tail}" for pid in range(os.getpid(), os.getpid() + 5)
             for tail in ("tmp.mf4", "tmp")]
    for link in links:
        link.symlink_to(victim)
    return links


@pytest.mark.parametrize("command", ["decode", "export"])
def test_a_link_planted_at_a_temporary_name_is_never_written_through(command, tmp_path,
                                                                     capsys):
    pytest.importorskip("asammdf")
    from evtribo.acquisition.simulator import SubjectParams, TrialConfig, write_trial
    from evtribo.canlog.rig import default_rig_path
    from evtribo.cli import main

    study = tmp_path / "study"
    write_trial(study, "a80", SubjectParams(), TrialConfig(duration_s=3.0))
    log = study / "P01" / "a80.log"
    before = log.read_bytes()
    out = tmp_path / "forces.mf4"
    links = _plant_links(tmp_path, out.name, log)
    argv = (["decode", str(log), "--dbc", str(default_rig_path().with_name("default.dbc")),
             "-o", str(out)] if command == "decode" else ["export", str(study), "-o", str(out)])
    assert main(argv) == 0, capsys.readouterr().err
    assert log.read_bytes() == before  # the raw log is as it was
    assert out.read_bytes()[:3] == b"MDF"
    assert all(p.is_symlink() for p in links)
    left = [p.name for p in tmp_path.iterdir() if tempfiles.TEMP_INFIX in p.name
            and p.name != MANIFEST]
    assert left == []


def _write_until_killed(path: Path, ready, anonymous: bool) -> None:  # in a forked process
    if not anonymous:
        del os.O_TMPFILE  # a file system without nameless files
    with atomic_open(path, "wb") as fh:
        fh.write(b"x" * 216_000)
        fh.flush()
        ready.set()
        signal.pause()


@pytest.mark.parametrize("anonymous", [True, False], ids=["O_TMPFILE", "named"])
def test_a_writer_killed_leaves_no_temporary_file_after_the_next_write(tmp_path, anonymous):
    target = tmp_path / "forces.mf4"
    ready = FORK.Event()
    proc = FORK.Process(target=_write_until_killed, args=(target, ready, anonymous))
    proc.start()
    try:
        assert ready.wait(30)
        if not anonymous:  # a live writer's file is its own: not swept
            assert len(list(tmp_path.iterdir())) == 1
            assert tempfiles.sweep(target) == []
    finally:
        os.kill(proc.pid, signal.SIGKILL)
        proc.join(30)
    assert not target.exists()
    atomic_write(target, b"done")  # the next write of the same file
    assert [p.name for p in tmp_path.iterdir()] == ["forces.mf4"]
    assert target.read_bytes() == b"done"


def test_a_file_of_the_temporary_pattern_that_is_not_ours_is_left(tmp_path):
    target = tmp_path / "fit.csv"
    foreign = tmp_path / f".fit.csv{tempfiles.TEMP_INFIX}{'0' * 16}{tempfiles.TEMP_SUFFIX}"
    foreign.symlink_to(tmp_path / "elsewhere")  # a link is never ours
    hard = tmp_path / f".fit.csv{tempfiles.TEMP_INFIX}{'1' * 16}{tempfiles.TEMP_SUFFIX}"
    (tmp_path / "mine.txt").write_text("mine")
    os.link(tmp_path / "mine.txt", hard)  # a second name of a user's file
    odd = tmp_path / f".fit.csv{tempfiles.TEMP_INFIX}notatoken{tempfiles.TEMP_SUFFIX}"
    odd.write_text("mine too")
    atomic_write(target, "a,b\n")
    assert foreign.is_symlink() and hard.read_text() == "mine" and odd.read_text() == "mine too"
