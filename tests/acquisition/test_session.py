"""``evtribo session``: a subject's protocol against the simulated rig in another process
(over an emulated slcan adapter), the amplifier under command, resumed after a stop."""

from __future__ import annotations

import json
import re
import signal
import subprocess
import sys
import time
from datetime import datetime
from pathlib import Path

import numpy as np
import pytest

from _process import kill_and_reap
from evtribo.canlog.cache import load_trial
from evtribo.canlog.rig import default_rig
from evtribo.documents.session import read_session

PROTOCOL = """\
[session]
trial_s = {trial_s}
repetitions = 1
randomize = true
seed = 5
tare_s = 0.5
on_s = 1.0
off_s = 1.0

[[trial]]
waveform = "square"
frequency_Hz = 10000
amplitude_V = [60, 100, 140]
condition = "alternating"
"""


#: The simulated rig's cells at 250 frames/s: a machine busy enough to receive 3,050 frames/s
#: across two processes at a fraction of their pace still records the session's trials whole
#: (what is tested here is the plan and the amplifier, not the throughput:
#: tests/acquisition/test_slcan.py and benchmarks/acquire.py)
RIG_RATES = ("--fz-rate", "250", "--fx-rate", "250")


#: Longest a session may take before the test calls it hung, s: a guard, not a measure (a
#: machine busy with other suites takes many times the protocol's length).
HANG_S = 900.0


