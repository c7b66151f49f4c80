"""The trial logger: candump lines, rolling counters, periodic flush, receive loop."""

import io
import os
import random
import time
from pathlib import Path

import can
import cantools
import numpy as np
import pytest

import evtribo.acquisition.logger as logger_module
import evtribo.acquisition.receive as receive_module
from evtribo.acquisition.logger import (
    CounterSpec,
    CounterTracker,
    LogWriter,
    counter_spec_from_dbc,
    format_candump_line,
)
from evtribo.acquisition.receive import receive
from evtribo.acquisition.rigfile import load_rig_toml
from evtribo.canlog.io import candump, frames_from_messages, write_candump
from evtribo.canlog.signal_codec import SignalCodec

FRAMES = [
    can.Message(timestamp=1763700000.000123, arbitration_id=0x0C1, is_extended_id=False,
                data=bytes.fromhex("1122334455667788")),
    can.Message(timestamp=1763700000.5, arbitration_id=0x18FF0001, is_extended_id=True,
                data=b"\x01\x02"),
    can.Message(timestamp=1763700001.0, arbitration_id=0x123, is_extended_id=False,
                is_remote_frame=True, dlc=8),
    can.Message(timestamp=1763700001.25, arbitration_id=0x7FF, is_extended_id=False, data=b""),
    can.Message(timestamp=1763700002.0, is_error_frame=True, data=bytes(8)),
]


def test_candump_line_is_the_spec_format():
    assert format_candump_line(FRAMES[0], "vcan0") == \
        "(1763700000.000123) vcan0 0C1#1122334455667788\n"
    assert format_candump_line(FRAMES[1], "can0") == "(1763700000.500000) can0 18FF0001#0102\n"
    assert format_candump_line(FRAMES[2], "can0") == "(1763700001.000000) can0 123#R8\n"
    assert format_candump_line(FRAMES[3], "can0") == "(1763700001.250000) can0 7FF#\n"
    assert format_candump_line(FRAMES[4], "can0") == \
        "(1763700002.000000) can0 20000080#0000000000000000\n"
    # an error frame that names its class (here CAN_ERR_CTRL) keeps it
    ctrl = can.Message(timestamp=1.0, is_error_frame=True, arbitration_id=0x4,
                       data=bytes([0, 4, 0, 0, 0, 0, 0, 0]))
    assert format_candump_line(ctrl, "can0") == "(1.000000) can0 20000004#0004000000000000\n"


def test_logger_and_vectorised_writer_write_the_same_lines():
    """One formatting of a frame: the logger (a frame at a time) and write_candump (whole
    tables) give the same line for every kind of frame, remote lengths included."""
    frames = [*FRAMES,
              can.Message(timestamp=3.0, arbitration_id=0x123, is_extended_id=False,
                          is_remote_frame=True, dlc=4),
              can.Message(timestamp=3.5, arbitration_id=0x123, is_extended_id=False,
                          is_remote_frame=True, dlc=0),
              can.Message(timestamp=4.0, arbitration_id=0x1ABCDEF0, is_extended_id=True,
                          is_remote_frame=True, dlc=2),
              can.Message(timestamp=4.5, is_error_frame=True, arbitration_id=0x4,
                          data=bytes([0, 4, 0, 0, 0, 0, 0, 0])),
              can.Message(timestamp=5.0, arbitration_id=0x0C2, is_extended_id=False,
                          is_fd=True, bitrate_switch=True, data=bytes(range(12))),
              can.Message(timestamp=5.5, arbitration_id=0x18FF0002, is_extended_id=True,
                          is_fd=True, error_state_indicator=True, data=bytes(range(8)))]
    table = frames_from_messages(frames)
    table.extras["fd_flags"] = np.array(
        [(1 if m.bitrate_switch else 0) | (2 if m.error_state_indicator else 0)
         for m in frames], dtype=np.uint8)
    out = io.BytesIO()
    write_candump(out, table, "can0")
    assert out.getvalue().decode().splitlines(keepends=True) == [
        format_candump_line(m, "can0") for m in frames]
    assert "(3.000000) can0 123#R4\n" in out.getvalue().decode()
    assert logger_module.CAN_ERR_FLAG is candump.CAN_ERR_FLAG
    assert logger_module.CAN_ERR_BUSERROR is candump.CAN_ERR_BUSERROR


