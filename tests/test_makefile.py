"""The Makefile's two first commands on a fresh clone: ``make demo`` installs evtribo and what
it runs on, nothing of the test suite's; ``make test`` adds the test, mf4 and dask extras.
Read from ``make -n`` (what make would run), in a copy of the Makefile."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[1]

pytestmark = pytest.mark.skipif(shutil.which("make") is None, reason="no make here")


def _would_run(tmp_path: Path, target: str) -> str:
    for name in ("Makefile", "pyproject.toml"):
        shutil.copy(ROOT / name, tmp_path / name)
    return subprocess.run(["make", "-n", target], cwd=tmp_path, capture_output=True,
                          text=True, check=True, timeout=60).stdout


def test_make_demo_installs_what_the_demo_needs_only(tmp_path):
    commands = _would_run(tmp_path, "demo")
    installs = [c for c in commands.splitlines() if "pip install" in c]
    assert installs and installs[-1].endswith(" -e .")
    assert "[test" not in commands and "dask" not in commands.split("pip install")[-1]
    assert "evtribo demo --out demo-output" in commands


def test_make_test_installs_the_test_extras_then_runs_the_suite(tmp_path):
    commands = _would_run(tmp_path, "test")
    assert "-e '.[test,mf4,dask]'" in commands
    assert "-m pytest -n 3 -q" in commands
