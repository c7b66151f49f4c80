"""Shared fixtures of the acquisition tests: the simulated rig as a separate process."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable, Iterator

import pytest

from _process import kill_and_reap


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
