"""The command line never writes a decoded table over a raw log, and stops quietly when
its standard output is closed early (``evtribo inspect run.log | head -1``)."""

import os
import subprocess
import sys
from pathlib import Path

import can
import pytest

from evtribo.canlog.rig import default_rig
from evtribo.cli import main

DBC = str(default_rig().dbc)
EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE, what a shell reports for a tool SIGPIPE ended
FRAMES = [can.Message(timestamp=1763700000 + i * 1e-3, arbitration_id=0xC1 + i % 2,
                      is_extended_id=False, data=bytes(8)) for i in range(20)]


def _csv_log(path: Path) -> Path:
    with can.Logger(path) as writer:
        for m in FRAMES:
            writer.on_message_received(m)
    return path


def _unchanged(path: Path):
    before = (path.read_bytes(), path.stat().st_mtime_ns)
    return lambda: (path.read_bytes(), path.stat().st_mtime_ns) == before


@pytest.mark.parametrize("spelling", ["same", "dotted", "symlink", "hardlink"])
def test_decode_never_overwrites_its_own_input_even_with_force(tmp_path, capsys, spelling):
    log = _csv_log(tmp_path / "run-01.csv")
    unchanged = _unchanged(log)
    out = {"same": log, "dotted": tmp_path / "sub" / ".." / "run-01.csv",
           "symlink": tmp_path / "link.csv", "hardlink": tmp_path / "hard.csv"}[spelling]
    (tmp_path / "sub").mkdir()
    if spelling == "symlink":
        out.symlink_to(log)
    elif spelling == "hardlink":
        os.link(log, out)
    code = main(["decode", str(log), "--dbc", DBC, "-o", str(out), "--force"])
    err = capsys.readouterr().err
    assert code == 2
    assert (f"{out}: key '-o': is the log being decoded: evtribo decode never writes over a "
            "study's input or a raw CAN log, --force included") in err
    assert unchanged()


def test_decode_never_overwrites_another_log_even_with_force(tmp_path, capsys):
    log = _csv_log(tmp_path / "run-01.csv")
    other = _csv_log(tmp_path / "run-02.csv")
    unchanged = _unchanged(other)
    code = main(["decode", str(log), "--dbc", DBC, "-o", str(other), "--force"])
    assert code == 2 and unchanged()
    assert "is a CAN log (a python-can CSV log)" in capsys.readouterr().err
    decoded = tmp_path / "decoded.csv"   # a table decode wrote: --force replaces it
    assert main(["decode", str(log), "--dbc", DBC, "-o", str(decoded)]) == 0
    assert main(["decode", str(log), "--dbc", DBC, "-o", str(decoded), "--force"]) == 0


def test_decode_writes_no_csv_into_a_study_subject_folder(tmp_path, capsys):
    study = tmp_path / "study"
    (study / "P01").mkdir(parents=True)
    (study / "study.toml").write_text('name = "x"\n')
    log = _csv_log(study / "P01" / "run-01.csv")
    out = study / "P01" / "run-01-signals.csv"
    assert main(["decode", str(log), "--dbc", DBC, "-o", str(out)]) == 2
    assert ("would be read as a trial's log (run-01-signals.csv in a study's subject folder) "
            "by evtribo analyze") in capsys.readouterr().err
    assert not out.exists()
    assert main(["decode", str(log), "--dbc", DBC, "-o", str(out.with_suffix(".parquet"))]) == 0


def test_decode_channel_column_and_option(tmp_path):
    import pandas as pd

    log = tmp_path / "two.log"
    log.write_text("(1.000000) vcan0 0C1#0000000000000000\n(1.000100) can1 0C1#0100000000000000\n"
                   "(1.001000) vcan0 0C2#0000000000000000\n")
    out = tmp_path / "all.csv"
    assert main(["decode", str(log), "--dbc", DBC, "-o", str(out)]) == 0
    table = pd.read_csv(out)
    assert table["channel"].tolist() == ["vcan0", "can1", "vcan0"]
    assert main(["decode", str(log), "--dbc", DBC, "-o", str(out), "--force",
                 "--channel", "can1"]) == 0
    assert pd.read_csv(out)["Fz"].tolist() == [pytest.approx(1e-5)]
    assert main(["decode", str(log), "--dbc", DBC, "-o", str(out), "--force",
                 "--channel", "can9"]) == 2


def _many_ids_log(path: Path) -> Path:
    """A log whose inspect output (a line per ID) is far larger than a pipe's buffer."""
    path.write_text("".join(f"({1763700000 + i * 1e-3:.6f}) vcan0 {i:08X}#11\n"
                            for i in range(6000)))
    return path


def test_a_closed_stdout_ends_a_command_quietly(tmp_path):
    """``evtribo inspect X | head -1``: no message, no traceback, exit 141 as SIGPIPE."""
    log = _many_ids_log(tmp_path / "many.log")
    proc = subprocess.Popen([sys.executable, "-m", "evtribo", "inspect", str(log)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    first = proc.stdout.readline()
    proc.stdout.close()
    err = proc.stderr.read()
    proc.wait(timeout=60)
    proc.stderr.close()
    assert first.startswith(str(log).encode())
    assert err == b"", err.decode()
    assert proc.returncode == EXIT_BROKEN_PIPE


def test_a_closed_stdout_while_parsing_arguments_is_quiet_too(monkeypatch, capsys):
    read, write = os.pipe()
    os.close(read)
    broken = open(write, "w")
    monkeypatch.setattr(sys, "stdout", broken)
    try:
        assert main(["--help"]) == EXIT_BROKEN_PIPE
    finally:
        monkeypatch.undo()
        broken.close()
    assert capsys.readouterr().err == ""


def test_a_broken_pipe_that_is_not_stdout_is_a_failure(monkeypatch, capsys):
    from evtribo.cli.results import model

    def run(_args):
        raise BrokenPipeError("a pipe to a worker")

    monkeypatch.setattr(model, "run", run)
    assert main(["model", "--list"]) == 1
    assert "failed: BrokenPipeError" in capsys.readouterr().err
