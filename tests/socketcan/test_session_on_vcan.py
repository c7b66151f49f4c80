"""The whole protocol on SocketCAN: the simulated rig on a vcan interface (``evtribo
simulate --interface socketcan``, its amplifier obeying the command frames), ``evtribo
session`` against it with the live view, stopped by Ctrl-C mid-trial and resumed; then, on
the host (``_socketcan.on_host``), what the amplifier did in each trial and the study
analysed. The session's own check of each trial (an analysis) is left out in the VM
(``--no-check``): its processors are emulated, an analysis takes a minute there.

The VM's one emulated processor keeps real time only as far as the machine lets it: on a
busy machine the simulated rig falls behind and a trial records less of the protocol than
it ran. The analysis is therefore held to what each trial recorded (a whole ON and OFF
phase), and the rig's cells run at 250 frames/s (what the VM's processor must keep up
with: the rig and the session receiving it)."""

from __future__ import annotations

import json
import signal
import time
import urllib.request
from datetime import datetime
from pathlib import Path

import pytest

from _socketcan import HANG_S, evtribo, on_host, wait_for
from evtribo.documents.session import read_session

pytestmark = pytest.mark.slow

PROTOCOL = """\
[session]
trial_s = 9
tare_s = 1.0
on_s = 2.0
off_s = 2.0
target_force_N = 0.5

[[trial]]
waveform = "square"
frequency_Hz = 10000
amplitude_V = [80, 110, 140]
condition = "alternating"
"""


def _rig_on_the_bus(vcan: str, sim) -> None:
    """Wait until the simulated rig's frames are on *vcan*: it sends, and hears the
    amplifier's commands on the bus it sends on (a rig that came up in the middle of a
    trial would obey only its last commands)."""
    import can

    deadline = time.monotonic() + HANG_S
    with can.Bus(interface="socketcan", channel=vcan) as bus:
        while bus.recv(1.0) is None:
            assert sim.poll() is None, sim.output()
            assert time.monotonic() < deadline, "the simulated rig sent nothing"


def _frames_in(part: Path, proc) -> None:
    """Wait until the trial being recorded into *part* holds frames (whole lines)."""
    deadline = time.monotonic() + HANG_S
    while not (part.exists() and part.stat().st_size > 1000):
        assert proc.poll() is None, proc.output()
        assert time.monotonic() < deadline, f"no frames in {part}"
        time.sleep(0.05)


def _view_state(output: str, timeout: float = HANG_S) -> dict:
    """The live view's state once it shows frames (its address is in *output*)."""
    url = next(w for w in output.split() if w.startswith("http://127.0.0.1:"))
    deadline = time.monotonic() + timeout
    while True:
        with urllib.request.urlopen(url + "state", timeout=10) as reply:
            state = json.loads(reply.read())
        if state.get("frames") or time.monotonic() > deadline:
            return state
        time.sleep(0.2)


#: The amplifier's status frames per second (the simulated rig's default).
HV_RATE_HZ = 50.0
#: A whole ON and a whole OFF phase of the protocol (on_s, off_s): a trial whose recording
#: holds that much of each, the finger sliding, has an electrostatic force to find.
PHASE_S = 2.0


def _phases_recorded(ex, start: float, tare_s: float) -> tuple[float, float]:
    """Seconds of ON and of OFF after the tare stretch that the recording holds, by the
    amplifier's status frames it received (each stands for its period, however late a busy
    machine delivered it)."""
    import numpy as np

    after_tare = np.asarray(ex.t) >= start + tare_s
    on = np.asarray(ex.enabled, dtype=bool)
    return (float(np.count_nonzero(on)) / HV_RATE_HZ,
            float(np.count_nonzero(after_tare & ~on)) / HV_RATE_HZ)


