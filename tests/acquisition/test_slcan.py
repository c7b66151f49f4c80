"""slcan: the bulk-reading bus against python-can's, the emulated adapter, across processes."""

from __future__ import annotations

import itertools
import os
import re
import signal
import time
import tty
from contextlib import contextmanager

import can
import numpy as np
import pytest
import serial
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from evtribo.acquisition.buses.slcan import BulkSlcanBus, SlcanPtyAdapter, encode_slcan
from evtribo.acquisition.simulator import TrialConfig, simulate_trial

FZ, FX, HV = 0x0C1, 0x0C2, 0x1A0


@contextmanager
def bus_on_pty(interface):
    """A python-can bus on a fresh pty; yields (bus, master fd)."""
    master, slave = os.openpty()
    tty.setraw(slave)
    try:
        bus = can.Bus(interface=interface, channel=os.ttyname(slave), sleep_after_open=0)
        os.set_blocking(master, False)
        try:
            os.read(master, 4096)  # the bus's own commands (C, O)
        except BlockingIOError:
            pass
        try:
            yield bus, master
        finally:
            bus.shutdown()
    finally:
        os.close(master)
        os.close(slave)


def _key(msg):
    return (msg.arbitration_id, msg.is_extended_id, msg.is_remote_frame, msg.is_fd,
            msg.bitrate_switch, msg.dlc, bytes(msg.data))


def _drain(bus, timeout=0.03):
    out = []
    while True:
        try:
            msg = bus.recv(timeout)
        except ValueError as err:  # python-can's parser on a malformed line
            out.append(("ValueError", type(err).__name__))
            continue
        if msg is None:
            return out
        out.append(_key(msg))


def _late(bus, got: list, expect: int | None) -> None:
    """Add to *got* what a loaded machine delivers late: until *expect* items are in, or
    (unknown) until the bus stays quiet; a minute at most (a hang, not slowness)."""
    deadline = time.monotonic() + 60.0
    while time.monotonic() < deadline:
        if expect is not None and len(got) >= expect:
            return
        late = _drain(bus, timeout=0.15)
        if not late and expect is None:
            return
        got += late


def parse_both(pieces, expect=None):
    """What python-can's slcan and BulkSlcanBus make of the same bytes, written in pieces
    (*expect*: how many frames and errors the stream holds, all waited for)."""
    results = []
    for interface in ("slcan", "slcan_bulk"):
        got = []
        with bus_on_pty(interface) as (bus, master):
            assert isinstance(bus, BulkSlcanBus) == (interface == "slcan_bulk")
            for piece in pieces:
                batch = []
                for k in range(0, len(piece), 1024):  # what the pty takes without a reader
                    os.write(master, piece[k:k + 1024])
                    batch += _drain(bus)
                got.append(batch)
            # what a loaded machine delivers late still counts, in the last batch
            late = []
            _late(bus, late, None if expect is None else expect - sum(map(len, got)))
            got[-1] += late
        results.append(got)
    return results


def test_bulk_parser_gives_python_cans_frames_on_a_fixed_stream():
    stream = (b"t1238DEADBEEF01020304\r" b"t0C10\r" b"T1FFFFFFF4deadBEEF\r" b"r7FF3\r"
              b"R123456780\r" b"\a" b"\r" b"z\r" b"t2322AABB\r\a" b"d1239" + b"11" * 12 +
              b"\r" b"B0000012AA" + b"22" * 16 + b"\r" b"F00\r" b"V1013\r")
    pieces = [stream[:7], stream[7:23], stream[23:60], stream[60:61], stream[61:]]
    classic, bulk = parse_both(pieces, expect=8)
    # the same frames in the same order (which read returns each depends on timing)
    frames = [m for batch in bulk for m in batch]
    assert [m for batch in classic for m in batch] == frames
    assert len(frames) == 8
    assert frames[0] == (0x123, False, False, False, False, 8,
                         bytes.fromhex("DEADBEEF01020304"))
    assert frames[2][:2] == (0x1FFFFFFF, True)
    assert frames[3][:3] == (0x7FF, False, True) and frames[4][:3] == (0x12345678, True, True)
    assert frames[6][3:6] == (True, False, 12) and frames[7][3:6] == (True, True, 16)
    assert classic[0] == []  # half a line waits for the rest


def test_a_malformed_line_fails_the_same_way_in_both():
    stream = b"t1232AABB\rtXYZ1AA\rt4561CC\r"
    classic, bulk = parse_both([stream], expect=3)
    assert classic == bulk
    assert [m[0] for m in bulk[0]] == [0x123, "ValueError", 0x456]