def _session(tmp_path: Path, pty: str, subject: str, *, trial_s: float = 4.0,
             wait: bool = True) -> subprocess.Popen[str]:
    """``evtribo session`` of the protocol, without the check of each trial (an analysis:
    what is tested here is the plan, the amplifier and the resume; the check's output is
    tested against the in-process session below)."""
    protocol = tmp_path / "protocol.toml"
    protocol.write_text(PROTOCOL.format(trial_s=trial_s))
    proc = subprocess.Popen(
        [sys.executable, "-m", "evtribo", "session", str(protocol), "--study",
         str(tmp_path / "study"), "--subject", subject, "--interface", "slcan", "--channel",
         pty, "--bus-option", "sleep_after_open=0", "--yes", "--quiet", "--no-check"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if wait:
        try:
            proc.wait(timeout=HANG_S)
        except subprocess.TimeoutExpired:
            out, err = kill_and_reap(proc, timeout=10)
            pytest.fail(f"the session hung ({HANG_S:g} s): {out[-2000:]}{err[-2000:]}")
    return proc


def _tree(folder: Path) -> dict[str, tuple[int, int]]:
    return {str(p.relative_to(folder)): (p.stat().st_size, p.stat().st_mtime_ns)
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.slow
def test_a_randomized_session_records_the_plan_with_the_commanded_excitation(
        tmp_path, simulate_pty):
    _sim, pty = simulate_pty("--duration", "300", *RIG_RATES)
    proc = _session(tmp_path, pty, "P01")
    out, err = kill_and_reap(proc, timeout=10)
    assert proc.returncode == 0, err
    unconfirmed = {float(v) for v in re.findall(
        r"the amplifier's status does not confirm the command \(off, ([\d.]+) V\)", err)}
    subject = tmp_path / "study" / "P01"
    session = read_session(subject / "session.json")
    assert [t.trial for t in session.order] == ["run-01", "run-02", "run-03"]
    assert list(session.done) == ["run-01", "run-02", "run-03"]
    # the seeded shuffle of the protocol's amplitudes, one trial each
    assert sorted(t.amplitude_V for t in session.order) == [60.0, 100.0, 140.0]
    for planned in session.order:
        sidecar = json.loads((subject / f"{planned.trial}.json").read_text())
        assert sidecar["ended"] == "completed"
        assert (sidecar["amplitude_V"], sidecar["waveform"], sidecar["frequency_Hz"],
                sidecar["condition"], sidecar["tare_s"]) == \
            (planned.amplitude_V, "square", 10000.0, "alternating", 0.5)
        # the amplifier obeyed: off while taring, then switched on (how long each phase
        # lasted depends on how busy this machine was, and is not asserted), and while ON
        # its status reports the commanded amplitude
        ex = load_trial(subject / f"{planned.trial}.log", default_rig(), cache=False).excitation
        on = ex.enabled
        # no frame received before the tare stretch had passed says ON (the first ON is
        # commanded once it has, from the trial's start on, however late the rig answers),
        # unless the session said that the amplifier had not confirmed the OFF it was sent
        # before the trial (a rig too late to answer within SETTLE_S, on a busy machine)
        start = datetime.fromisoformat(sidecar["start_time"]).timestamp()
        assert not on[ex.t < start + sidecar["tare_s"]].any() \
            or planned.amplitude_V in unconfirmed, (planned.trial, err)
        switched = np.flatnonzero(np.diff(on.astype(np.int8)))
        assert on.any() and len(switched) >= 1, planned.trial
        assert set(np.round(ex.amplitude[on], 2)) == {planned.amplitude_V}, planned.trial
    assert "3 of 3 trials done" in out
    # the same command again records nothing
    before = _tree(tmp_path / "study")
    proc = _session(tmp_path, pty, "P01")
    out, err = kill_and_reap(proc, timeout=10)
    assert proc.returncode == 0, err
    assert "3 of 3 trials done" in out
    assert _tree(tmp_path / "study") == before


@pytest.mark.slow
def test_a_session_stopped_mid_trial_goes_on_and_records_each_trial_once(
        tmp_path, simulate_pty):
    _sim, pty = simulate_pty("--duration", "300", *RIG_RATES)
    subject = tmp_path / "study" / "P02"
    proc = _session(tmp_path, pty, "P02", trial_s=3.0, wait=False)
    try:
        deadline = time.monotonic() + HANG_S
        part = subject / "run-02.log.part"
        while not (part.exists() and part.stat().st_size > 1000):  # mid-trial: frames in
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, "run-02 never began"
            time.sleep(0.05)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=HANG_S)
    finally:
        kill_and_reap(proc, timeout=10)
    assert proc.returncode == 0, err
    assert list(read_session(subject / "session.json").done) == ["run-01"]
    assert (subject / "run-01.log").exists() and not (subject / "run-02.log").exists()
    cut = sorted(p.name for p in (subject / "rejected").iterdir())
    assert cut == ["run-02-1.json", "run-02-1.log"]  # kept, out of the study's trials
    first = (subject / "run-01.log").read_bytes()
    proc = _session(tmp_path, pty, "P02", trial_s=3.0)
    out, err = kill_and_reap(proc, timeout=10)
    assert proc.returncode == 0, err
    assert "1 of 3 trials done; going on" in out and "3 of 3 trials done" in out
    session = read_session(subject / "session.json")
    assert list(session.done) == ["run-01", "run-02", "run-03"]
    logs = sorted(p.name for p in subject.glob("*.log"))
    assert logs == ["run-01.log", "run-02.log", "run-03.log"]
    assert (subject / "run-01.log").read_bytes() == first  # never recorded again
    assert sorted(p.name for p in (subject / "rejected").iterdir()) == cut


@pytest.mark.slow
def test_without_a_command_message_the_operator_sets_the_amplifier_and_may_redo(tmp_path):
    # a rig whose amplifier is not under command (the Motorola rig): the session asks the
    # operator to set it; a redone trial's first recording is kept under rejected/
    import io
    import threading

    import can

    from evtribo.acquisition.simulator import Simulator, TrialConfig
    from evtribo.canlog.rig import load_rig
    from evtribo.session import SessionConfig, run_session

    rig_toml = Path(__file__).parents[1] / "data" / "rigs" / "motorola.toml"
    protocol = tmp_path / "protocol.toml"
    protocol.write_text("[session]\ntrial_s = 1.5\ntare_s = 0.3\n[[trial]]\n"
                        "waveform = \"sine\"\nfrequency_Hz = 200\namplitude_V = 90\n"
                        "condition = \"on\"\n")
    answers = iter(["", "r", "", "k"])  # set; redo; set again; keep
    asked: list[str] = []
    seen: list[str] = []  # what the operator had read when asked

    def ask(question: str) -> str:
        asked.append(question)
        seen.append(out.getvalue())
        return next(answers)

    stop = threading.Event()
    channel = f"session-{id(tmp_path)}"
    with can.Bus(interface="virtual", channel=channel) as sim_bus, \
            can.Bus(interface="virtual", channel=channel) as bus:
        sim = Simulator(config=TrialConfig(duration_s=60.0), rig=load_rig(rig_toml))
        thread = threading.Thread(target=sim.run, args=(sim_bus,),
                                  kwargs={"stop_event": stop}, daemon=True)
        thread.start()
        out = io.StringIO()
        try:
            outcome = run_session(bus, SessionConfig(
                protocol=protocol, study=tmp_path / "study", subject="P03", rig=rig_toml,
                stream=out, ask=ask, display=False))
        finally:
            stop.set()
            thread.join(timeout=10)
    text = out.getvalue()
    assert "set the amplifier: sine 200 Hz 90 V, on" in text
    assert len(asked) == 4 and asked[1].startswith("keep run-01?")
    # the check's reasons, each on its line, before the operator decides (the simulated rig
    # here runs on without a tare stretch at the trial's start)
    check = seen[1][seen[1].rindex("check: "):]
    reasons = [line for line in check.splitlines() if line.startswith("  warning: ")]
    assert any("no finger-lifted stretch was found" in r for r in reasons), check
    assert f"{len(reasons)} warning(s)" in check.splitlines()[0]
    assert len(set(reasons)) == len(reasons)
    assert outcome.recorded == ["run-01"] and outcome.rejected == ["run-01-1"]
    subject = tmp_path / "study" / "P03"
    assert sorted(p.name for p in (subject / "rejected").iterdir()) == \
        ["run-01-1.json", "run-01-1.log"]
    assert json.loads((subject / "run-01.json").read_text())["amplitude_V"] == 90.0
    assert list(read_session(subject / "session.json").done) == ["run-01"]
