"""Frames queued before a trial never enter its log: an adapter that went on sending after a
recording was killed, or a bus left open between two trials, holds frames from before the
trial; read at its start they would land in its first tenth of a second (its tare stretch,
where the load cells' zero is read). The trial discards them and says how many."""

import json
import subprocess
import sys
import threading
import time

import can
import pytest

from _process import kill_and_reap
from evtribo.acquisition.buses.bus import BusSettings
from evtribo.acquisition.trial import record_trial
from evtribo.canlog.io import read_frames
from evtribo.cli import main


def test_frames_the_bus_held_when_the_trial_started_are_discarded_and_counted(tmp_path):
    channel = "stale-before-the-trial"
    stale = [can.Message(arbitration_id=0x7AB, is_extended_id=False, data=bytes([k % 256] * 8))
             for k in range(1500)]
    fresh_sent = threading.Event()

    def send_fresh() -> None:
        with can.Bus(interface="virtual", channel=channel) as tx:
            for k in range(300):
                tx.send(can.Message(arbitration_id=0x0C1, is_extended_id=False,
                                    data=bytes([0, 0, 0, 0, 0, 0, 0, k % 256])))
        fresh_sent.set()

    with can.Bus(interface="virtual", channel=channel) as rx, \
            can.Bus(interface="virtual", channel=channel) as tx:
        for msg in stale:  # the bus is open and nobody reads: they pile up
            tx.send(msg)
        sender = threading.Thread(target=send_fresh, daemon=True)
        result = record_trial(
            rx, tmp_path / "study", "P01", "run-01", duration=None,
            settings=BusSettings("virtual", channel), rig_data_timeout=None,
            started=lambda _paths: sender.start(),
            should_stop=lambda: fresh_sent.is_set() and rx.queue.empty())
        sender.join(5)
    frames, _ = read_frames(tmp_path / "study" / "P01" / "run-01.log")
    assert set(frames.arbitration_id.tolist()) == {0x0C1}
    assert frames.data[:, 7].tolist() == [k % 256 for k in range(300)]  # all, in order
    side = result.sidecar
    assert side["frames_by_id"] == {"0C1": 300}
    assert side["discarded_before_start"] == 1500


@pytest.mark.slow
def test_a_trial_after_a_killed_acquire_holds_nothing_the_adapter_queued_before(
        tmp_path, simulate_pty):
    rates = {"--fz-rate": 1000.0, "--fx-rate": 2000.0, "--hv-rate": 50.0}
    sim, path = simulate_pty(*[str(x) for kv in rates.items() for x in kv])
    study = tmp_path / "study"
    args = ["--study", str(study), "--subject", "P01", "--interface", "slcan_bulk",
            "--channel", path, "--bitrate", "1000000", "--bus-option", "sleep_after_open=0",
            "--log-channel", "vcan0", "--quiet"]
    first = subprocess.Popen([sys.executable, "-m", "evtribo", "acquire", *args,
                              "--trial", "run-01", "--duration", "60"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    part = study / "P01" / "run-01.log.part"
    try:
        deadline = time.monotonic() + 60
        while not (part.exists() and part.stat().st_size > 20_000):
            assert first.poll() is None and time.monotonic() < deadline, first.communicate()
            time.sleep(0.05)
    finally:
        kill_and_reap(first)  # SIGKILL: the adapter goes on sending into the port
    time.sleep(2.0)           # ... seconds of frames that nobody reads
    assert main(["acquire", *args, "--trial", "run-02", "--duration", "2"]) == 0
    sim.send_signal(2)
    kill_and_reap(sim, timeout=10)
    side = json.loads((study / "P01" / "run-02.json").read_text())
    assert side["ended"] == "completed"
    frames, _ = read_frames(study / "P01" / "run-02.log")
    assert len(frames) == side["frames"]
    # at most what the rig sent while the trial lasted (its clocks are off by < 200 ppm)
    sent_meanwhile = sum(rates.values()) * 1.0002 * side["duration_s"]
    assert side["frames"] <= sent_meanwhile + 50
    assert side["discarded_before_start"] > 1000
