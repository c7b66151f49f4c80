"""The one way a test ends a child process it started (a recorder, a lock holder, the
simulated rig): killed if it still runs, waited for, its pipes read and closed, so that no
process outlives its test and no pipe leaks a ResourceWarning."""

from __future__ import annotations

import subprocess
from typing import Any


def kill_and_reap(proc: subprocess.Popen[Any], timeout: float | None = None) -> tuple[Any, Any]:
    """SIGKILL *proc* unless it has ended; wait for it and return its ``(stdout, stderr)``
    (None for a stream that is not a pipe)."""
    if proc.poll() is None:
        proc.kill()
    if proc.stdin is not None and proc.stdin.closed:  # closed by the test: the child's cue
        proc.stdin = None
    return proc.communicate(timeout=timeout)
