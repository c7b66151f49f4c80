"""The SocketCAN tests run in a VM whose kernel has a CAN stack (``tests/_vcanvm.py``).

On a machine whose kernel has no SocketCAN, every test of this folder is replaced at
collection by a stand-in; the first stand-in to run boots the VM once and runs the whole
folder's selected tests there, in one pytest process; each stand-in then reports its test's
outcome in the guest (its failure text, its skip or expected-failure reason). Where the VM
cannot run, they skip and say why. In the guest (``EVTRIBO_SOCKETCAN_HERE=1``, which the
harness sets; set it on a Linux machine with the ``vcan`` module, as root, to run them
directly) the tests run as they are: each makes its own ``vcan`` interface.

The VM emulates its processors in software, 10 to 50 times slower than this machine: a test
does there only what needs the kernel (recording, replaying), and leaves the rest to
this machine through ``_socketcan.on_host``: a ``before`` step (making a trace) runs here
before the VM boots, an ``after`` step (decoding, analysing what was recorded) after it,
both on the test's ``exports`` folder, which the VM shares.

The stand-ins are one group of pytest-xdist's ``--dist loadgroup`` (their node ids end in
``@socketcan-vm``): ``make test`` sends them to one worker, and first, so the VM works while
the other worker runs the rest.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from itertools import count
from pathlib import Path
from typing import Any

import pytest

HERE = os.environ.get("EVTRIBO_SOCKETCAN_HERE") == "1"
#: The folder shared with the host, holding each test's ``exports`` folder (in the VM).
EXPORTS_ENV = "EVTRIBO_SOCKETCAN_EXPORTS"
#: The file (in the VM's ``$VCANVM_OUT``) the guest's pytest writes its reports to, one JSON
#: object per line.
REPORT_FILE = "socketcan-report.jsonl"
#: Longest time the VM may take for the whole folder, s.
VM_TIMEOUT_S = float(os.environ.get("EVTRIBO_VCAN_VM_TIMEOUT", "1800"))
#: The VM's processors: one, so that it takes at most one of the machine's cores from the
#: rest of the suite (``make test``: three workers on two cores), and a vcan interface
#: delivers a sender's frames in the order sent (with two, a sender moved from one to the
#: other can see two of its frames delivered swapped: each processor has its own backlog
#: queue).
VM_CPUS = 1
#: Environment variables the guest's tests see as the host's (PYTHONPATH: the sources a
#: checkout runs with, when they are not the ones installed in its environment).
PASSED_ON = ("HYPOTHESIS_PROFILE", "EVTRIBO_REPLAY_STUDIES", "PYTHONPATH")
#: Set to 1 to keep the tests' exports folder (what each test recorded) after the run.
KEEP_ENV = "EVTRIBO_SOCKETCAN_KEEP"
GROUP = "socketcan-vm"
FOLDER = Path(__file__).parent


def _folder_name(nodeid: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", nodeid.split("@", maxsplit=1)[0])[-120:]


# ------------------------------------------------------------------------------------------
# In the guest (or on a machine with vcan): a fresh vcan interface per test, the exports
# folder, the host steps (on a machine with vcan), and the reports (in the VM)
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


@pytest.fixture
def exports(request: pytest.FixtureRequest, tmp_path: Path) -> Path:
    """The test's folder shared with its host steps (``_socketcan.on_host``)."""
    root = os.environ.get(EXPORTS_ENV)
    folder = (Path(root) if root else tmp_path) / _folder_name(request.node.nodeid)
    folder.mkdir(parents=True, exist_ok=True)
    return folder