def test_candump_lines_read_back_with_python_can(tmp_path):
    path = tmp_path / "t.log"
    path.write_text("".join(format_candump_line(m, "vcan0") for m in FRAMES))
    back = list(can.CanutilsLogReader(path))
    assert len(back) == len(FRAMES)
    for orig, got in zip(FRAMES, back, strict=True):
        assert got.timestamp == pytest.approx(orig.timestamp, abs=1e-6)
        assert got.is_error_frame == orig.is_error_frame
        if not orig.is_error_frame:
            assert got.arbitration_id == orig.arbitration_id
            assert got.is_extended_id == orig.is_extended_id
            assert got.is_remote_frame == orig.is_remote_frame
            assert got.dlc == orig.dlc
            if not orig.is_remote_frame:
                assert bytes(got.data) == bytes(orig.data)


DBC = """VERSION ""
BS_:
BU_: A
BO_ 100 Intel: 8 A
 SG_ Cnt : 52|7@1+ (1,0) [0|127] "" A
BO_ 101 Moto: 8 A
 SG_ Cnt : 13|10@0+ (1,0) [0|1023] "" A
BO_ 102 MotoShort: 4 A
 SG_ Seq : 7|4@0+ (1,0) [0|15] "" A
"""


@pytest.mark.parametrize("message,signal", [("Intel", "Cnt"), ("Moto", "Cnt"),
                                            ("MotoShort", "Seq")])
