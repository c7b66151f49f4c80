"""Shared fixtures of the acquisition tests: the simulated rig as a separate process; the
default rig's load cells heard once as a trial on python-can's virtual bus starts."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable, Iterator

import pytest

from _process import kill_and_reap
from _rigcells import rig_heard


@pytest.fixture
def rig_heard_by_acquire(monkeypatch):
    """Every ``evtribo acquire`` run in this process on python-can's virtual bus hears the
    default rig's load cells once as its trial starts."""
    import evtribo.cli.recording.acquire as cli

    real = cli.record_trial

    def record(bus, *args, **kwargs):
        kwargs["started"] = rig_heard(bus.channel_id, kwargs.get("started"))
        return real(bus, *args, **kwargs)

    monkeypatch.setattr(cli, "record_trial", record)


@pytest.fixture
def simulate_pty() -> Iterator[Callable[..., tuple[subprocess.Popen[str], str]]]:
    """Start ``python -m evtribo simulate --pty ARGS...``; return ``(process, pty path)``.

    The process is killed at the end of the test if it still runs.
    """
    procs: list[subprocess.Popen[str]] = []

    def start(*args: str) -> tuple[subprocess.Popen[str], str]:
        proc = subprocess.Popen(
            [sys.executable, "-m", "evtribo", "simulate", "--pty", *args],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        procs.append(proc)
        path = proc.stdout.readline().strip() if proc.stdout else ""
        if not path.startswith("/dev/"):
            _, err = kill_and_reap(proc, timeout=5)
            pytest.fail(f"simulate --pty printed {path!r}; stderr: {err}")
        return proc, path

    yield start
    for proc in procs:
        kill_and_reap(proc, timeout=5)
