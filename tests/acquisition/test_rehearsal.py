"""The README's rehearsal of one's own rig without hardware, run as written: a study made by
``evtribo init`` from another lab's DBC (Motorola cells at 0x210/0x211, an amplifier without
a command message), the simulated rig speaking it on an emulated slcan adapter, a session
of two trials, then ``evtribo analyze``: every trial tared on its own lifted stretch."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from _process import kill_and_reap
from evtribo.cli import main

README = Path(__file__).parents[2] / "README.md"
DBC = Path(__file__).parents[1] / "data" / "rigs" / "motorola.dbc"
PROTOCOL = """\
[session]
trial_s = 5.0
repetitions = 1
tare_s = 1.0
on_s = 1.0
off_s = 1.0

[[trial]]
waveform = "square"
frequency_Hz = 10000
amplitude_V = [80, 140]
condition = "alternating"
"""

#: The recipe's commands as the README gives them (the pty's path as in its example).
SESSION = ("evtribo session protocol.toml --study my-study --subject P00 \\\n"
           "    --interface slcan_bulk --channel /dev/pts/3 --bus-option sleep_after_open=0 "
           "--yes")
SIMULATE = "evtribo simulate --pty --rig my-study &"
ANALYZE = "evtribo analyze my-study --out rehearsal-results"


def _args(command: str, pty: str) -> list[str]:
    return command.replace("\\\n", " ").replace("/dev/pts/3", pty).split()[1:]


@pytest.mark.slow
def test_the_readme_rehearsal_runs_and_each_trial_is_tared(tmp_path, simulate_pty, capsys,
                                                         monkeypatch):
    text = README.read_text(encoding="utf-8")
    for command in (SIMULATE, SESSION, ANALYZE):
        assert command in text
    monkeypatch.chdir(tmp_path)
    assert main(["init", "my-study", "--dbc", str(DBC)]) == 0
    (tmp_path / "protocol.toml").write_text(PROTOCOL)
    _sim, pty = simulate_pty(*_args(SIMULATE, "")[1:-1])  # --rig my-study
    session = subprocess.run([sys.executable, "-m", "evtribo", *_args(SESSION, pty)],
                             capture_output=True, text=True, timeout=180, cwd=tmp_path,
                             check=False)
    assert session.returncode == 0, session.stderr
    assert "2 of 2 trials done" in session.stdout
    capsys.readouterr()
    assert main(_args(ANALYZE, pty)) == 0
    said = capsys.readouterr().err
    assert "no finger-lifted stretch" not in said
    trials = pd.read_csv(tmp_path / "rehearsal-results" / "trials.csv")
    assert list(trials["trial"]) == ["run-01", "run-02"]
    assert (trials["tare"].astype(str) == "lifted").all(), trials.to_string()
    kill_and_reap(_sim, timeout=5)