frame_strategy = st.one_of(
    st.tuples(st.just("t"), st.integers(0, 0x7FF), st.binary(max_size=8)),
    st.tuples(st.just("T"), st.integers(0, 0x1FFFFFFF), st.binary(max_size=8)),
    st.tuples(st.just("r"), st.integers(0, 0x7FF), st.integers(0, 8)),
    st.tuples(st.just("R"), st.integers(0, 0x1FFFFFFF), st.integers(0, 8)),
    st.sampled_from([("bell",), ("ack",), ("z",)]),
)


def _encode(item):
    kind = item[0]
    if kind == "bell":
        return b"\a"
    if kind == "ack":
        return b"\r"
    if kind == "z":
        return b"z\r"
    if kind in ("t", "T"):
        ident = b"%03X" % item[1] if kind == "t" else b"%08X" % item[1]
        return kind.encode() + ident + b"%d" % len(item[2]) + item[2].hex().encode() + b"\r"
    ident = b"%03X" % item[1] if kind == "r" else b"%08X" % item[1]
    return kind.encode() + ident + b"%d" % item[2] + b"\r"


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(frame_strategy, min_size=1, max_size=30), st.lists(st.integers(0, 600),
                                                                    max_size=6))
def test_bulk_parser_matches_python_can_on_any_stream_cut_anywhere(items, cuts):
    stream = b"".join(_encode(i) for i in items)
    points = sorted({min(c, len(stream)) for c in cuts} | {0, len(stream)})
    pieces = [stream[a:b] for a, b in itertools.pairwise(points) if b > a]
    n_frames = sum(1 for i in items if i[0] in "tTrR")
    classic, bulk = parse_both(pieces, expect=n_frames)
    # the same frames in the same order (which read returns each depends on timing)
    assert [m for batch in classic for m in batch] == [m for batch in bulk for m in batch]
    assert sum(len(batch) for batch in bulk) == n_frames


def test_encode_slcan_round_trips_through_python_can():
    frames, _ = simulate_trial(config=TrialConfig(duration_s=0.2, foreign_rate_Hz=500.0))
    frames.is_remote[3] = True
    classic, bulk = parse_both([encode_slcan(frames)], expect=len(frames))
    assert classic == bulk
    got = bulk[0]
    assert len(got) == len(frames)
    for i, m in enumerate(got):
        assert m[0] == frames.arbitration_id[i] and m[1] == frames.is_extended[i]
        assert m[2] == frames.is_remote[i] and m[5] == frames.dlc[i]
        if not m[2]:
            assert m[6] == bytes(frames.data[i, : frames.dlc[i]])


# -- the emulated adapter ------------------------------------------------------------------
def _ask(port, adapter, command):
    port.write(command + b"\r")
    answer = b""
    deadline = time.monotonic() + 30  # ends a hang only: the answer ends the loop
    while time.monotonic() < deadline and not answer.endswith((b"\r", b"\a")):
        adapter.poll(0.01)
        answer += port.read(port.in_waiting or 1)
    return answer


def test_adapter_answers_lawicel_commands():
    with SlcanPtyAdapter() as adapter:
        port = serial.Serial(adapter.path, timeout=0.01)
        try:
            expected = [
                (b"V", b"V1013\r"), (b"v", b"v0107\r"), (b"N", b"NEV01\r"),
                (b"F", b"\a"),  # status needs an open channel
                (b"S9", b"\a"), (b"S8", b"\r"), (b"s031C", b"\r"), (b"sXY", b"\a"),
                (b"t1230", b"\a"),  # cannot transmit while closed
                (b"O", b"\r"), (b"O", b"\a"), (b"S6", b"\a"), (b"F", b"F00\r"),
                (b"t1232AABB", b"z\r"), (b"T000001231CC", b"Z\r"), (b"r1230", b"z\r"),
                (b"t1232AA", b"\a"), (b"Z0", b"\r"), (b"Z1", b"\a"), (b"?", b"\a"),
                (b"", b"\r"), (b"C", b"\r"), (b"L", b"\r"), (b"t1230", b"\a"), (b"C", b"\r"),
            ]
            for command, answer in expected:
                assert (command, _ask(port, adapter, command)) == (command, answer)
            assert adapter.transmitted == 3
            assert adapter.bitrate_command == b"s031C"
        finally:
            port.close()


