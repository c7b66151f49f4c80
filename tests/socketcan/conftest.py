"""The SocketCAN tests run in a VM whose kernel has a CAN stack (``tests/_vcanvm.py``).

On a machine whose kernel has no SocketCAN, every test of this folder is replaced at
collection by a stand-in; the first stand-in to run boots the VM once and runs the whole
folder's selected tests there, in one pytest process; each stand-in then reports its test's
outcome in the guest (its failure text, its skip reason). Where the VM cannot run, they skip
and say why. In the guest (``EVTRIBO_SOCKETCAN_HERE=1``, which the harness sets; set it on a
Linux machine with the ``vcan`` module, as root, to run them directly) the tests run as they
are: each makes its own ``vcan`` interface.

The stand-ins are one ``xdist_group``: ``make test`` (``--dist loadgroup``) sends them to one
worker, and puts them first, so the VM works while the other worker runs the rest.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from itertools import count
from pathlib import Path
from typing import Any

import pytest

HERE = os.environ.get("EVTRIBO_SOCKETCAN_HERE") == "1"
#: The file (in the VM's ``$VCANVM_OUT``) the guest's pytest writes its reports to, one JSON
#: object per line.
REPORT_FILE = "socketcan-report.jsonl"
#: Longest time the VM may take for the whole folder, s.
VM_TIMEOUT_S = float(os.environ.get("EVTRIBO_VCAN_VM_TIMEOUT", "1200"))
GROUP = "socketcan-vm"
FOLDER = Path(__file__).parent


# ------------------------------------------------------------------------------------------
# In the guest (or on a machine with vcan): a fresh vcan interface per test, and reports
# ------------------------------------------------------------------------------------------
_numbers = count()


def _ip(*args: str) -> None:
    subprocess.run(["ip", "link", *args], check=True, capture_output=True)


@pytest.fixture
def vcan() -> Iterator[str]:
    """A new ``vcan`` interface, up, MTU 72 (classic and CAN FD frames); deleted after."""
    name = f"vcant{os.getpid() % 1000}x{next(_numbers)}"
    _ip("add", "dev", name, "type", "vcan")
    try:
        _ip("set", name, "mtu", "72")
        _ip("set", "up", name)
        yield name
    finally:
        _ip("delete", name)


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    out = os.environ.get("VCANVM_OUT")
    if not out or not HERE:
        return
    if report.when != "call" and report.passed:
        return
    reason = ""
    if report.skipped and isinstance(report.longrepr, tuple):
        reason = str(report.longrepr[2])
    entry = {"nodeid": report.nodeid, "when": report.when, "outcome": report.outcome,
             "duration": report.duration, "reason": reason,
             "longrepr": "" if report.passed or report.skipped else report.longreprtext,
             "sections": [list(s) for s in report.sections] if report.failed else []}
    with open(os.path.join(out, REPORT_FILE), "a", encoding="utf-8") as fh:
        fh.write(json.dumps(entry) + "\n")


# ------------------------------------------------------------------------------------------
# On a machine without SocketCAN: the stand-ins and the one VM run
# ------------------------------------------------------------------------------------------
class _GuestRun:
    """The whole folder's tests, run once in the VM; their reports by node id."""

    def __init__(self, config: pytest.Config, nodeids: list[str]) -> None:
        self.config = config
        self.nodeids = nodeids
        self.done = False
        self.skip_reason: str | None = None
        self.error: str | None = None
        self.reports: dict[str, list[dict[str, Any]]] = {}
        self.figures: dict[str, float | str] = {}
        self.output = ""

    def run(self) -> None:
        if self.done:
            return
        self.done = True
        sys.path.insert(0, str(FOLDER.parent))
        import _vcanvm

        self.skip_reason = _vcanvm.unavailable()
        if self.skip_reason is not None:
            return
        env = {"PATH": "/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin",
               "HOME": "/root", "LANG": "C.UTF-8", "EVTRIBO_SOCKETCAN_HERE": "1",
               "PYTHONUNBUFFERED": "1",
               "HYPOTHESIS_PROFILE": os.environ.get("HYPOTHESIS_PROFILE", "ci")}
        argv = [sys.executable, "-m", "pytest", "-q", "-n", "0", "-p", "no:cacheprovider",
                "--basetemp", "/tmp/pytest-socketcan", *self.nodeids]
        t0 = time.monotonic()
        try:
            guest = _vcanvm.run(argv, cwd=self.config.rootpath, env=env,
                                timeout=VM_TIMEOUT_S)
        except Exception as err:  # the VM failed: every test says so
            self.error = f"the VM failed: {type(err).__name__}: {err}"
            return
        for line in guest.files.get(REPORT_FILE, "").splitlines():
            entry = json.loads(line)
            self.reports.setdefault(entry["nodeid"], []).append(entry)
        slowest = sorted(((e["duration"], e["nodeid"].rsplit("::", 1)[-1])
                          for entries in self.reports.values() for e in entries
                          if e["when"] == "call"), reverse=True)[:3]
        self.figures = {"boot_s": round(guest.boot_s, 1), "tests_s": round(guest.command_s, 1),
                        "wall_s": round(time.monotonic() - t0, 1),
                        "slowest": ", ".join(f"{name} {d:.0f} s" for d, name in slowest)}
        self.output = guest.stdout[-6000:] + guest.stderr[-3000:]


_RUN = pytest.StashKey[_GuestRun]()


class GuestFailure(Exception):
    """A test failed in the VM (the text is the guest's report)."""


class SocketcanStandIn(pytest.Item):
    """Stands for a test of this folder on a machine without SocketCAN: reports how it went
    in the VM."""

    def __init__(self, *, original_nodeid: str, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.original_nodeid = original_nodeid

    def runtest(self) -> None:
        run = self.config.stash[_RUN]
        run.run()
        if run.skip_reason is not None:
            pytest.skip(f"no VM with SocketCAN: {run.skip_reason}")
        if run.error is not None:
            raise GuestFailure(run.error)
        if run.figures:
            self.user_properties.append(("socketcan_vm", dict(run.figures)))
        entries = run.reports.get(self.original_nodeid)
        if not entries:
            raise GuestFailure("the VM ran no such test; its output ends:\n" + run.output)
        for entry in entries:
            if entry["outcome"] == "failed":
                raise GuestFailure(f"in the VM ({entry['when']}):\n{entry['longrepr']}")
        for entry in entries:
            if entry["outcome"] == "skipped":
                pytest.skip(f"in the VM: {entry['reason']}")

    def repr_failure(self, excinfo: pytest.ExceptionInfo[BaseException],
                     style: Any = None) -> str:
        if isinstance(excinfo.value, GuestFailure):
            return str(excinfo.value)
        return str(super().repr_failure(excinfo))

    def reportinfo(self) -> tuple[Path, int | None, str]:
        return self.path, None, self.name


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(session: pytest.Session, config: pytest.Config,
                                  items: list[pytest.Item]) -> None:
    """Replace this folder's tests by stand-ins (unless SocketCAN is here), first in line."""
    if HERE:
        return
    mine, others = [], []
    for item in items:
        (mine if FOLDER in Path(item.path).parents else others).append(item)
    if not mine:
        return
    stand_ins = []
    for item in mine:
        new = SocketcanStandIn.from_parent(item.parent, name=item.name,
                                           original_nodeid=item.nodeid)
        new.own_markers = [*item.own_markers, pytest.mark.xdist_group(GROUP).mark]
        new.keywords.update(item.keywords)
        stand_ins.append(new)
    items[:] = stand_ins + others
    config.stash[_RUN] = _GuestRun(config, [i.nodeid for i in mine])