@pytest.hookimpl(wrapper=True)
def pytest_pyfunc_call(pyfuncitem: pytest.Function) -> Any:
    """On a machine with vcan (no VM), a test's host steps run around it, here."""
    steps = getattr(pyfuncitem.obj, "host_steps", None)
    direct = steps is not None and HERE and not os.environ.get(EXPORTS_ENV)
    if direct and steps.before is not None:
        steps.before(pyfuncitem.funcargs["exports"])
    result = yield
    if direct and steps.after is not None:
        steps.after(pyfuncitem.funcargs["exports"])
    return result


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    out = os.environ.get("VCANVM_OUT")
    if not out or not HERE:
        return
    if report.when != "call" and report.passed:
        return
    outcome, reason = report.outcome, ""
    if hasattr(report, "wasxfail"):
        outcome, reason = "xfailed", str(report.wasxfail)
    elif report.skipped and isinstance(report.longrepr, tuple):
        reason = str(report.longrepr[2])
    entry = {"nodeid": report.nodeid, "when": report.when, "outcome": outcome,
             "duration": report.duration, "reason": reason,
             "longrepr": report.longreprtext if report.failed else ""}
    with open(os.path.join(out, REPORT_FILE), "a", encoding="utf-8") as fh:
        fh.write(json.dumps(entry) + "\n")


# ------------------------------------------------------------------------------------------
# On a machine without SocketCAN: the stand-ins and the one VM run
# ------------------------------------------------------------------------------------------
class _GuestRun:
    """The whole folder's tests, run once in the VM; their reports by node id."""

    def __init__(self, config: pytest.Config) -> None:
        self.config = config
        self.done = False
        self.skip_reason: str | None = None
        self.error: str | None = None
        self.before_failed: dict[str, BaseException] = {}
        self.reports: dict[str, list[dict[str, Any]]] = {}
        self.figures: dict[str, float | str] = {}
        self.output = ""
        self.exports = Path(tempfile.mkdtemp(prefix="socketcan-exports-"))
        if os.environ.get(KEEP_ENV) != "1":
            config.add_cleanup(lambda: shutil.rmtree(self.exports, ignore_errors=True))

    def folder(self, nodeid: str) -> Path:
        return self.exports / _folder_name(nodeid)

    def run(self, session: pytest.Session) -> None:
        """Boot the VM and run the session's stand-ins' tests there (once)."""
        if self.done:
            return
        self.done = True
        stand_ins = [i for i in session.items if isinstance(i, SocketcanStandIn)]
        sys.path.insert(0, str(FOLDER.parent))
        import _vcanvm

        self.skip_reason = _vcanvm.unavailable()
        if self.skip_reason is not None:
            return
        for item in stand_ins:  # the host's steps before the VM
            self.folder(item.original_nodeid).mkdir(parents=True, exist_ok=True)
            if item.steps is not None and item.steps.before is not None:
                try:
                    item.steps.before(self.folder(item.original_nodeid))
                except Exception as err:
                    self.before_failed[item.original_nodeid] = err
        nodeids = [i.original_nodeid for i in stand_ins
                   if i.original_nodeid not in self.before_failed]
        env = {"PATH": "/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin",
               "HOME": "/root", "LANG": "C.UTF-8", "EVTRIBO_SOCKETCAN_HERE": "1",
               "PYTHONUNBUFFERED": "1", EXPORTS_ENV: str(self.exports),
               **{k: os.environ[k] for k in PASSED_ON if k in os.environ}}
        argv = [sys.executable, "-m", "pytest", "-q", "-n", "0", "-p", "no:cacheprovider",
                "--tb=short",
                "--basetemp", "/tmp/pytest-socketcan", *nodeids]
        t0 = time.monotonic()
        try:
            guest = _vcanvm.run(argv, cwd=self.config.rootpath, env=env, timeout=VM_TIMEOUT_S,
                                writable=[self.exports], cpus=VM_CPUS)
        except Exception as err:  # the VM failed: every test says so
            self.error = f"the VM failed: {type(err).__name__}: {err}"
            return
        for line in guest.files.get(REPORT_FILE, "").splitlines():
            entry = json.loads(line)
            self.reports.setdefault(entry["nodeid"], []).append(entry)
        self.figures = self._figures(guest.boot_s, guest.command_s, time.monotonic() - t0)
        self.output = guest.stdout[-6000:] + guest.stderr[-3000:]

    def _figures(self, boot: float, ran: float, wall: float) -> dict[str, float | str]:
        slowest = sorted(((e["duration"], e["nodeid"].rsplit("::", 1)[-1])
                          for entries in self.reports.values() for e in entries
                          if e["when"] == "call"), reverse=True)[:3]
        return {"boot_s": round(boot, 1), "tests_s": round(ran, 1), "wall_s": round(wall, 1),
                "slowest": ", ".join(f"{name} {d:.0f} s" for d, name in slowest)}


