"""A trial being recorded is locked: a second ``acquire`` or ``simulate --study`` into it is
refused (exit 2, naming the process), ``--force`` included; a lock left by a killed process
is cleared by the next recording."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time

import can
import pytest

from _process import kill_and_reap
from _rigcells import rig_heard
from evtribo.acquisition.trial import TrialPaths, record_trial
from evtribo.cli import main
from evtribo.errors import LockedError

pytestmark = pytest.mark.skipif(not hasattr(os, "openpty"), reason="needs a pseudo-terminal")


def acquire_process(study, path, log_channel):
    """``python -m evtribo acquire`` recording P01/run-01 from the slcan pty *path*."""
    return subprocess.Popen(
        [sys.executable, "-m", "evtribo", "acquire", "--study", str(study), "--subject",
         "P01", "--trial", "run-01", "--interface", "slcan_bulk", "--channel", path,
         "--bus-option", "sleep_after_open=0", "--log-channel", log_channel,
         "--duration", "60", "--quiet", "--force"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def wait_for_bytes(part, proc, n_bytes, timeout=120.0):
    """Wait until *part* holds *n_bytes* (*timeout* only ends a hang)."""
    deadline = time.monotonic() + timeout
    while not (part.exists() and part.stat().st_size >= n_bytes):
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "no frames reached the log"
        time.sleep(0.05)


def stop(proc, sig=signal.SIGTERM):
    if proc.poll() is None:
        proc.send_signal(sig)
    try:
        return proc.communicate(timeout=30)
    finally:
        kill_and_reap(proc)


def check_whole_log(log, channel, frames):
    data = log.read_bytes()
    assert b"\0" not in data and data.endswith(b"\n")
    assert {line.split()[1] for line in data.decode().splitlines()} == {channel}
    assert len(list(can.LogReader(log))) == frames > 0


def test_a_trial_being_recorded_is_refused_to_everyone_force_included(tmp_path, simulate_pty,
                                                                     capsys):
    _sim, path = simulate_pty("--fz-rate", "500", "--fx-rate", "500")
    study = tmp_path / "study"
    paths = TrialPaths.of(study, "P01", "run-01")
    first = acquire_process(study, path, "busA")
    try:
        wait_for_bytes(paths.part, first, 5000)
        holder = json.loads(paths.lock.read_text())
        assert holder["pid"] == first.pid and holder["host"] == socket.gethostname()
        assert holder["command"].startswith("python -m evtribo acquire --study")
        size = paths.part.stat().st_size
        capsys.readouterr()
        for argv in (["acquire", "--study", str(study), "--subject", "P01", "--trial",
                      "run-01", "--interface", "virtual", "--channel", "lock-second",
                      "--duration", "0.5", "--log-channel", "busB"],
                     ["simulate", "--study", str(study), "--subject", "P01", "--trial",
                      "run-01", "--duration", "1"]):
            for force in ([], ["--force"]):
                assert main([*argv, *force]) == 2, (argv[0], force)
                err = capsys.readouterr().err
                assert (f"error: {paths.lock}: the trial P01/run-01 is being recorded by "
                        f"PID {first.pid} on {socket.gethostname()}") in err, err
                assert "python -m evtribo acquire --study" in err and "Traceback" not in err
        with can.Bus(interface="virtual", channel="lock-api") as bus:
            with pytest.raises(LockedError, match=f"PID {first.pid}"):
                record_trial(bus, study, "P01", "run-01", duration=0.5, force=True)
        wait_for_bytes(paths.part, first, size + 1)      # the first one records on
        assert not paths.log.exists()
    finally:
        _out, err = stop(first)
    assert first.returncode == 0, err
    assert not paths.lock.exists() and not paths.part.exists()
    side = json.loads(paths.sidecar.read_text())
    assert side["ended"] == "interrupted" and side["log_channel"] == "busA"
    check_whole_log(paths.log, "busA", side["frames"])


@pytest.mark.slow
@pytest.mark.parametrize("offset_s", [0.0, 0.4, 1.5])
def test_two_recordings_started_together_one_records_the_other_is_refused(
        tmp_path, simulate_pty, offset_s):
    """Started at once or one after the other: one records, the other exits 2 at once;
    the log holds one bus's frames only, whole."""
    study = tmp_path / "study"
    paths = TrialPaths.of(study, "P01", "run-01")
    procs = {}
    for name in ("busA", "busB"):
        _sim, path = simulate_pty("--fz-rate", "500", "--fx-rate", "500")
        procs[name] = acquire_process(study, path, name)
        time.sleep(offset_s)
    try:
        deadline = time.monotonic() + 60
        while all(p.poll() is None for p in procs.values()):
            assert time.monotonic() < deadline, "neither was refused"
            time.sleep(0.05)
        [loser] = [name for name, p in procs.items() if p.poll() is not None]
        [winner] = [name for name in procs if name != loser]
        _out, err = procs[loser].communicate()
        assert procs[loser].returncode == 2, err
        assert f"is being recorded by PID {procs[winner].pid}" in err
        wait_for_bytes(paths.part, procs[winner], 3000)
    finally:
        for p in procs.values():
            stop(p)
    assert procs[winner].returncode == 0
    side = json.loads(paths.sidecar.read_text())
    assert side["log_channel"] == winner and side["ended"] == "interrupted"
    check_whole_log(paths.log, winner, side["frames"])
    assert not paths.lock.exists()


