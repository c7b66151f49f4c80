"""``evtribo acquire`` as a process, recording python-can's ``slcan`` driver on a pty that
emulates a USB-CAN adapter: SIGTERM / SIGINT mid-trial, the adapter vanishing, exit codes."""

import contextlib
import json
import os
import queue
import re
import select
import signal
import subprocess
import sys
import threading
import time
import tty

import can
import cantools
import pytest

from _process import kill_and_reap
from evtribo.acquisition.rigfile import default_rig_path
from evtribo.cli import main

pytestmark = pytest.mark.skipif(not hasattr(os, "openpty"), reason="needs a pseudo-terminal")

DBC = cantools.database.load_file(str(default_rig_path().with_name("default.dbc")))


def _slcan_lines():
    fz, fx = DBC.get_message_by_name("FzCell"), DBC.get_message_by_name("FxCell")
    lines = []
    for c in range(256):
        for msg, sig in ((fz, "Fz"), (fx, "Fx")):
            prefix = sig[:2]
            data = msg.encode({sig: 0.5, f"{prefix}Status": 0, f"{prefix}Temp": 25,
                               f"{prefix}Counter": c})
            lines.append(f"t{msg.frame_id:03X}8{data.hex().upper()}\r".encode())
    return lines


class SlcanPty(threading.Thread):
    """A pseudo-terminal answering as an slcan adapter: once opened (``O``), it streams
    FzCell/FxCell frames with rolling counters at *rate* frames/s, none while its channel is
    closed (``C``); :meth:`inject` slips raw bytes in between two of its lines."""

    LINES = _slcan_lines()

    def __init__(self, rate=2000.0):
        super().__init__(daemon=True)
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        os.set_blocking(self.master, False)
        self.path = os.ttyname(self.slave)
        self.rate = rate
        self.sent = 0
        self.opened = threading.Event()
        self.stop = threading.Event()
        self.injected: queue.SimpleQueue[bytes] = queue.SimpleQueue()

    def inject(self, raw):
        """Write *raw* between two frame lines, as an adapter that garbles one would."""
        self.injected.put(raw)

    def run(self):
        buf = b""
        while b"O\r" not in buf and not self.stop.is_set():
            if select.select([self.master], [], [], 0.05)[0]:
                with contextlib.suppress(BlockingIOError):
                    buf += os.read(self.master, 1024)
        self.opened.set()
        t0 = time.perf_counter()
        lines = self.LINES
        is_open = True
        while not self.stop.is_set():
            due = int((time.perf_counter() - t0) * self.rate)
            # a closed channel (C) sends no frames until it is opened again (O)
            chunk = b"".join(lines[k % len(lines)] for k in range(self.sent, due)) \
                if is_open else b""
            while not self.injected.empty():
                chunk = self.injected.get() + chunk
            while chunk and not self.stop.is_set():
                if select.select([], [self.master], [], 0.05)[1]:
                    try:  # never a blocking write: a reader gone would hang it forever
                        chunk = chunk[os.write(self.master, chunk):]
                    except BlockingIOError:
                        pass
            self.sent = due
            if select.select([self.master], [], [], 0.005)[0]:
                with contextlib.suppress(BlockingIOError):
                    commands = os.read(self.master, 1024)     # the driver's commands
                    for cmd in commands.split(b"\r"):
                        is_open = {b"C": False, b"O": True}.get(cmd, is_open)

    def vanish(self):
        """Stop and close the master side, as an adapter pulled out of its USB port."""
        self.stop.set()
        self.join()
        os.close(self.master)
        self.master = None

    def close(self):
        if self.is_alive():
            self.stop.set()
            self.join()
        for fd in (self.master, self.slave):
            if fd is not None:
                os.close(fd)


@pytest.fixture
def adapter():
    pty = SlcanPty()
    pty.start()
    yield pty
    pty.close()


def acquire_cmd(study, path, *extra):
    return [sys.executable, "-m", "evtribo", "acquire", "--study", str(study),
            "--subject", "P01", "--trial", "run-01", "--interface", "slcan",
            "--channel", path, "--bitrate", "1000000", "--bus-option", "sleep_after_open=0",
            "--log-channel", "vcan0", *extra]