def test_counter_extraction_matches_cantools(message, signal):
    db = cantools.database.load_string(DBC, database_format="dbc")
    spec = counter_spec_from_dbc(db, message, signal)
    msg = db.get_message_by_name(message)
    top = (1 << spec.length) - 1
    for value in (0, 1, 5, top // 2, top):
        data = msg.encode({signal: value})
        assert spec.extract(data) == value
    # arbitrary payloads: the other bits must not leak into the counter
    rng = random.Random(1)
    for _ in range(200):
        data = bytes(rng.randrange(256) for _ in range(msg.length))
        assert spec.extract(data) == db.decode_message(message, data)[signal]


def test_counter_tracker_counts_gaps_and_wraps():
    spec = CounterSpec(message="M", arbitration_id=1, codec=SignalCodec(
        "MCounter", start=56, length=8, byte_order="little_endian", is_signed=False,
        is_float=False, scale=1, offset=0))
    tracker = CounterTracker([spec])

    def frame(c):
        return bytes(7) + bytes([c % 256])

    sent = [c for c in range(600) if c not in (10, 11, 12, 300)]   # 4 lost, across a wrap
    for c in sent:  # each at the time it was sent (a lost frame takes its period too)
        t = 0.001 * (c + 1)
        tracker.update(1, frame(c), t)
    assert tracker.dropped == 4
    assert tracker.dropped_by_message() == {"M": 4}
    assert tracker.update(1, frame(sent[-1] + 6), t + 0.5) == 5
    assert tracker.longest_gap_by_message() == {"M": pytest.approx(0.5)}
    assert tracker.update(2, b"anything", t) == 0          # not a counted message


class FsyncRecorder:
    """Stands in for ``os.fsync``: records (time, fd) of each call, then really syncs."""

    def __init__(self):
        self.calls = []
        self._real = os.fsync

    def __call__(self, fd):
        self.calls.append((time.monotonic(), fd))
        self._real(fd)


def _until(done, limit_s: float = 60.0) -> None:
    """Wait until *done()* (a loaded machine may take long: the limit only ends a hang)."""
    deadline = time.monotonic() + limit_s
    while not done() and time.monotonic() < deadline:
        time.sleep(0.02)


def test_writer_flushes_and_fsyncs_without_closing(tmp_path, monkeypatch):
    """Frames put are written and fsynced by the writer on its own, while the file is open
    (a crash then loses nothing put before the last flush): another reader sees them."""
    fsync = FsyncRecorder()
    monkeypatch.setattr(logger_module.os, "fsync", fsync)
    path = tmp_path / "run.log.part"
    fh = path.open("wb", buffering=0)
    writer = LogWriter(fh, "vcan0", flush_interval=0.3).start()
    try:
        writer.put(FRAMES[:2])
        _until(lambda: path.read_text().count("\n") >= 2 and fsync.calls)
        content = path.read_text()          # another reader, as after a crash
        assert content.splitlines() == [format_candump_line(m, "vcan0").strip()
                                        for m in FRAMES[:2]]
        assert [fd for _, fd in fsync.calls][:1] == [fh.fileno()]  # fsynced before close
    finally:
        writer.close()
        fh.close()
    assert writer.stats.frames == 2
    assert writer.stats.frames_by_id == {"0C1": 1, "18FF0001": 1}


def test_writer_fsyncs_under_continuous_traffic(tmp_path, monkeypatch):
    """A batch every 20 ms: the log is fsynced during the recording, again and again, not
    only when the writer closes."""
    fsync = FsyncRecorder()
    monkeypatch.setattr(logger_module.os, "fsync", fsync)
    interval = 0.2
    fh = (tmp_path / "run.log.part").open("wb", buffering=0)
    writer = LogWriter(fh, "vcan0", flush_interval=interval).start()
    try:
        k = 0
        deadline = time.monotonic() + 60.0  # ends a hang only: a loaded machine is slow
        while len(fsync.calls) < 2 and time.monotonic() < deadline:
            writer.put([can.Message(timestamp=1763700000.0 + k, arbitration_id=0xC1,
                                    is_extended_id=False, data=bytes([k % 256]))])
            k += 1
            time.sleep(0.02)
        during = len(fsync.calls)
    finally:
        writer.close()
        fh.close()
    assert during >= 2                               # fsynced while the traffic went on
    assert len(fsync.calls) > during                 # and once more when closing
    assert writer.stats.frames == k


MOTOROLA_RIG = Path(__file__).parents[1] / "data" / "rigs" / "motorola.toml"


def test_counters_of_extended_id_load_cells_are_checked(tmp_path):
    """The Motorola rig's load cells have 29-bit IDs: their counters count lost frames, and a
    standard frame with the same number is another message."""
    rig = load_rig_toml(MOTOROLA_RIG)
    assert {(s.message, s.is_extended) for s in rig.counters} == {
        ("NormalCell", True), ("TangentialCell", True)}
    normal = rig.database.get_message_by_name("NormalCell")
    fh = (tmp_path / "run.log.part").open("wb", buffering=0)
    writer = LogWriter(fh, "vcan0", CounterTracker(rig.counters))
    batch = []
    for k in [c for c in range(40) if c not in (5, 6, 7, 20)]:      # 4 frames lost
        batch.append(can.Message(timestamp=k * 1e-3, arbitration_id=normal.frame_id,
                                 is_extended_id=True, data=normal.encode(
                                     {"Force_mN": 0.5, "Seq": k % 16, "Spare": 0})))
        # a standard frame with the same number: not NormalCell, not counted
        batch.append(can.Message(timestamp=k * 1e-3, arbitration_id=normal.frame_id & 0x7FF,
                                 is_extended_id=False, data=bytes(8)))
    writer._write(batch)
    fh.close()
    assert writer.stats.dropped == 4
    assert writer.stats.dropped_by_message == {"NormalCell": 4, "TangentialCell": 0}


def test_a_restart_at_the_trials_end_is_judged_when_the_log_closes(tmp_path):
    """A load cell's firmware restarts 0.2 s before the trial ends (its counter from 231 back
    to 3): counted as 27 frames lost while too few frames after it can say otherwise, and as
    none once the writer is closed (the sidecar's count)."""
    writer = LogWriter((tmp_path / "run.log.part").open("wb", buffering=0), "vcan0",
                       CounterTracker([CounterSpec("M", 0x0C1, SignalCodec(
                           "C", start=56, length=8, byte_order="little_endian",
                           is_signed=False, is_float=False, scale=1, offset=0))])).start()
    counters = [k % 256 for k in range(1000)] + [3 + k for k in range(200)]
    for a in range(0, len(counters), 50):
        writer.put([can.Message(timestamp=1.76e9 + (a + i) * 1e-3, arbitration_id=0x0C1,
                                is_extended_id=False, data=bytes(7) + bytes([c]))
                    for i, c in enumerate(counters[a:a + 50])])
    deadline = time.monotonic() + 60
    while writer.stats.frames < len(counters):  # written, not yet closed
        assert time.monotonic() < deadline
        time.sleep(0.01)
    assert writer.stats.dropped == (3 - 999) % 256 - 1 == 27
    writer.close()
    writer.file.close()
    assert writer.stats.dropped == 0 and writer.stats.dropped_by_message == {"M": 0}
    assert writer.counters.restarts_by_message(1.76e9) == {"M": [1.0]}


class FailingBus(can.BusABC):
    """A bus that delivers *n* frames, then fails the way a vanished adapter does."""

    def __init__(self, n, exc, **kwargs):
        super().__init__(channel="fake", **kwargs)
        self.n = n
        self.exc = exc
        self.i = 0

    def _recv_internal(self, timeout):
        if self.i >= self.n:
            raise self.exc
        self.i += 1
        return can.Message(timestamp=time.time(), arbitration_id=0xC1, is_extended_id=False,
                           data=bytes(8)), False

    def send(self, msg, timeout=None):
        raise can.CanOperationError("read-only")


@pytest.mark.parametrize("exc", [can.CanOperationError("Could not read from serial device"),
                                 OSError(5, "Input/output error")])
def test_receive_stops_on_a_bus_fault_and_keeps_what_came(tmp_path, exc):
    fh = (tmp_path / "x.log").open("wb", buffering=0)
    writer = LogWriter(fh, "can0").start()
    bus = FailingBus(1234, exc)
    try:
        result = receive(bus, writer, duration=5.0, should_stop=lambda: False)
    finally:
        writer.close()
        fh.close()
        bus.shutdown()
    assert result.reason == "bus-error"
    assert result.error is exc
    assert result.frames == 1234
    assert len(list(can.CanutilsLogReader(tmp_path / "x.log"))) == 1234


def test_an_adapter_sending_only_damaged_lines_is_taken_for_dead(tmp_path):
    """A driver that fails to parse every line (a wrong serial speed) does not record
    garbage counts until the end: after MAX_DAMAGED_IN_A_ROW lines and no frame, bus-error."""
    fh = (tmp_path / "x.log").open("wb", buffering=0)
    writer = LogWriter(fh, "can0").start()
    bus = FailingBus(10, ValueError("invalid literal for int() with base 16: 'Z'"))
    try:
        result = receive(bus, writer, duration=60.0, should_stop=lambda: False)
    finally:
        writer.close()
        fh.close()
        bus.shutdown()
    assert result.reason == "bus-error" and result.frames == 10
    assert result.damaged_lines == receive_module.MAX_DAMAGED_IN_A_ROW
    assert "damaged lines in a row and no frame" in str(result.error)
    assert len(result.damaged_examples) == receive_module.DAMAGED_EXAMPLES


def test_receive_stops_when_asked(tmp_path):
    fh = (tmp_path / "x.log").open("wb", buffering=0)
    writer = LogWriter(fh, "can0").start()
    polls = []

    def stop():  # asked for once the loop has gone round twice, whatever the machine's pace
        polls.append(None)
        return len(polls) > 2

    with can.Bus(interface="virtual", channel="test_receive_stops_when_asked") as bus:
        result = receive(bus, writer, duration=600.0, should_stop=stop)
    writer.close()
    fh.close()
    assert result.reason == "interrupted"           # stopped when asked, not after its 600 s


@pytest.mark.parametrize("message,signal", [("Intel", "Cnt"), ("Moto", "Cnt")])
def test_a_frame_shorter_than_its_counter_is_counted_not_fatal(message, signal):
    # a frame cut short (a smaller DLC than the DBC's) reads its missing bytes as 0, as the
    # decoder does; it never stops the recording
    db = cantools.database.load_string(DBC, database_format="dbc")
    spec = counter_spec_from_dbc(db, message, signal)
    tracker = CounterTracker([spec])
    msg = db.get_message_by_name(message)
    full = msg.encode({signal: 3})
    assert tracker.update(msg.frame_id, full, 0.0) == 0
    tracker.update(msg.frame_id, full[:1], 0.01)  # a step down: not known until the log closes
    tracker.settle()
    assert tracker.dropped == spec.extract(full[:1] + bytes(7)) - 3 - 1 & ((1 << spec.length) - 1)