@pytest.mark.parametrize("n_bytes", [1, 20_000])
@pytest.mark.usefixtures("rig_heard_by_acquire")
def test_a_lock_left_by_a_killed_recording_is_cleared(tmp_path, simulate_pty, capsys, caplog,
                                                      n_bytes):
    """SIGKILL at two moments (the log just opened, well into the trial): the lock file
    stays, and the next ``acquire --force`` finds its process gone and records."""
    _sim, path = simulate_pty("--fz-rate", "500", "--fx-rate", "500")
    study = tmp_path / "study"
    paths = TrialPaths.of(study, "P01", "run-01")
    first = acquire_process(study, path, "busA")
    try:
        deadline = time.monotonic() + 120  # ends a hang only
        while not (paths.lock.exists() and paths.part.exists()
                   and paths.part.stat().st_size >= n_bytes):
            assert first.poll() is None and time.monotonic() < deadline, first.communicate()
            time.sleep(0.01)
    finally:
        stop(first, signal.SIGKILL)
    assert json.loads(paths.lock.read_text())["pid"] == first.pid
    capsys.readouterr()
    assert main(["acquire", "--study", str(study), "--subject", "P01", "--trial", "run-01",
                 "--interface", "virtual", "--channel", "lock-stale", "--duration", "0.3",
                 "--quiet", "--force"]) == 0, capsys.readouterr().err
    assert f"cleared a stale lock (PID {first.pid}" in caplog.text
    assert sorted(p.name for p in paths.folder.iterdir()) == ["run-01.json", "run-01.log"]
    assert json.loads(paths.sidecar.read_text())["ended"] == "completed"


def test_a_stale_lock_file_of_a_dead_process_is_cleared(tmp_path, caplog):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    paths = TrialPaths.of(tmp_path / "study", "P01", "run-01")
    paths.folder.mkdir(parents=True)
    paths.lock.write_text(json.dumps({"pid": dead.pid, "host": socket.gethostname(),
                                      "command": "evtribo acquire --study study",
                                      "since": "2025-01-01T00:00:00Z"}))
    with can.Bus(interface="virtual", channel="lock-dead") as bus:
        result = record_trial(bus, tmp_path / "study", "P01", "run-01", duration=0.2,
                              started=rig_heard("lock-dead"))
    assert result.ended == "completed"
    assert f"cleared a stale lock (PID {dead.pid}" in caplog.text
    assert sorted(p.name for p in paths.folder.iterdir()) == ["run-01.json", "run-01.log"]


@pytest.mark.parametrize("name", [".run-01.reserve", "run-01.log.part"])
def test_acquire_never_writes_through_a_link_at_its_working_names(tmp_path, name, capsys):
    """The disk reserve (``.TRIAL.reserve``) and the growing log (``TRIAL.log.part``) have
    names anyone can foresee: a link planted there is never written through."""
    from evtribo.acquisition.simulator import SubjectParams, TrialConfig, write_trial

    study = tmp_path / "study"
    write_trial(study, "run-00", SubjectParams(), TrialConfig(duration_s=1.0))
    victim = study / "P01" / "run-00.log"
    before = victim.read_bytes()
    (study / "P01" / name).symlink_to(victim)
    main(["acquire", "--study", str(study), "--subject", "P01", "--trial", "run-01",
          "--interface", "virtual", "--channel", f"links-{name}", "--duration", "0.2",
          "--force"])
    assert victim.read_bytes() == before
