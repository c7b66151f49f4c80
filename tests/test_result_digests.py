"""scripts/result_digests.py: the digests of a result folder's tables and figures, and a file
that differs between two trees (or is written by one only) said and counted."""

from __future__ import annotations

import hashlib
import importlib.util
from pathlib import Path

SCRIPT = Path(__file__).parents[1] / "scripts" / "result_digests.py"


def _script():
    spec = importlib.util.spec_from_file_location("result_digests", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_table_and_figure_is_digested_and_a_difference_is_said(tmp_path):
    script = _script()
    (tmp_path / "figures").mkdir()
    for name, data in (("trials.csv", b"a\n1\n"), ("figures/x.svg", b"<svg/>"),
                       ("summary.json", b"{}")):
        (tmp_path / name).write_bytes(data)
    got = script.digests(tmp_path)
    assert got == {"figures/x.svg": hashlib.sha256(b"<svg/>").hexdigest(),
                   "trials.csv": hashlib.sha256(b"a\n1\n").hexdigest()}
    lines, differ = script.compared(got, dict(got))
    assert differ == 0 and all(line.endswith("same") for line in lines)
    lines, differ = script.compared(got, {"trials.csv": "0" * 64, "fit.csv": "1" * 64})
    assert differ == 3
    assert [line.split()[0] for line in lines if "DIFFERS" in line] == [
        "figures/x.svg", "fit.csv", "trials.csv"]
    assert script.STUDIES == ("data/reference-study", "data/vcan-traces/study")
