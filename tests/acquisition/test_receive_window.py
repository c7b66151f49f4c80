"""What the receive loop knows of a bus that stamps frames as this machine receives them
(SocketCAN's kernel times: here a virtual bus whose sender sets the times), of the receiving
side's drop count, and of error frames: which frames belong to the trial, what was lost,
and what went wrong on the bus, as the sidecar, the display and the summary say it."""

from __future__ import annotations

import threading
import time
from types import SimpleNamespace

import can
from hypothesis import given
from hypothesis import strategies as st

from evtribo.acquisition.buses.bus import receive_care
from evtribo.acquisition.buses.errorframes import ErrorTally, error_kinds
from evtribo.acquisition.live.display import Snapshot, render_line, render_status
from evtribo.acquisition.logger import LogWriter
from evtribo.acquisition.receive import receive
from evtribo.acquisition.trial import record_trial
from evtribo.canlog.io import read_frames
from evtribo.cli.recording.acquire import summary_counts


def _frame(t: float, k: int) -> can.Message:
    return can.Message(timestamp=t, arbitration_id=0x0C1, is_extended_id=False,
                       data=k.to_bytes(8, "big"))


def test_frames_stamped_before_the_start_are_skipped_and_those_queued_at_the_end_read(
        tmp_path):
    channel = "receive-window"
    with can.Bus(interface="virtual", channel=channel) as rx, \
            can.Bus(interface="virtual", channel=channel, preserve_timestamps=True) as tx:
        start = time.time() - 0.5  # the trial began half a second ago: every frame sent
        # below but the last is stamped before now, whatever the time its sending takes
        for k in range(40):                      # received before the trial
            tx.send(_frame(start - 1.0 + k * 0.001, k))
        for k in range(40, 2040):                # during it
            tx.send(_frame(start + 1e-5 * k, k))
        tx.send(_frame(time.time() + 3600, 99999))  # after its end
        stop = threading.Event()
        stop.set()  # the loop ends at its first hand-over (512 frames): the frames queued
        # and stamped before its end are still read, the one stamped after it is not
        fh = (tmp_path / "x.log").open("wb", buffering=0)
        writer = LogWriter(fh, "vcan0").start()
        result = receive(rx, writer, duration=None, should_stop=stop.is_set,
                         not_before=start)
        writer.close()
        fh.close()
    assert result.reason == "interrupted" and result.stale == 40
    frames, _ = read_frames(tmp_path / "x.log")
    assert [int.from_bytes(bytes(d), "big") for d in frames.data] == list(range(40, 2040))


def test_the_receiving_sides_drop_count_goes_to_the_sidecar_display_and_summary(tmp_path):
    """A bus that counts what its driver dropped (python-can's ``get_stats()``, as Kvaser's
    does): the count is read while recording and at the end."""
    channel = "drop-count"
    overruns = {"n": 0}

    class Counting(can.interfaces.virtual.VirtualBus):
        def get_stats(self):
            overruns["n"] += 1
            return SimpleNamespace(overruns=overruns["n"] - 1)

    with Counting(channel=channel) as rx, can.Bus(interface="virtual", channel=channel) as tx:
        care = receive_care(rx)
        assert care.drop_counter and care.dropped is not None and care.queue is None
        sender = threading.Thread(target=lambda: [tx.send(_frame(0, k)) for k in range(200)])
        result = record_trial(rx, tmp_path / "study", "P01", "run-01", duration=0.8,
                              rig_data_timeout=None, started=lambda _p: sender.start())
        sender.join(5)
    side = result.sidecar
    assert side["queue_dropped_frames"] == overruns["n"] - 1 > 0  # the last reading
    assert side["dropped_frames"] == side["queue_dropped_frames"]  # the counters saw none
    assert side["receive"] == {"timestamps": "driver", "queue": None,
                               "drop_counter": "overruns (python-can get_stats)"}
    assert f"({side['queue_dropped_frames']} by the receive queue" in summary_counts(side)


@given(st.integers(0, 0x3FF), st.binary(min_size=8, max_size=8))
def test_every_error_class_and_controller_problem_is_named(classes, data):
    kinds = error_kinds(classes, data)
    names = {0x001: "tx-timeout", 0x002: "lost-arbitration", 0x008: "protocol-violation",
             0x010: "transceiver", 0x020: "no-ack", 0x040: "bus-off", 0x080: "bus-error",
             0x100: "restarted", 0x200: "error-counters"}
    for bit, name in names.items():
        assert (name in kinds) == bool(classes & bit)
    problems = [k for k in kinds if k.startswith("controller")]
    if classes & 0x004:
        assert len(problems) == (bin(data[1] & 0x7F).count("1") or 1)
    else:
        assert not problems
    assert kinds == ["error"] if not classes else kinds


def test_the_controllers_state_follows_its_error_frames():
    tally = ErrorTally()
    tally.add(0x004, bytes([0, 0x04, 0, 0, 0, 0, 0, 0]))   # rx warning
    assert (tally.state, tally.worst) == ("error-warning", "error-warning")
    tally.add(0x004 | 0x200, bytes([0, 0x20, 0, 0, 0, 0, 130, 12]))   # tx passive
    assert (tally.state, tally.error_counters) == ("error-passive", (130, 12))
    tally.add(0x040, bytes(8))
    tally.add(0x100, bytes(8))                             # restarted: error-active again
    assert (tally.state, tally.worst) == ("error-active", "bus-off")
    assert tally.describe() == ("bus-off 1, controller rx-warning 1, controller "
                                "tx-error-passive 1, error-counters 1, restarted 1")


def test_the_display_says_what_the_queue_dropped_and_the_controllers_state():
    snap = Snapshot(elapsed_s=3.0, frames=1000, dropped=25, queue_dropped=25,
                    bus_errors=2, controller="bus-off")
    line = render_line(snap)
    assert "dropped=25 (receive queue 25)" in line and "controller BUS-OFF" in line
    block = render_status(snap, columns=120)
    assert any("dropped 25 (receive queue 25)" in b and "controller BUS-OFF" in b
               for b in block)
    calm = render_line(Snapshot(elapsed_s=1.0, queue_dropped=0, controller="error-active"))
    assert "receive queue" not in calm and "controller" not in calm
