"""Wall time and peak memory of a command in a fresh process, for the benchmarks."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Mapping

#: Runs a command and prints its wall seconds and peak resident set size (KiB). The measured
#: command is a child of this small process, not of the benchmark: on Linux a child's
#: ``ru_maxrss`` starts from its parent's size at the fork.
LAUNCHER = """
import os, subprocess, sys, time
t = time.perf_counter()
p = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL)
_, status, usage = os.wait4(p.pid, 0)
print(time.perf_counter() - t, usage.ru_maxrss, os.waitstatus_to_exitcode(status))
"""


def run(cmd: list[str], env: Mapping[str, str] | None = None) -> tuple[float, float]:
    """Wall seconds and peak resident set size (MB) of a command in a fresh process (with
    *env* as its environment, when given)."""
    proc = subprocess.run([sys.executable, "-c", LAUNCHER, *cmd], capture_output=True,
                          text=True, check=True, env=None if env is None else dict(env))
    elapsed, maxrss, code = proc.stdout.split()
    if int(code) != 0:
        raise SystemExit(f"{cmd[:4]} failed: {proc.stderr[-2000:]}")
    return float(elapsed), int(maxrss) / 1024