def test_adapter_streams_only_while_open_and_drops_when_the_client_lags():
    frames, _ = simulate_trial(config=TrialConfig(duration_s=1.0))
    with SlcanPtyAdapter(max_pending=2000) as adapter:
        port = serial.Serial(adapter.path, timeout=0.01)
        try:
            assert adapter.send_frames(frames, 0, 10) == 0  # closed: nothing taken
            assert _ask(port, adapter, b"O") == b"\r"
            assert adapter.send_frames(frames, 0, 10) == 10
            time.sleep(0.05)
            lines = port.read(10_000).split(b"\r")
            assert lines[:10] == encode_slcan(frames, 0, 10).split(b"\r")[:10]
            # nobody reads: the pty fills up, then frames are dropped and F reports it
            starts = range(10, len(frames) - 100, 100)
            taken = sum(adapter.send_frames(frames, i, i + 100) for i in starts)
            assert adapter.dropped > 0 and taken > 0
            assert taken + adapter.dropped == 100 * len(starts)
            port.reset_input_buffer()
            adapter.drain(0.5)
            port.reset_input_buffer()
            assert _ask(port, adapter, b"F").endswith(b"F08\r")
        finally:
            port.close()


# -- across processes ----------------------------------------------------------------------
def _receive_until_gone(bus, limit_s, enough=None):
    """Frames until the adapter vanishes (or *enough* frames came); returns (frames, the
    error). *limit_s* only ends a hang: a loaded machine is slow, not wrong."""
    got = []
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline and (enough is None or len(got) < enough):
        try:
            msg = bus.recv(0.2)
        except can.CanOperationError as err:
            return got, err
        if msg is not None:
            got.append(msg)
    return got, None


def _check_counters(msgs, dropped=0):
    """Each cell's counter steps by one, but where the adapter dropped frames (*dropped*,
    a full buffer: this machine too busy to read in time): a gap, never a repeat."""
    for frame_id, byte, mask, modulo in ((FZ, 7, 0xFF, 256), (FX, 7, 0xFF, 256),
                                         (HV, 0, 0xF0, 16)):
        c = np.array([(m.data[byte] & mask) >> (4 if mask == 0xF0 else 0)
                      for m in msgs if m.arbitration_id == frame_id])
        assert c.size > 10
        steps = np.diff(c) % modulo
        if dropped == 0:
            assert (steps == 1).all(), f"counter gap in {frame_id:#x}"
        else:
            assert (steps != 0).all() and int((steps - 1).sum()) <= dropped, frame_id


def _sent(stderr):
    """The frames the simulator sent and those its adapter dropped (a full buffer)."""
    found = re.search(r"(\d+) frames sent in [\d.]+ s", stderr)
    assert found, stderr
    full = re.search(r"(\d+) to a full buffer \(the client did not read them in time\)",
                     stderr)
    return int(found.group(1)), int(full.group(1)) if full else 0


@pytest.mark.parametrize("interface", ["slcan", "slcan_bulk"])
def test_simulate_pty_across_processes_zero_loss_then_the_adapter_vanishes(simulate_pty,
                                                                           interface):
    proc, path = simulate_pty("--duration", "1.2", "--fz-rate", "1000", "--fx-rate", "1500",
                              "--hv-rate", "80", "--seed", "4")
    bus = can.Bus(interface=interface, channel=path, bitrate=1_000_000, sleep_after_open=0)
    try:
        msgs, err = _receive_until_gone(bus, limit_s=300)
    finally:
        with pytest.raises(can.CanOperationError):  # writing 'C' to a vanished adapter
            bus.shutdown()
    # the adapter vanishing is an exception from recv(), not a silent None. Its cause is the
    # pty's OSError: pyserial's read() wraps it in a SerialException (an OSError), but the
    # in_waiting that python-can asks first raises EIO bare, whichever the reader was in
    assert isinstance(err, can.CanOperationError)
    assert isinstance(err.__cause__, OSError)
    assert proc.wait(60) == 0
    sent, dropped = _sent(proc.stderr.read())
    assert len(msgs) == sent > 0  # every frame written reached the reader before it vanished
    _check_counters(msgs, dropped)


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGKILL])
def test_killing_the_simulator_makes_the_reader_see_the_adapter_vanish(simulate_pty, signum):
    proc, path = simulate_pty("--fz-rate", "500", "--fx-rate", "500")
    bus = can.Bus(interface="slcan_bulk", channel=path, sleep_after_open=0)
    try:
        # 600 frames hold ~28 of the 50-Hz HvStatus's: enough of each counter to check
        msgs, err = _receive_until_gone(bus, limit_s=120, enough=600)
        assert err is None and len(msgs) >= 600
        proc.send_signal(signum)
        more, err = _receive_until_gone(bus, limit_s=300)
    finally:
        with pytest.raises(can.CanOperationError):
            bus.shutdown()
    assert isinstance(err, can.CanOperationError)
    _check_counters(msgs + more)
    assert proc.wait(60) == (0 if signum == signal.SIGTERM else -signal.SIGKILL)


