"""Suite-wide settings: hypothesis profiles and a private cache of decoded trials; result
folders with known air gaps for the fit, figure and report tests (``synthetic.py``); how the
tests are shared between pytest-xdist's workers.

Under ``pytest -n N`` (``--dist loadgroup``) each test module is one unit of work, run by one
worker (:func:`pytest_xdist_make_scheduler`), so that a module-scoped fixture (a simulated
study, its analysis, a cluster) is made once, not once on each worker; the SocketCAN VM's
stand-ins are one unit, first (``tests/socketcan/conftest.py``). The modules go out
longest first, by the seconds each took when last measured (``tests/module_seconds.json``,
a busy machine's figures: only their order counts), so that no long module starts last
while the other workers idle; a module not listed goes after the listed ones, first if it
has slow tests. ``EVTRIBO_MODULE_SECONDS=write pytest -n 3`` writes the file again.
"""

import json
import os
from collections import Counter
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

#: The seconds each test module took when last measured (setup, call and teardown).
MODULE_SECONDS = Path(__file__).with_name("module_seconds.json")
#: The SocketCAN VM's stand-ins' group (``tests/socketcan/conftest.py``).
VM_GROUP = "socketcan-vm"

# Property tests run a bounded number of examples, the same ones on every run (derandomised:
# a suite that is red or green by the draw says nothing of a change); HYPOTHESIS_PROFILE=
# thorough runs more, drawn afresh, to look for what the fixed ones miss.
settings.register_profile("ci", max_examples=100, deadline=None, derandomize=True,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("thorough", max_examples=5_000, deadline=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture(autouse=True, scope="session")
def _private_cache_dir(tmp_path_factory):
    """Decoded-trial cache in a temporary folder, not the user's ~/.cache."""
    old = os.environ.get("EVTRIBO_CACHE_DIR")
    os.environ["EVTRIBO_CACHE_DIR"] = str(tmp_path_factory.mktemp("evtribo-cache"))
    yield
    if old is None:
        os.environ.pop("EVTRIBO_CACHE_DIR", None)
    else:
        os.environ["EVTRIBO_CACHE_DIR"] = old


@pytest.fixture
def out_dir(tmp_path: Path) -> Path:
    """A synthetic result folder with known air gaps (see synthetic.py)."""
    from synthetic import make_out

    return make_out(tmp_path / "out")


@pytest.fixture(scope="module")
def compared_out(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A synthetic result folder on which ``compare`` has run (low-dpi figures)."""
    from evtribo.report.compare import compare
    from synthetic import make_out

    folder = make_out(tmp_path_factory.mktemp("cmp") / "out",
                      note="<script>alert('x')</script> & notes")
    compare(folder, dpi=40)
    return folder


#: The SocketCAN VM's figures, as its stand-ins report them (tests/socketcan/conftest.py).
_VM_FIGURES: list[dict[str, float | str]] = []


#: Seconds per test module in this run (setup, call and teardown).
_SECONDS: Counter[str] = Counter()


def pytest_runtest_logreport(report):
    _SECONDS[_module(report.nodeid)] += report.duration
    for name, value in getattr(report, "user_properties", ()):
        if name == "socketcan_vm" and value not in _VM_FIGURES:
            _VM_FIGURES.append(value)


def pytest_terminal_summary(terminalreporter):
    for fig in _VM_FIGURES:
        terminalreporter.write_line(
            f"SocketCAN VM: booted in {fig['boot_s']} s, its tests ran {fig['tests_s']} s, "
            f"{fig['wall_s']} s from start to power-off (slowest: {fig.get('slowest')})")


# ------------------------------------------------------------------------------------------
# Sharing the tests between the workers
# ------------------------------------------------------------------------------------------
def _module(nodeid: str) -> str:
    return nodeid.split("::", 1)[0]


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """On pytest-xdist's workers (``--dist loadgroup``): the VM's stand-ins first, then the
    modules longest first; a module's tests stay together, in their order."""
    if not getattr(config.option, "loadgroup", False):
        return
    seconds = json.loads(MODULE_SECONDS.read_text(encoding="utf-8"))
    slow = {_module(i.nodeid) for i in items if i.get_closest_marker("slow")}
    longest = max(seconds.values(), default=0)

    def rank(item: pytest.Item) -> tuple[int, float]:
        if item.nodeid.endswith("@" + VM_GROUP):
            return 0, 0.0
        module = _module(item.nodeid)
        if module in seconds:
            return 1, -seconds[module]
        return 1, -(longest + 1) if module in slow else 1.0

    items.sort(key=rank)  # stable


def pytest_xdist_make_scheduler(config: pytest.Config, log: object) -> object | None:
    """``--dist loadgroup`` by module: each module one unit of work (its module-scoped
    fixtures made once), the VM's stand-ins one unit; the units in the workers' order."""
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class ByModule(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            name = nodeid.rpartition("::")[2]
            if "@" in name and nodeid.rfind("@") > nodeid.rfind("]"):
                return nodeid.rsplit("@", 1)[1]  # a group (the VM's stand-ins)
            return _module(nodeid)

    config.option.loadscopereorder = False  # the workers' order: longest first
    return ByModule(config, log)


def pytest_sessionfinish(session: pytest.Session) -> None:
    """With ``EVTRIBO_MODULE_SECONDS=write``: the seconds each module took, into
    ``tests/module_seconds.json`` (on the controller, or a run without workers)."""
    if os.environ.get("EVTRIBO_MODULE_SECONDS") != "write" or \
            os.environ.get("PYTEST_XDIST_WORKER") or not _SECONDS:
        return
    ranked = {m: round(s) for m, s in _SECONDS.most_common()
              if not m.startswith("tests/socketcan/")}
    MODULE_SECONDS.write_text(json.dumps(ranked, indent=1) + "\n", encoding="utf-8")