def wait_for_frames(part, proc, n_bytes=2000, timeout=300.0):
    """Wait until *part* holds *n_bytes* (*timeout* only ends a hang: a loaded machine
    starts the recorder slowly)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        assert proc.poll() is None, proc.communicate()
        if part.exists() and part.stat().st_size >= n_bytes:
            return
        time.sleep(0.05)
    pytest.fail("no frames reached the log")


def check_log(log, side):
    """Every line reads back; the load cells' counters skip exactly the frames the sidecar
    counts as dropped (none, from an adapter that never drops one)."""
    frames = list(can.LogReader(log))
    assert len(frames) == side["frames"] > 0
    last, skipped = {}, 0
    for f in frames:
        if f.arbitration_id not in (0x0C1, 0x0C2):
            continue
        counter = f.data[7]
        if f.arbitration_id in last:
            skipped += (counter - last[f.arbitration_id] - 1) % 256
        last[f.arbitration_id] = counter
    assert skipped == side["dropped_frames"]
    assert {ln.split()[1] for ln in log.read_text().splitlines()} == {"vcan0"}


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_signal_mid_trial_leaves_a_complete_log(tmp_path, adapter, sig):
    study = tmp_path / "study"
    proc = subprocess.Popen(acquire_cmd(study, adapter.path, "--duration", "60", "--quiet"),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_for_frames(study / "P01" / "run-01.log.part", proc)
        side = json.loads((study / "P01" / "run-01.json").read_text())
        assert side["ended"] == "recording"          # what a killed process would leave
        proc.send_signal(sig)
        _out, err = proc.communicate(timeout=120)
    finally:
        kill_and_reap(proc)
    assert proc.returncode == 0, err
    log = study / "P01" / "run-01.log"
    assert not (study / "P01" / "run-01.log.part").exists()
    side = json.loads((study / "P01" / "run-01.json").read_text())
    assert side["ended"] == "interrupted"
    assert side["end_detail"] == f"stopped by {sig.name}"
    assert side["interface"] == "slcan"
    assert side["bitrate"] == 1_000_000
    assert side["dropped_frames"] == 0
    check_log(log, side)


SLOW_DISK_ACQUIRE = """
import os, sys, threading, time
import can
from evtribo.cli import main

real_fsync = os.fsync

def slow_fsync(fd):            # a disk slow to sync: saving the trial takes seconds
    time.sleep(1.0)
    real_fsync(fd)

os.fsync = slow_fsync

import evtribo.acquisition.trial as trial_module

real_close = trial_module._close_writer

def saving(writer):            # the test's cue: the receive has ended, the log is saved
    open(sys.argv[2], "w").close()
    real_close(writer)

trial_module._close_writer = saving

def send():
    bus = can.Bus(interface="virtual", channel="slow-disk")
    k = 0
    while True:
        bus.send(can.Message(arbitration_id=0xC1, is_extended_id=False,
                             data=bytes(7) + bytes([k % 256])))
        k += 1
        time.sleep(0.002)

threading.Thread(target=send, daemon=True).start()
sys.exit(main(["acquire", "--study", sys.argv[1], "--subject", "P01", "--trial", "run-01",
               "--interface", "virtual", "--channel", "slow-disk", "--quiet"]))
