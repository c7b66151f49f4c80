"""The write lock: one writer at a time, its holder named, stale locks cleared."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import textwrap
import time

import pytest

import evtribo.store.lock as lock_module
from _process import kill_and_reap
from evtribo.errors import LockedError, OutputExistsError
from evtribo.store.lock import WriteLock, lock_holder

#: Holds the lock given as argv[1] until its stdin closes; prints "held" once it holds it.
HOLDER = textwrap.dedent("""
    import sys
    from evtribo.store.lock import WriteLock
    with WriteLock(sys.argv[1], "the thing"):
        print("held", flush=True)
        sys.stdin.read()
""")


def dead_pid() -> int:
    """The PID of a process that has ended."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def write_lock_file(path, **content):
    holder = {"pid": dead_pid(), "host": socket.gethostname(), "command": "evtribo acquire",
              "since": "2025-01-01T00:00:00Z", "process_start": None, **content}
    path.write_text(json.dumps(holder) + "\n")
    return holder


@pytest.fixture
def other_process(tmp_path):
    """Start a process holding a lock; return (process, lock path)."""
    procs = []

    def start(path):
        proc = subprocess.Popen([sys.executable, "-c", HOLDER, str(path)],
                                stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        procs.append(proc)
        assert proc.stdout.readline().strip() == "held"
        return proc

    yield start
    for proc in procs:
        kill_and_reap(proc)


def test_a_lock_held_by_another_process_is_refused_naming_it(tmp_path, other_process):
    path = tmp_path / "run-01.lock"
    proc = other_process(path)
    holder = lock_holder(path)
    assert holder["pid"] == proc.pid and holder["host"] == socket.gethostname()
    assert "python -c" in holder["command"]
    with pytest.raises(LockedError) as err:
        WriteLock(path, "the trial P01/run-01", "recorded").acquire()
    assert isinstance(err.value, OutputExistsError) and err.value.exit_code == 2
    message = err.value.cli_text()  # as the command line prints it
    assert message.startswith(f"{path}: the trial P01/run-01 is being recorded by PID "
                              f"{proc.pid} on {socket.gethostname()}")
    assert "--force does not override" in message
    assert json.loads(path.read_text())["pid"] == proc.pid        # left as it was
    proc.stdin.close()
    proc.wait(10)
    assert not path.exists()                                      # its holder removed it
    with WriteLock(path, "the thing") as lock:
        assert lock.held and lock_holder(path)["pid"] == os.getpid()
    assert not path.exists()


@pytest.mark.parametrize("moment", ["alive", "killed"])
def test_a_killed_holder_leaves_a_stale_lock_that_is_cleared(tmp_path, other_process, caplog,
                                                             moment):
    path = tmp_path / "run-01.lock"
    proc = other_process(path)
    if moment == "killed":
        proc.kill()
        proc.wait(10)
        assert path.exists()                                      # SIGKILL: no clean-up
        assert lock_holder(path) is None
        with WriteLock(path, "the thing"):
            assert lock_holder(path)["pid"] == os.getpid()
        assert f"cleared a stale lock (PID {proc.pid}" in caplog.text
    else:
        with pytest.raises(LockedError, match=f"PID {proc.pid}"):
            WriteLock(path, "the thing").acquire()


def test_a_stale_lock_file_of_a_dead_pid_is_cleared(tmp_path, caplog):
    path = tmp_path / "run-01.lock"
    old = write_lock_file(path)
    assert lock_holder(path) is None
    lock = WriteLock(path, "the thing").acquire()
    try:
        now = json.loads(path.read_text())
        assert now["pid"] == os.getpid() and now["pid"] != old["pid"]
    finally:
        lock.release()
    assert not path.exists()
    assert f"cleared a stale lock (PID {old['pid']} on {old['host']}" in caplog.text


def test_two_locks_in_one_process_exclude_each_other(tmp_path):
    path = tmp_path / "x.lock"
    with WriteLock(path, "the thing"):
        with pytest.raises(LockedError, match=f"PID {os.getpid()}"):
            WriteLock(path, "the thing").acquire()
    with WriteLock(path, "the thing"):  # free again
        pass


@pytest.mark.parametrize(("content", "held"), [
    ({"pid": "alive"}, True),
    ({"pid": "dead"}, False),
    ({"pid": "alive", "process_start": -1}, False),   # the PID now names another process
    ({"pid": "dead", "host": "another-host"}, True),  # cannot be checked from here
])
def test_without_flock_the_content_decides(tmp_path, monkeypatch, content, held):
    """On a file system without locks, a lock is held while its PID lives on this host (and
    is the same process), and always when it was written on another host."""
    monkeypatch.setattr(lock_module, "_try_flock", lambda fd, shared=False: None)
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        pid = sleeper.pid if content["pid"] == "alive" else dead_pid()
        path = tmp_path / "x.lock"
        write_lock_file(path, **{**content, "pid": pid})
        assert (lock_holder(path) is not None) == held
        if held:
            with pytest.raises(LockedError, match=f"PID {pid}"):
                WriteLock(path, "the thing").acquire()
        else:
            with WriteLock(path, "the thing"):
                assert json.loads(path.read_text())["pid"] == os.getpid()
    finally:
        kill_and_reap(sleeper)


@pytest.mark.slow
def test_an_empty_lock_file_is_one_being_written_unless_old(tmp_path, monkeypatch):
    monkeypatch.setattr(lock_module, "_try_flock", lambda fd, shared=False: None)
    path = tmp_path / "x.lock"
    path.write_text("")
    assert lock_holder(path) == {}
    with pytest.raises(LockedError, match="names none"):
        WriteLock(path, "the thing").acquire()
    past = time.time() - 60
    os.utime(path, (past, past))
    assert lock_holder(path) is None
    with WriteLock(path, "the thing"):
        pass


def test_the_command_line_is_the_users():
    assert lock_module.command_line()  # pytest's own; never empty
    saved = sys.argv
    try:
        sys.argv = ["/x/bin/evtribo", "acquire", "--notes", "a b"]
        assert lock_module.command_line() == "evtribo acquire --notes 'a b'"
        sys.argv = ["/x/evtribo/__main__.py", "simulate"]
        assert lock_module.command_line() == "python -m evtribo simulate"
    finally:
        sys.argv = saved