def test_bulk_reader_takes_a_saturated_bus_and_accounts_for_every_frame(simulate_pty):
    # 4150 + 4200 + 50 = 8,400 frames/s of 8 bytes: a saturated 1 Mbit/s bus
    proc, path = simulate_pty("--duration", "1.5", "--fz-rate", "4150", "--fx-rate", "4200",
                              "--hv-rate", "50")
    bus = can.Bus(interface="slcan_bulk", channel=path, bitrate=1_000_000, sleep_after_open=0)
    try:
        msgs, err = _receive_until_gone(bus, limit_s=300)
    finally:
        with pytest.raises(can.CanOperationError):
            bus.shutdown()
    assert isinstance(err, can.CanOperationError)
    assert proc.wait(60) == 0
    # every frame the adapter sent was read; any it dropped (this machine too busy to read
    # at 8,400 frames/s: benchmarks/acquire.py measures the rate) is a gap in the counters
    sent, dropped = _sent(proc.stderr.read())
    assert len(msgs) == sent > 0
    _check_counters(msgs, dropped)


# -- damaged lines ---------------------------------------------------------------------------
#: The lines a tester saw end a trial: a bad hex digit, cut short, no text, an extended frame
#: cut short.
REPORTED = [b"t0CZ8" + b"00" * 8 + b"\r", b"t0C1\r", b"\xff\xfe\r", b"T1\r"]


def _damage(line, how, k):
    """A damaged version of the frame line *line* (``\\r`` included)."""
    body = line[:-1]
    if how == "cut":                               # cut short, the kind letter kept
        return body[:len(body) - 1 - k % (len(body) - 1)] + b"\r"
    if how == "hex":                               # a digit of the identifier garbled
        return body[:1] + b"Z" + body[2:] + b"\r"
    return b"\xff" + body[1:] + b"\r"              # a byte that is no text


damaged_strategy = st.one_of(
    st.sampled_from(REPORTED),
    st.builds(_damage, st.sampled_from([b"t1238DEADBEEF01020304\r", b"T1FFFFFFF4deadBEEF\r",
                                        b"t0C10\r", b"r7FF3\r", b"R123456780\r"]),
              st.sampled_from(["cut", "hex", "text"]), st.integers(0, 30)),
    st.binary(min_size=1, max_size=12).map(
        lambda b: b"\x80" + b.replace(b"\r", b"").replace(b"\a", b"") + b"\r"),
)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.one_of(frame_strategy.map(lambda i: ("good", _encode(i), i)),
                          damaged_strategy.map(lambda d: ("bad", d, None))),
                min_size=1, max_size=30))
def test_bulk_reader_skips_each_damaged_line_and_nothing_else(items):
    """Whatever the damage, a damaged line is one ``ValueError`` naming it, in its place in
    the stream, and every good line around it gives its frame."""
    stream = b"".join(raw for _kind, raw, _item in items)
    expected = []
    for kind, _raw, item in items:
        if kind == "bad":
            expected.append(("ValueError", "ValueError"))
        elif item[0] in "tTrR":
            expected.append("frame")
    with bus_on_pty("slcan_bulk") as (bus, master):
        for k in range(0, len(stream), 1024):
            os.write(master, stream[k:k + 1024])
        got = _drain(bus)
        _late(bus, got, len(expected))
    assert [g if g[0] == "ValueError" else "frame" for g in got] == expected
    frames = [g for g in got if g[0] != "ValueError"]
    good = [i for kind, _r, i in items if kind == "good" and i[0] in "tTrR"]
    assert [(f[0], f[1]) for f in frames] == [(i[1], i[0] in "TR") for i in good]


@pytest.mark.parametrize("interface", ["slcan", "slcan_bulk"])
def test_receive_counts_damaged_lines_of_either_driver_and_goes_on(tmp_path, interface):
    """python-can's ``slcan`` raises ValueError, IndexError, or (bytes that are no text) a
    CanOperationError that would poison its line buffer; ``slcan_bulk`` a ValueError. The
    receive loop counts each as one damaged line and loses no good frame."""
    from evtribo.acquisition.logger import LogWriter
    from evtribo.acquisition.receive import receive

    good = [b"t0C18%016X\r" % k for k in range(40)]
    stream = b"".join(good[:10] + REPORTED[:2] + good[10:20] + REPORTED[2:3] + good[20:30]
                      + REPORTED[3:] + good[30:])
    fh = (tmp_path / "x.log").open("wb", buffering=0)
    writer = LogWriter(fh, "can0").start()
    with bus_on_pty(interface) as (bus, master):
        os.write(master, stream)
        result = receive(bus, writer, duration=1.0, should_stop=lambda: False)
    writer.close()
    fh.close()
    assert (result.reason, result.frames, result.damaged_lines) == ("completed", 40, 4)
    assert writer.stats.damaged_lines == 4 and len(result.damaged_examples) == 4
    frames = list(can.CanutilsLogReader(tmp_path / "x.log"))
    assert [int.from_bytes(f.data, "big") for f in frames] == list(range(40))