"""


@pytest.mark.slow
def test_more_signals_while_the_trial_is_saved_do_not_abandon_it(tmp_path):
    """Ctrl-C, then Ctrl-C and SIGTERM again while the log is being saved (a slow disk):
    the trial still ends as interrupted, with every frame received in its log."""
    study = tmp_path / "study"
    saving = tmp_path / "saving"
    proc = subprocess.Popen([sys.executable, "-c", SLOW_DISK_ACQUIRE, str(study), str(saving)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_for_frames(study / "P01" / "run-01.log.part", proc, n_bytes=200)
        proc.send_signal(signal.SIGINT)
        deadline = time.monotonic() + 300  # a hang guard: a loaded machine is slow
        while not saving.exists():  # then the next signals come while the trial is saved
            assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
            time.sleep(0.02)
        proc.send_signal(signal.SIGINT)
        time.sleep(0.1)
        proc.send_signal(signal.SIGTERM)
        _out, err = proc.communicate(timeout=120)
    finally:
        kill_and_reap(proc)
    assert proc.returncode == 0, err
    assert "Traceback" not in err
    assert "ignored: saving the trial" in err
    assert not (study / "P01" / "run-01.log.part").exists()
    side = json.loads((study / "P01" / "run-01.json").read_text())
    assert side["ended"] == "interrupted"
    assert side["end_detail"] == "stopped by SIGINT"
    log = study / "P01" / "run-01.log"
    assert len(log.read_text().splitlines()) == side["frames"] > 0


def test_adapter_vanishing_mid_trial_exits_1_with_the_log(tmp_path, adapter):
    study = tmp_path / "study"
    proc = subprocess.Popen(acquire_cmd(study, adapter.path, "--duration", "60"),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_for_frames(study / "P01" / "run-01.log.part", proc)
        adapter.vanish()
        _out, err = proc.communicate(timeout=120)
    finally:
        kill_and_reap(proc)
    assert proc.returncode == 1, err
    assert "what was received is kept" in err
    assert "Traceback" not in err
    side = json.loads((study / "P01" / "run-01.json").read_text())
    assert side["ended"] == "bus-error"
    assert "CanOperationError" in side["end_detail"]
    assert side["bus_errors"] == 1
    check_log(study / "P01" / "run-01.log", side)


def wait_for_lines(part, proc, n_lines, timeout=300.0):
    """Wait until *part* holds *n_lines* whole lines (*timeout* only ends a hang)."""
    deadline = time.monotonic() + timeout
    while part.read_bytes().count(b"\n") < n_lines:
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.05)


#: Lines an slcan adapter garbled: a bad hex digit, cut short, no text, an extended frame cut.
DAMAGED = [b"t0CZ8" + b"00" * 8 + b"\r", b"t0C1\r", b"\xff\xfe\r", b"T1\r"]


@pytest.mark.slow
@pytest.mark.parametrize("interface", ["slcan", "slcan_bulk"])
def test_damaged_lines_are_counted_and_the_recording_goes_on(tmp_path, adapter, interface):
    study = tmp_path / "study"
    argv = acquire_cmd(study, adapter.path, "--duration", "300")  # ended by Ctrl-C below
    argv[argv.index("slcan")] = interface
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    part = study / "P01" / "run-01.log.part"
    try:
        wait_for_frames(part, proc)
        for k, raw in enumerate(DAMAGED):
            adapter.inject(raw)
            time.sleep(0.1)
            if k == 1:
                time.sleep(0.3)  # some between two flushes, some in one
        # the log holds more frames than the adapter had sent before the last damaged line:
        # it was read, and the recording went on past it (however late a busy machine reads)
        while not adapter.injected.empty():
            time.sleep(0.01)
        wait_for_lines(part, proc, adapter.sent + 200)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=120)
    finally:
        kill_and_reap(proc)
    assert proc.returncode == 0, err
    assert "(4 damaged lines)" in out and "Traceback" not in err
    side = json.loads((study / "P01" / "run-01.json").read_text())
    assert side["ended"] == "interrupted"
    assert side["damaged_lines"] == 4 and side["bus_errors"] == 4
    assert len(side["bus_exceptions"]) == 4
    assert side["dropped_frames"] == 0
    check_log(study / "P01" / "run-01.log", side)   # not one good frame lost around them


@pytest.mark.usefixtures("rig_heard_by_acquire")
def test_second_acquire_into_the_same_trial_is_refused(tmp_path, capsys):
    study = tmp_path / "study"
    args = ["acquire", "--study", str(study), "--subject", "P01", "--trial", "t1",
            "--interface", "virtual", "--channel", "cli_refused", "--duration", "0.2"]
    assert main([*args, "--quiet"]) == 0
    before = (study / "P01" / "t1.json").read_text()
    assert main(args) == 2
    assert "--force" in capsys.readouterr().err
    assert (study / "P01" / "t1.json").read_text() == before
    assert main([*args, "--force", "--notes", "again"]) == 0
    assert "completed, 2 frames" in capsys.readouterr().out
    assert json.loads((study / "P01" / "t1.json").read_text())["notes"] == "again"


@pytest.mark.usefixtures("rig_heard_by_acquire")
def test_acquire_records_the_tare_stretch_it_asked_for(tmp_path, capsys):
    study = tmp_path / "study"
    args = ["acquire", "--study", str(study), "--subject", "P01", "--interface", "virtual",
            "--channel", "cli_tare", "--duration", "0.4"]
    assert main([*args, "--trial", "t1", "--tare-s", "0.3"]) == 0
    out = capsys.readouterr().out
    assert "lift the finger off the screen for 0.3 s (taring), then slide" in out
    assert json.loads((study / "P01" / "t1.json").read_text())["tare_s"] == 0.3
    assert main([*args, "--trial", "t2"]) == 0  # by default 1.5 s, at most half the trial
    assert json.loads((study / "P01" / "t2.json").read_text())["tare_s"] == 0.2
    assert main([*args, "--trial", "t3", "--tare-s", "0", "--quiet"]) == 0
    assert json.loads((study / "P01" / "t3.json").read_text())["tare_s"] == 0.0
    assert main([*args, "--trial", "t4", "--tare-s", "0.4"]) == 2  # as long as the trial
    assert "'--tare-s'" in capsys.readouterr().err


@pytest.mark.parametrize("args,key", [
    (["--subject", "../x"], "subject"),
    (["--interface", "no_such_interface"], "--interface"),
    (["--bus-option", "novalue"], "--bus-option"),
    (["--duration", "-1"], "--duration"),
])
def test_bad_usage_exits_2_naming_the_key(tmp_path, capsys, args, key):
    base = {"--study": str(tmp_path / "s"), "--subject": "P01", "--trial": "t",
            "--interface": "virtual", "--channel": "cli_bad", "--duration": "0.1"}
    for flag, value in zip(args[::2], args[1::2], strict=True):
        base[flag] = value
    argv = ["acquire", "--quiet"] + [x for kv in base.items() for x in kv]
    assert main(argv) == 2
    assert f"'{key}'" in capsys.readouterr().err


def test_sigkill_leaves_whole_lines_up_to_the_last_flush(tmp_path, adapter):
    study = tmp_path / "study"
    proc = subprocess.Popen(acquire_cmd(study, adapter.path, "--duration", "60", "--quiet"),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_for_frames(study / "P01" / "run-01.log.part", proc, n_bytes=20000)
    finally:
        kill_and_reap(proc)
    part = study / "P01" / "run-01.log.part"
    text = part.read_text()
    assert text.endswith("\n")                      # no line cut in two
    frames = list(can.CanutilsLogReader(part))
    assert len(frames) == text.count("\n")          # every line whole and readable
    assert len(text) >= 20000                       # at least what was on disk before the kill
    side = json.loads((study / "P01" / "run-01.json").read_text())
    assert side["ended"] == "recording"
    assert side["log"] == "run-01.log.part"


@pytest.mark.parametrize("interface,rates", [
    ("slcan", ["--fz-rate", "1000", "--fx-rate", "2000"]),            # python-can's driver
    ("slcan_bulk", ["--fz-rate", "2800", "--fx-rate", "5550"]),       # saturated 1 Mbit/s
])
@pytest.mark.slow
def test_acquire_from_simulate_pty_loses_nothing_unseen(tmp_path, simulate_pty, interface,
                                                        rates):
    """The simulated rig streams at full speed through its emulated adapter; every frame the
    adapter had to drop (a full buffer, when this machine is too busy to read in time) is a
    counted gap in the log, and no other frame is missing. How fast the frames flowed is
    not asserted: benchmarks/acquire.py measures the sustained rates."""
    sim, path = simulate_pty(*rates)
    study = tmp_path / "study"
    code = main(["acquire", "--study", str(study), "--subject", "P01", "--trial", "run-01",
                 "--interface", interface, "--channel", path, "--bitrate", "1000000",
                 "--bus-option", "sleep_after_open=0", "--log-channel", "vcan0",
                 "--duration", "1.5", "--quiet"])
    sim.send_signal(signal.SIGTERM)
    _out, err = sim.communicate(timeout=60)
    assert code == 0
    assert re.search(r"evtribo simulate: \d+ frames sent in [\d.]+ s", err), err
    full = re.search(r"(\d+) to a full buffer \(the client did not read them in time\)", err)
    side = json.loads((study / "P01" / "run-01.json").read_text())
    assert side["ended"] == "completed"
    assert side["interface"] == interface
    assert side["dropped_frames"] <= (int(full.group(1)) if full else 0)  # the adapter's
    assert side["frames_by_id"]["0C1"] > 0 and side["frames_by_id"]["0C2"] > 0
    check_log(study / "P01" / "run-01.log", side)
