"""The suite's harnesses on a machine without what some tests need: the SocketCAN tests'
stand-ins (``tests/socketcan/conftest.py``) show a host step's failure from the step on, as
a test function's is, without the frames of pytest and pluggy that ran it (hundreds of lines
before the assertion); without Chromium, a test that looks at a page is skipped, saying
why (``tests/_browser.py``)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

CONFTEST = Path(__file__).parent / "socketcan" / "conftest.py"


def _stand_ins():
    spec = importlib.util.spec_from_file_location("socketcan_stand_ins", CONFTEST)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.SocketcanStandIn


def test_a_host_step_s_failure_is_shown_without_pytest_s_and_pluggy_s_frames():
    runners = []  # a runner's code, as pytest's and pluggy's files hold it
    for path in ("/venv/lib/python3.11/site-packages/pluggy/_callers.py",
                 "/venv/lib/python3.11/site-packages/_pytest/runner.py"):
        namespace: dict = {}
        exec(compile("def run(step):\n    return step()\n", path, "exec"), namespace)
        runners.append(namespace["run"])
    pluggy, runner = runners

    def host_step():
        found = [110.0, 140.0]
        assert found == [80.0, 110.0, 140.0]

    with pytest.raises(AssertionError) as caught:
        runner(lambda: pluggy(host_step))
    kept = _stand_ins()._traceback_filter(None, caught)
    names = [entry.name for entry in kept]
    assert "host_step" in names and "run" not in names
    assert not [e for e in kept if "pluggy" in str(e.path) or "_pytest" in str(e.path)]


def test_without_chromium_a_test_that_looks_at_a_page_is_skipped_saying_why(monkeypatch):
    import _browser

    monkeypatch.setattr(_browser, "CHROMIUM", None)
    with pytest.raises(pytest.skip.Exception, match=r"no Chromium .* apt-get install chromium"):
        _browser.Browser()
