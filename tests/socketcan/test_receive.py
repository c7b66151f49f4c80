"""``evtribo acquire --interface socketcan`` against a kernel's CAN stack: the receive queue
and the kernel's count of what it dropped, error frames, frames queued before the trial."""

from __future__ import annotations

import datetime as dt
import json
import struct
import threading

import can
import pytest

from _socketcan import HANG_S, Candump, evtribo, frames_of, playing, stop_when_dumped
from evtribo.acquisition.buses.bus import BusSettings, open_bus
from evtribo.acquisition.trial import record_trial
from evtribo.canlog.io import read_frames

pytestmark = pytest.mark.slow

#: One FzCell frame: the rig is there (else the trial ends as no-rig-data after 3 s).
FZ_LINE = "(1700000000.000000) vcan0 0C1#F401000000190000"


def _acquire(tmp_path, vcan, *extra, setup=None):
    return evtribo(["acquire", "--study", str(tmp_path / "study"), "--subject", "P01",
                    "--trial", "run-01", "--interface", "socketcan", "--channel", vcan,
                    "--tare-s", "0", *extra], tmp_path / "acquire.out", setup)


def _sidecar(tmp_path):
    return json.loads((tmp_path / "study" / "P01" / "run-01.json").read_text())


def _burst(tmp_path, n):
    """FzCell's frame, then *n* frames 0x123, each with its number: the log says which
    arrived."""
    burst = tmp_path / "burst.log"
    burst.write_text("\n".join([FZ_LINE] + [
        f"(1700000000.{k:06d}) vcan0 123#{struct.pack('>I', k).hex().upper()}"
        for k in range(n)]) + "\n")
    return burst


def _record_played(tmp_path, vcan, lines, *extra):
    """``acquire`` recording *lines* played as fast as canplayer can from the trial's start,
    stopped by Ctrl-C once candump beside it has them all; candump's lines."""
    candump = Candump(vcan, tmp_path / "candump.log",
                      count=len(lines.read_text().splitlines()))
    proc = _acquire(tmp_path, vcan, "--duration", "600", *extra,
                    setup=playing(lines, vcan, ignore_times=True))
    stop_when_dumped(candump, proc)
    assert proc.wait(HANG_S) == 0, proc.output()
    return proc, candump.stop()


def test_a_burst_into_a_tiny_receive_queue_is_counted_by_the_kernel(tmp_path, vcan):
    n = 5_000
    proc, _ = _record_played(tmp_path, vcan, _burst(tmp_path, n),
                             "--bus-option", "receive_buffer=1")
    side = _sidecar(tmp_path)
    assert side["receive"]["queue"]["requested_bytes"] == 1
    assert side["receive"]["queue"]["bytes"] < 10_000  # the kernel's least
    frames, _ = read_frames(tmp_path / "study" / "P01" / "run-01.log")
    numbers = [struct.unpack(">I", bytes(d[:4]))[0]
               for d, i in zip(frames.data, frames.arbitration_id, strict=True) if i == 0x123]
    assert numbers == sorted(set(numbers))  # in order, none twice
    logged = len(numbers) + side["frames_by_id"].get("0C1", 0)
    assert side["frames"] == logged == len(frames)
    # what canplayer sent = what was logged + what the kernel says the queue dropped
    assert side["queue_dropped_frames"] == n + 1 - logged > 0
    assert side["dropped_frames"] >= side["queue_dropped_frames"]
    assert f"({side['queue_dropped_frames']} by the receive queue" in proc.output()


def test_the_default_queue_holds_a_burst_whole(tmp_path, vcan):
    n = 5_000
    _record_played(tmp_path, vcan, _burst(tmp_path, n))
    side = _sidecar(tmp_path)
    queue = side["receive"]["queue"]
    assert queue["requested_bytes"] == 32 * 1024 * 1024 and queue["bytes"] >= 2 * 32 * 1024 * 1024
    assert queue["forced"]  # root: beyond net.core.rmem_max
    assert side["queue_dropped_frames"] == 0 and side["dropped_frames"] == 0
    assert side["frames_by_id"] == {"0C1": 1, "123": n}


def test_error_frames_are_logged_and_the_controller_state_said(tmp_path, vcan):
    # a controller going error-passive (CAN_ERR_CRTL, rx passive in byte 1), then bus-off
    errors = ["20000004#0010000000000000", "20000040#0000000000000000"]
    lines = tmp_path / "errors.log"
    lines.write_text("\n".join([FZ_LINE] + [f"(1700000000.{k + 1:06d}) vcan0 {e}"
                                            for k, e in enumerate(errors)]) + "\n")
    proc, dumped = _record_played(tmp_path, vcan, lines)
    side = _sidecar(tmp_path)
    assert side["error_frames"] == 2
    assert side["error_frames_by_kind"] == {"bus-off": 1, "controller rx-error-passive": 1}
    assert side["controller_state"] == side["worst_controller_state"] == "bus-off"
    log = (tmp_path / "study" / "P01" / "run-01.log").read_text().splitlines()
    assert frames_of(log) == frames_of(dumped) == ["0C1#F401000000190000", *errors]
    out = proc.output()
    assert "bus-off 1, controller rx-error-passive 1" in out
    assert "the CAN controller went bus-off" in out


def test_frames_stamped_before_the_trial_never_enter_its_log(tmp_path, vcan):
    bus = open_bus(BusSettings("socketcan", vcan))
    done = threading.Event()

    def send(ident: int, n: int, first: int = 0) -> None:
        with can.Bus(interface="socketcan", channel=vcan) as tx:
            for k in range(first, first + n):
                tx.send(can.Message(arbitration_id=ident, is_extended_id=False,
                                    data=struct.pack(">Q", k)))

    def started(_paths):  # the rig heard as the trial starts, the rest from a thread
        send(0x0C1, 1)
        sender.start()

    try:
        send(0x7AB, 300)  # queued in the bus's socket: nobody reads yet
        # each frame is in the recorder's socket once its send has returned
        sender = threading.Thread(target=lambda: (send(0x0C1, 499, first=1), done.set()))
        result = record_trial(bus, tmp_path / "study", "P01", "run-01", duration=None,
                              settings=BusSettings("socketcan", vcan), started=started,
                              should_stop=done.is_set)
        sender.join(10)
    finally:
        bus.shutdown()
    side = result.sidecar
    assert side["frames_by_id"] == {"0C1": 500}
    assert side["discarded_before_start"] == 300
    frames, _ = read_frames(tmp_path / "study" / "P01" / "run-01.log")
    start = dt.datetime.fromisoformat(side["start_time"]).timestamp()
    assert frames.timestamp.min() >= start - 1e-6
    assert side["receive"]["timestamps"] == "kernel"