def _obeyed_and_analysed(exports: Path) -> None:
    """On the host: in each trial the amplifier was at the commanded amplitude whenever its
    status said ON; every trial whose recording holds a whole ON and OFF phase has its
    electrostatic force, and it grows with the voltage. A machine too busy for the VM to
    keep up records less of a trial (a simulated rig that fell behind, commands obeyed
    late): what was recorded is judged, and said."""
    import numpy as np

    from evtribo.canlog.cache import load_trial
    from evtribo.canlog.rig import default_rig
    from evtribo.results.pipeline import compute_study

    study = exports / "study"
    whole, short = [], []
    for planned in read_session(study / "P01" / "session.json").order:
        side = json.loads((study / "P01" / f"{planned.trial}.json").read_text())
        ex = load_trial(study / "P01" / f"{planned.trial}.log", default_rig(),
                        cache=False).excitation
        assert ex.enabled.any(), planned.trial
        assert set(np.round(ex.amplitude[ex.enabled], 2)) == {planned.amplitude_V}
        start = datetime.fromisoformat(side["start_time"]).timestamp()
        on_s, off_s = _phases_recorded(ex, start, side["tare_s"])
        if on_s >= PHASE_S and off_s >= PHASE_S:
            whole.append(planned.amplitude_V)
        else:
            short.append(f"{planned.trial} ({planned.amplitude_V:g} V): {on_s:.1f} s ON, "
                         f"{off_s:.1f} s OFF recorded")

    results = compute_study(study, jobs=1, cache_dir=exports / "cache")
    el = results.electrostatic
    found = sorted(el.amplitude_V)
    # a whole trial has its force, unless the analysis said why it cannot: the live rig's
    # finger is not lifted at each trial's start, and where the tangential cell's zero is
    # then unknown and the ON windows all slid the other way from the OFF ones, the force
    # cannot be told from the cell's offset
    untold = {f"{w['subject']}/{w['trial']}" for w in results.summary["warnings"]
              if w["kind"] == "directions-confounded"}
    excused = {planned.amplitude_V for planned in read_session(study / "P01" / "session.json")
               .order if f"P01/{planned.trial}" in untold}
    assert set(whole) - excused <= set(found), (found, short, untold)
    assert set(found) <= {80.0, 110.0, 140.0} and len(found) == len(set(found))
    assert (el.n_on > 0).all() and (el.n_off > 0).all()
    if len(found) < 2:
        pytest.skip("too little of the trials was recorded to compare the voltages (a "
                    f"machine too busy for the VM): {'; '.join(short)}")
    fel = el.sort_values("amplitude_V").electrostatic_force_N.to_numpy()
    assert (fel > 0).all() and (np.diff(fel) > 0).all(), el  # F_el grows with the voltage


@on_host(after=_obeyed_and_analysed)
def test_a_session_over_vcan_against_the_simulated_rig_stopped_and_resumed(
        tmp_path, vcan, exports):
    protocol = tmp_path / "protocol.toml"
    protocol.write_text(PROTOCOL)
    study = exports / "study"
    sim = evtribo(["simulate", "--interface", "socketcan", "--channel", vcan, "--fz-rate",
                   "250", "--fx-rate", "250", "--seed", "7"], tmp_path / "simulate.out")
    session = ["session", str(protocol), "--study", str(study), "--subject", "P01", "--yes",
               "--no-check", "--interface", "socketcan", "--channel", vcan]
    try:
        _rig_on_the_bus(vcan, sim)  # the session begins once the rig sends and listens
        first = evtribo([*session, "--view", "0"], tmp_path / "first.out")
        wait_for(first, "recording P01/run-01", timeout=HANG_S)
        state = _view_state(first.output())
        assert state["frames"] > 0 and state["queue_dropped"] == 0  # the kernel's count
        _frames_in(study / "P01" / "run-02.log.part", first)
        first.send_signal(signal.SIGINT)  # Ctrl-C mid-trial
        assert first.wait(300) == 0, first.output()
        assert list(read_session(study / "P01" / "session.json").done) == ["run-01"]
        assert sorted(p.name for p in (study / "P01" / "rejected").iterdir()) == \
            ["run-02-1.json", "run-02-1.log"]
        second = evtribo(session, tmp_path / "second.out")
        assert second.wait(600) == 0, second.output()
    finally:
        sim.send_signal(signal.SIGINT)
        sim.wait(60)
    assert "1 of 3 trials done; going on" in second.output()
    assert "3 of 3 trials done" in second.output()
    doc = read_session(study / "P01" / "session.json")
    assert list(doc.done) == ["run-01", "run-02", "run-03"]
    for planned in doc.order:
        side = json.loads((study / "P01" / f"{planned.trial}.json").read_text())
        assert side["ended"] == "completed" and side["interface"] == "socketcan"
        assert side["receive"]["timestamps"] == "kernel"
        assert side["queue_dropped_frames"] == 0
        assert side["amplitude_V"] == planned.amplitude_V
