"""Suite-wide settings: hypothesis profiles and a private cache of decoded trials; result
folders with known air gaps for the fit, figure and report tests (``synthetic.py``)."""

import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

# Property tests run a bounded number of examples in CI; HYPOTHESIS_PROFILE=thorough runs more.
settings.register_profile("ci", max_examples=100, deadline=None,
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


def pytest_runtest_logreport(report):
    for name, value in getattr(report, "user_properties", ()):
        if name == "socketcan_vm" and value not in _VM_FIGURES:
            _VM_FIGURES.append(value)


def pytest_terminal_summary(terminalreporter):
    for fig in _VM_FIGURES:
        terminalreporter.write_line(
            f"SocketCAN VM: booted in {fig['boot_s']} s, its tests ran {fig['tests_s']} s, "
            f"{fig['wall_s']} s from start to power-off (slowest: {fig.get('slowest')})")