_RUN = pytest.StashKey[_GuestRun]()
#: Where pytest's and pluggy's own frames come from, and this stand-in's running of them.
_INTERNALS = re.compile(r"[/\\](_pytest|pluggy|xdist)[/\\]|[/\\]socketcan[/\\]conftest\.py$")


class GuestFailure(Exception):
    """A test failed in the VM (the text is the guest's report)."""


class SocketcanStandIn(pytest.Item):
    """Stands for a test of this folder on a machine without SocketCAN: reports how it went
    in the VM, and runs its host steps."""

    def __init__(self, *, original_nodeid: str, steps: Any, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.original_nodeid = original_nodeid
        self.steps = steps

    def runtest(self) -> None:
        run = self.config.stash[_RUN]
        run.run(self.session)
        if run.skip_reason is not None:
            pytest.skip(f"no VM with SocketCAN: {run.skip_reason}")
        if self.original_nodeid in run.before_failed:
            raise run.before_failed[self.original_nodeid]
        if run.error is not None:
            raise GuestFailure(run.error)
        if run.figures:
            self.user_properties.append(("socketcan_vm", dict(run.figures)))
        entries = run.reports.get(self.original_nodeid)
        if not entries:
            raise GuestFailure("the VM ran no such test; its output ends:\n" + run.output)
        self._report(entries)
        if self.steps is not None and self.steps.after is not None:
            self.steps.after(run.folder(self.original_nodeid))

    @staticmethod
    def _report(entries: list[dict[str, Any]]) -> None:
        """The guest's outcome, here: raise its failure, or skip or xfail as it did."""
        for entry in entries:
            if entry["outcome"] == "failed":
                raise GuestFailure(f"in the VM ({entry['when']}):\n{entry['longrepr']}")
        for entry in entries:
            if entry["outcome"] == "xfailed":
                pytest.xfail(f"in the VM: {entry['reason']}")
            if entry["outcome"] == "skipped":
                pytest.skip(f"in the VM: {entry['reason']}")

    def repr_failure(self, excinfo: pytest.ExceptionInfo[BaseException],
                     style: Any = None) -> Any:
        if isinstance(excinfo.value, GuestFailure):
            return str(excinfo.value)
        return super().repr_failure(excinfo, style=style)

    def _traceback_filter(self, excinfo: pytest.ExceptionInfo[BaseException]) -> Any:
        """A host step's failure from the step on, as a test function's is shown: not the
        frames of pytest and pluggy that ran this stand-in (hundreds of lines)."""
        kept = excinfo.traceback.filter(excinfo).filter(
            lambda entry: not _INTERNALS.search(str(entry.path)))
        return kept or excinfo.traceback

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
        steps = getattr(getattr(item, "obj", None), "host_steps", None)
        # on an xdist worker, the stand-ins are one group of --dist loadgroup (what its
        # xdist_group mark does, which this pytest's node ids no longer take)
        grouped = getattr(config.option, "loadgroup", False)
        new = SocketcanStandIn.from_parent(
            item.parent, name=item.name, original_nodeid=item.nodeid, steps=steps,
            nodeid=f"{item.nodeid}@{GROUP}" if grouped else None)
        new.own_markers = list(item.own_markers)
        new.keywords.update(item.keywords)
        stand_ins.append(new)
    items[:] = stand_ins + others
    config.stash[_RUN] = _GuestRun(config)
