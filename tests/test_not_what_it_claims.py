"""No command hangs on a file that is not what it claims: a FIFO (reading blocks until a
writer comes), a link to ``/dev/zero`` (reading never ends). Each is refused with exit code
2 naming it, and nothing is written. Every command runs in its own process, with a time
limit that only a hang reaches.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import _studies
from evtribo.canlog.rig import default_rig_path

DBC = default_rig_path().with_name("default.dbc")
LOG = ("(1763700000.000000) vcan0 0C1#0000000000000000\n"
       "(1763700000.001000) vcan0 0C2#0000000000000000\n")
SIDECAR = {"subject": "P01", "waveform": "square", "frequency_Hz": 10000, "amplitude_V": 140,
           "condition": "alternating"}
RIG = {"dbc": "rig/default.dbc", "normal_force": "FzCell.Fz", "tangential_force": "FxCell.Fx"}
#: A command that hangs is stopped after this long (a command that works takes a few s).
HANG_S = 60


def _replace(path: Path, kind: str) -> None:
    path.unlink(missing_ok=True)
    if kind == "fifo":
        os.mkfifo(path)
    else:
        path.symlink_to("/dev/zero")


def _results(tmp: Path) -> None:
    """A result folder's files, as stand-ins: each table its columns' header, so that the
    command, whichever table it reads first, stops at the one replaced."""
    from evtribo.documents.tables import ELECTROSTATIC, EXPONENTS, TRIALS, WINDOWS

    out = tmp / "out"
    out.mkdir()
    for schema in (TRIALS, WINDOWS, ELECTROSTATIC, EXPONENTS):
        (out / schema.file).write_text(",".join(schema.names()) + "\n")
    (out / "summary.json").write_text("{}")


#: (what is replaced, the command); STUDY, OUT and TMP as in docs/errors.md.
CASES = {
    "analyze-study-toml": ("study/study.toml", "analyze STUDY --out TMP/new"),
    "analyze-dbc": ("study/rig/default.dbc", "analyze STUDY --out TMP/new"),
    "analyze-sidecar": ("study/P01/run-01.json", "analyze STUDY --out TMP/new"),
    "export-study-toml": ("study/study.toml", "export STUDY -o TMP/forces.mf4"),
    "plot-study-toml": ("study/study.toml", "plot trial STUDY P01 run-01 -o TMP/check.png"),
    "decode-log": ("study/P01/run-01.log", "decode STUDY/P01/run-01.log --dbc "
                   "STUDY/rig/default.dbc -o TMP/run-01.csv"),
    "decode-dbc": ("study/rig/default.dbc", "decode STUDY/P01/run-01.log --dbc "
                   "STUDY/rig/default.dbc -o TMP/run-01.csv"),
    "inspect-log": ("study/P01/run-01.log", "inspect STUDY/P01/run-01.log"),
    "plot-log": ("study/P01/run-01.log", "plot STUDY/P01/run-01.log --dbc "
                 "STUDY/rig/default.dbc FzCell.Fz -o TMP/signals.png"),
    "report-summary": ("out/summary.json", "report OUT -o TMP/report.html"),
    "compare-table": ("out/electrostatic.csv", "compare OUT"),
}


@pytest.mark.parametrize("kind", ["fifo", "dev-zero"])
@pytest.mark.parametrize("case", sorted(CASES))
def test_no_command_hangs_on_a_file_that_is_not_what_it_claims(case, kind, tmp_path):
    _studies.make_study(tmp_path / "study", {"P01/run-01": SIDECAR}, rig=RIG, log=LOG,
                        dbc=DBC, name="not what it claims")
    _results(tmp_path)
    rel, command = CASES[case]
    _replace(tmp_path / rel, kind)
    where = {"STUDY": tmp_path / "study", "OUT": tmp_path / "out", "TMP": tmp_path}
    argv = [os.fspath(where.get(w.split("/")[0], "")) + w[len(w.split("/")[0]):]
            if w.split("/")[0] in where else w for w in command.split()]
    before = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*"))
    env = {**os.environ, "MPLBACKEND": "Agg"}
    try:
        proc = subprocess.run([sys.executable, "-m", "evtribo", *argv], capture_output=True,
                              text=True, timeout=HANG_S, env=env, check=False)
    except subprocess.TimeoutExpired:
        pytest.fail(f"evtribo {command} hung on {rel} ({kind})")
    finally:
        shutil.rmtree(tmp_path / "cache", ignore_errors=True)
    assert proc.returncode == 2, proc.stderr
    assert str(tmp_path / rel) in proc.stderr or "/dev/zero" in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr
    assert "no such file" not in proc.stderr  # it exists: said for what it is
    after = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*"))
    assert after == before
