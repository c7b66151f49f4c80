"""``record_trial``: every frame of a python-can bus into a study folder, nothing lost."""

import copy
import errno
import json
import os
import threading
import time

import can
import cantools
import pytest

import evtribo.acquisition.trial as trial_module
from _rigcells import rig_heard
from evtribo.acquisition.buses.bus import BusSettings
from evtribo.acquisition.rigfile import default_rig_path
from evtribo.acquisition.simulator import Simulator, TrialConfig
from evtribo.acquisition.trial import TrialInfo, TrialOptions, TrialPaths, record_trial
from evtribo.documents.replacing import stages
from evtribo.errors import (
    AcquisitionError,
    ConfigError,
    OutputExistsError,
    SidecarError,
    StudyError,
)
from evtribo.study import load_study, read_sidecar

DBC = cantools.database.load_file(str(default_rig_path().with_name("default.dbc")))


def rig_frames(n, *, skip=(), extra=True):
    """*n* rig-like frames: FzCell and FxCell alternating with counters, HvStatus every 100,
    plus (with *extra*) a foreign extended frame and an error frame. Counter values in *skip*
    (for FzCell) are left out, as if lost on the bus: their time passes all the same. Each
    frame's timestamp is its time on a saturated bus (8,400 frames/s) from the first."""
    fz, fx, hv = (DBC.get_message_by_name(m) for m in ("FzCell", "FxCell", "HvStatus"))
    frames = []
    count = {"fz": 0, "fx": 0, "hv": 0}
    for i in range(n):
        if i % 100 == 99:
            c = count["hv"]
            msg, data = hv, hv.encode({"HvOn": c % 2, "HvWave": 1, "HvCounter": c % 16,
                                       "HvAmp": 140, "HvFreq": 10000, "HvCurrent": 1})
            count["hv"] += 1
        elif i % 2 == 0:
            c = count["fz"]
            count["fz"] += 1
            if c in skip:
                continue
            msg, data = fz, fz.encode({"Fz": 0.5, "FzStatus": 0, "FzTemp": 25,
                                       "FzCounter": c % 256})
        else:
            c = count["fx"]
            count["fx"] += 1
            msg, data = fx, fx.encode({"Fx": 0.25, "FxStatus": 0, "FxTemp": 25,
                                       "FxCounter": c % 256})
        frames.append(can.Message(timestamp=i / 8400, arbitration_id=msg.frame_id,
                                  is_extended_id=False, data=data))
    if extra:
        frames.insert(n // 3, can.Message(timestamp=frames[n // 3].timestamp,
                                          arbitration_id=0x18FF0001, is_extended_id=True,
                                          data=b"\x01\x02\x03"))
        frames.insert(n // 2, can.Message(timestamp=frames[n // 2].timestamp,
                                          is_error_frame=True, data=bytes(8)))
    return frames


class Sender(threading.Thread):
    """Sends *frames* on a virtual channel at *rate* frames/s, in 5 ms bursts, each stamped
    with its time on the bus (its timestamp from the start): what the receiver is given does
    not depend on how busy the machine is."""

    def __init__(self, channel, frames, rate=8400.0):
        super().__init__(daemon=True)
        self.bus = can.Bus(interface="virtual", channel=channel, preserve_timestamps=True)
        self.frames = frames
        self.rate = rate
        self.done = threading.Event()

    def run(self):
        t0, start = time.perf_counter(), time.time()
        n = 0
        while n < len(self.frames):
            due = min(int((time.perf_counter() - t0) * self.rate) + 1, len(self.frames))
            while n < due:
                frame = copy.copy(self.frames[n])
                frame.timestamp = start + frame.timestamp
                self.bus.send(frame)
                n += 1
            time.sleep(0.005)
        self.bus.shutdown()
        self.done.set()


def record_from_sender(tmp_path, channel, frames, **kwargs):
    """Record until the sender is done and every frame it sent was received (``until``): a
    busy machine sends and receives more slowly, and the trial waits for it."""
    study = tmp_path / "study"
    sender = Sender(channel, frames)
    with can.Bus(interface="virtual", channel=channel) as bus:
        result = record_trial(bus, study, "P01", "run-01", duration=None,
                              settings=BusSettings("virtual", channel, 1_000_000),
                              started=lambda _paths: sender.start(), until=sender.done.is_set,
                              **kwargs)
    sender.join()
    return study, result


def test_records_every_frame_and_a_spec_sidecar(tmp_path):
    frames = rig_frames(8400)                       # 1 s at a saturated 1 Mbit/s
    info = TrialInfo(waveform="square", frequency_Hz=10000, amplitude_V=140,
                     condition="alternating", notes="first try")
    study, result = record_from_sender(tmp_path, "acq_every_frame", frames, info=info)
    assert result.ended == "completed"
    assert result.exit_code == 0
    log = study / "P01" / "run-01.log"
    assert not (study / "P01" / "run-01.log.part").exists()

    back = list(can.LogReader(log))
    assert len(back) == len(frames)
    for sent, got in zip(frames, back, strict=True):
        assert got.is_error_frame == sent.is_error_frame
        if not sent.is_error_frame:
            assert (got.arbitration_id, got.is_extended_id, bytes(got.data)) == \
                (sent.arbitration_id, sent.is_extended_id, bytes(sent.data))
    first = log.read_text().splitlines()[0]
    assert first.split()[1] == "acq_every_frame"

    side = json.loads((study / "P01" / "run-01.json").read_text())
    assert side["subject"] == "P01"
    assert side["waveform"] == "square"
    assert side["frequency_Hz"] == 10000
    assert side["amplitude_V"] == 140
    assert side["condition"] == "alternating"
    assert side["notes"] == "first try"
    assert side["ended"] == "completed"
    assert side["frames"] == len(frames)
    n_hv = 84
    assert side["frames_by_id"] == {"0C1": 4200, "0C2": 4200 - n_hv, "1A0": n_hv,
                                    "18FF0001": 1, "error": 1}
    assert side["dropped_frames"] == 0
    assert side["dropped_frames_by_message"] == {"FzCell": 0, "FxCell": 0}
    assert side["error_frames"] == 1
    assert side["bus_errors"] == 1
    assert side["interface"] == "virtual"
    assert side["channel"] == "acq_every_frame"
    assert side["bitrate"] == 1_000_000
    assert side["rig"]["dbc"] == "rig/default.dbc"
    assert side["evtribo_version"]
    assert side["python_can_version"] == can.__version__
    assert side["start_time"].endswith("Z") and side["end_time"] > side["start_time"]
    # the recording lasted at least as long as the frames it holds (how long that was on
    # this machine is not asserted)
    assert side["duration_s"] >= back[-1].timestamp - back[0].timestamp > 0
    # the study module's readers accept what acquire writes
    assert read_sidecar(study / "P01" / "run-01.json", default_subject="P01").amplitude_V == 140
    loaded = load_study(study)
    assert [t.key for t in loaded.trials] == ["P01/run-01"]
    assert loaded.rig.normal_force.qualified_name == "FzCell.Fz"
    assert (study / "rig" / "default.dbc").read_bytes() == \
        default_rig_path().with_name("default.dbc").read_bytes()


def test_counts_frames_lost_by_the_counters(tmp_path):
    lost = {7, 8, 9, 200, 201, 1000}                # FzCell counter values never sent
    frames = rig_frames(3000, skip=lost, extra=False)
    _study, result = record_from_sender(tmp_path, "acq_counts_lost", frames)
    side = result.sidecar
    assert side["frames"] == len(frames)
    assert side["dropped_frames"] == len(lost)
    assert side["dropped_frames_by_message"] == {"FzCell": len(lost), "FxCell": 0}


def test_a_frame_received_twice_or_late_is_no_frame_lost(tmp_path):
    """One frame received twice made the sidecar say 255 frames lost, two received
    swapped 256: a duplicate is counted as one, a late frame is no loss."""
    lost = {7, 8, 9}
    frames = rig_frames(3000, skip=lost, extra=False)
    fz = [i for i, f in enumerate(frames) if f.arbitration_id == 0x0C1]
    a, b = fz[900], fz[901]
    frames[a], frames[b] = frames[b], frames[a]                  # received swapped
    frames.insert(fz[500] + 1, frames[fz[500]])                  # received twice
    _study, result = record_from_sender(tmp_path, "acq_twice_late", frames)
    side = result.sidecar
    assert (side["dropped_frames"], side["duplicate_frames"]) == (len(lost), 1)
    assert side["dropped_frames_by_message"] == {"FzCell": len(lost), "FxCell": 0}
    assert side["counter_restarts_s"] == {}


def test_stop_request_ends_as_interrupted(tmp_path):
    stop = threading.Event()  # asked for once the trial has begun, whatever the machine's pace
    with can.Bus(interface="virtual", channel="acq_stop") as bus:
        result = record_trial(bus, tmp_path / "s", "P02", "run-02", duration=20.0,
                              should_stop=stop.is_set, started=lambda _paths: stop.set())
    assert result.ended == "interrupted"  # by the request, not after its 20 s
    assert result.exit_code == 0
    assert (tmp_path / "s" / "P02" / "run-02.log").read_text() == ""


class VanishingBus(can.BusABC):
    """Delivers *n* FzCell frames, then fails as an unplugged adapter does."""

    def __init__(self, n, **kwargs):
        super().__init__(channel="ttyACM0", **kwargs)
        self.n = n
        self.i = 0

    def _recv_internal(self, timeout):
        if self.i >= self.n:
            raise can.CanOperationError("Could not read from serial device")
        data = DBC.get_message_by_name("FzCell").encode(
            {"Fz": 0.5, "FzStatus": 0, "FzTemp": 25, "FzCounter": self.i % 256})
        self.i += 1
        return can.Message(timestamp=time.time(), arbitration_id=0xC1, is_extended_id=False,
                           data=data), False

    def send(self, msg, timeout=None):
        raise can.CanOperationError("read-only")


def test_adapter_vanishing_keeps_the_log_and_says_so(tmp_path):
    bus = VanishingBus(5000)
    try:
        result = record_trial(bus, tmp_path / "s", "P01", "run-01", duration=10.0)
    finally:
        bus.shutdown()
    assert result.ended == "bus-error"
    assert result.exit_code == 1
    log = tmp_path / "s" / "P01" / "run-01.log"
    assert len(list(can.LogReader(log))) == 5000
    side = json.loads((tmp_path / "s" / "P01" / "run-01.json").read_text())
    assert side["ended"] == "bus-error"
    assert side["frames"] == 5000
    assert side["dropped_frames"] == 0
    assert "Could not read from serial device" in side["end_detail"]
    assert side["bus_errors"] == 1
    assert side["bus_exceptions"] == ["CanOperationError: Could not read from serial device"]


class GlitchingBus(VanishingBus):
    """Delivers *n* FzCell frames with *exc* raised once after the first *n* // 2, then
    nothing (the trial ends by its duration)."""

    def __init__(self, n, exc, **kwargs):
        super().__init__(n, **kwargs)
        self.exc = exc

    def _recv_internal(self, timeout):
        if self.exc is not None and self.i == self.n // 2:
            exc, self.exc = self.exc, None
            raise exc
        if self.i >= self.n:
            time.sleep(timeout or 0)
            return None, False
        return super()._recv_internal(timeout)


def _undecodable():
    try:
        b"\xff\xfe\r".decode()
    except UnicodeDecodeError as err:
        exc = can.CanOperationError("Could not read from serial device")
        exc.__cause__ = err
        return exc
    raise AssertionError


@pytest.mark.parametrize(("exc", "damaged"), [
    (ValueError("invalid literal for int() with base 16: '0CZ'"), True),
    (IndexError("string index out of range"), True),
    (_undecodable(), True),
    (can.CanOperationError("Could not read from serial device"), False),
    (OSError(5, "Input/output error"), False),
    (TypeError("unsupported operand"), False),
    (AttributeError("'NoneType' object has no attribute 'read'"), False),
    (RuntimeError("driver bug"), False),
])
def test_no_exception_from_the_bus_leaves_the_sidecar_recording(tmp_path, exc, damaged):
    """A line the driver cannot parse is counted and the trial goes on; anything else the
    bus raises ends it as bus-error. Either way the sidecar says how it ended."""
    bus = GlitchingBus(400, exc)
    try:
        result = record_trial(bus, tmp_path / "s", "P01", "run-01", duration=0.6)
    finally:
        bus.shutdown()
    side = json.loads((tmp_path / "s" / "P01" / "run-01.json").read_text())
    assert side == result.sidecar
    assert side["ended"] == ("completed" if damaged else "bus-error")
    assert result.exit_code == (0 if damaged else 1)
    assert side["frames"] == (400 if damaged else 200)
    assert side["damaged_lines"] == int(damaged)
    assert side["bus_errors"] == 1
    assert len(side["bus_exceptions"]) == 1 and type(exc).__name__ in side["bus_exceptions"][0]
    assert len(list(can.LogReader(tmp_path / "s" / "P01" / "run-01.log"))) == side["frames"]


@pytest.mark.parametrize("leftover", ["run-01.log", "run-01.json", "run-01.log.part"])
def test_refuses_to_overwrite_a_trial(tmp_path, leftover):
    study = tmp_path / "s"
    (study / "P01").mkdir(parents=True)
    (study / "P01" / leftover).write_text("precious\n")
    with can.Bus(interface="virtual", channel=f"acq_refuse_{leftover}") as bus:
        with pytest.raises(OutputExistsError, match=leftover):
            record_trial(bus, study, "P01", "run-01", duration=0.1)
        assert (study / "P01" / leftover).read_text() == "precious\n"
        result = record_trial(bus, study, "P01", "run-01", duration=0.1, force=True,
                              started=rig_heard(f"acq_refuse_{leftover}"))
    assert result.ended == "completed"
    assert sorted(p.name for p in (study / "P01").iterdir()) == ["run-01.json", "run-01.log"]


def test_forced_trial_keeps_the_previous_one_until_it_ends(tmp_path):
    study = tmp_path / "s"
    old = {}
    with can.Bus(interface="virtual", channel="acq_force_keep") as bus:
        record_trial(bus, study, "P01", "run-01", duration=0.1, info=TrialInfo(notes="first"),
                     started=rig_heard("acq_force_keep"))
        paths = TrialPaths.of(study, "P01", "run-01")
        before = {p.name: p.read_bytes() for p in (paths.log, paths.sidecar)}

        def started(p):
            old.update({q.name: q.read_bytes() for q in (p.log, p.sidecar) if q.exists()})
            old["new"] = [sorted(f.name for f in s.iterdir())
                          for s in stages(p.folder).get("run-01", [])]

        result = record_trial(bus, study, "P01", "run-01", duration=0.1, force=True,
                              info=TrialInfo(notes="second"),
                              started=rig_heard("acq_force_keep", started))
    # while recording: the old trial intact, the new one beside it in a folder of its own
    assert old == {**before, "new": [["run-01.json", "run-01.log.part"]]}
    assert result.ended == "completed" and not result.kept_previous
    assert json.loads(paths.sidecar.read_text())["notes"] == "second"
    assert sorted(p.name for p in paths.folder.iterdir()) == ["run-01.json", "run-01.log"]


def test_forced_trial_failing_before_any_frame_keeps_the_previous_one(tmp_path):
    study = tmp_path / "s"
    with can.Bus(interface="virtual", channel="acq_force_fail") as bus:
        record_trial(bus, study, "P01", "run-01", duration=0.1,
                     started=rig_heard("acq_force_fail"))
    paths = TrialPaths.of(study, "P01", "run-01")
    before = {p.name: p.read_bytes() for p in paths.folder.iterdir()}
    bus = VanishingBus(0)
    try:
        result = record_trial(bus, study, "P01", "run-01", duration=5.0, force=True)
    finally:
        bus.shutdown()
    assert (result.ended, result.exit_code, result.kept_previous) == ("bus-error", 1, True)
    assert {p.name: p.read_bytes() for p in paths.folder.iterdir()} == before


def test_first_sidecar_failing_leaves_nothing_that_blocks_a_retry(tmp_path, monkeypatch):
    study = tmp_path / "s"
    real = trial_module._write_json

    def full_disk(path, data):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(trial_module, "_write_json", full_disk)
    with can.Bus(interface="virtual", channel="acq_first_sidecar") as bus:
        with pytest.raises(AcquisitionError, match="No space left"):
            record_trial(bus, study, "P01", "run-01", duration=0.1)
        assert list((study / "P01").iterdir()) == []
        monkeypatch.setattr(trial_module, "_write_json", real)
        result = record_trial(bus, study, "P01", "run-01", duration=0.1,   # no --force
                              started=rig_heard("acq_first_sidecar"))
    assert result.ended == "completed"
    assert sorted(p.name for p in (study / "P01").iterdir()) == ["run-01.json", "run-01.log"]


@pytest.mark.parametrize(("kwargs", "error", "key"), [
    ({"duration": float("inf")}, ConfigError, "duration"),
    ({"duration": float("nan")}, ConfigError, "duration"),
    ({"info": TrialInfo(amplitude_V=float("inf"))}, SidecarError, "amplitude_V"),
    ({"info": TrialInfo(frequency_Hz=float("nan"))}, SidecarError, "frequency_Hz"),
])
def test_non_finite_duration_or_metadata_is_refused_before_writing(tmp_path, kwargs, error,
                                                                     key):
    kwargs = {"duration": 0.1, **kwargs}
    with can.Bus(interface="virtual", channel="acq_nonfinite") as bus:
        with pytest.raises(error) as err:
            record_trial(bus, tmp_path / "s", "P01", "run-01", **kwargs)
    assert err.value.key == key
    assert not (tmp_path / "s").exists()


@pytest.mark.parametrize("subject,trial", [("../P01", "run-01"), ("P01", "a/b"),
                                           ("P 01", "run"), ("P01", "")])
def test_refuses_names_that_are_not_plain(tmp_path, subject, trial):
    with can.Bus(interface="virtual", channel="acq_names") as bus:
        with pytest.raises(StudyError):
            record_trial(bus, tmp_path / "s", subject, trial, duration=0.1)
    assert not (tmp_path / "s").exists()


def test_refuses_bad_metadata(tmp_path):
    with can.Bus(interface="virtual", channel="acq_meta") as bus:
        with pytest.raises(SidecarError, match="waveform"):
            record_trial(bus, tmp_path / "s", "P01", "r", duration=0.1,
                         info=TrialInfo(waveform="sawtooth"))


def test_records_the_simulated_rig_at_a_saturated_rate(tmp_path):
    # ~8,400 frames/s: a saturated 1 Mbit/s bus of 8-byte frames; 1 % of the load cells'
    # frames lost on the bus (gaps in their counters) and some foreign traffic
    cfg = TrialConfig(fz_rate_Hz=2800, fx_rate_Hz=5550, hv_rate_Hz=50, drop_probability=0.01,
                      foreign_rate_Hz=20, seed=3)
    sim = Simulator(config=cfg)
    out = {}
    channel = "acq_simulated_rig"
    # each frame stamped by the rig's clock, as a logger with hardware timestamps gives them
    # (the frames this test hands the recorder do not depend on how busy the machine is)
    tx = can.Bus(interface="virtual", channel=channel, preserve_timestamps=True)
    done = threading.Event()
    sender = threading.Thread(target=lambda: (out.update(stats=sim.run(tx, duration=1.0)),
                                              done.set()))
    with can.Bus(interface="virtual", channel=channel) as rx:  # until all sent is received
        result = record_trial(rx, tmp_path / "s", "P01", "run-01", duration=None,
                              started=lambda _paths: sender.start(), until=done.is_set)
    sender.join()
    tx.shutdown()
    stats, truth = out["stats"], sim.generator.truth()
    side = result.sidecar
    assert stats.not_sent == 0
    assert side["frames"] == stats.sent > 8000
    assert len(list(can.LogReader(tmp_path / "s" / "P01" / "run-01.log"))) == stats.sent
    assert side["dropped_frames_by_message"] == {
        "FzCell": truth.nodes["FzCell"]["dropped"], "FxCell": truth.nodes["FxCell"]["dropped"]}
    assert side["dropped_frames"] > 50
    assert sum(n for k, n in side["frames_by_id"].items()
               if k not in ("0C1", "0C2", "1A0")) == truth.foreign_frames > 0


def test_disk_full_mid_trial_keeps_the_log_so_far(tmp_path, monkeypatch):
    from evtribo.acquisition.logger import LogWriter

    original = LogWriter._write_all
    calls = []

    def fill_up(self, data):
        calls.append(len(data))
        if len(calls) > 1:
            raise OSError(28, "No space left on device")
        original(self, data)

    monkeypatch.setattr(LogWriter, "_write_all", fill_up)
    bus = VanishingBus(10**9)                      # frames as fast as they can be made
    try:
        result = record_trial(bus, tmp_path / "s", "P01", "run-01", duration=5.0)
    finally:
        bus.shutdown()
    assert result.ended == "disk-error"                # ended by the fault, not its duration
    assert result.exit_code == 1
    assert result.sidecar["ended"] == "disk-error"
    assert "No space left on device" in result.sidecar["end_detail"]
    log = tmp_path / "s" / "P01" / "run-01.log"
    lines = log.read_text().splitlines()
    assert len(lines) > 0 and log.stat().st_size == calls[0]   # the first batch, whole
    assert len(list(can.LogReader(log))) == len(lines)


def test_bus_options_and_python_can_configuration(monkeypatch):
    from evtribo.acquisition.buses.bus import open_bus, parse_bus_options

    assert parse_bus_options(["sleep_after_open=0", "fd=True", "app_name=my rig",
                              "timeout=0.5"]) == \
        {"sleep_after_open": 0, "fd": True, "app_name": "my rig", "timeout": 0.5}
    monkeypatch.setenv("CAN_INTERFACE", "virtual")
    monkeypatch.setenv("CAN_CHANNEL", "acq_from_env")
    monkeypatch.setenv("CAN_BITRATE", "500000")
    settings = BusSettings()
    bus = open_bus(settings)
    try:
        assert (settings.interface, settings.channel, settings.bitrate) == \
            ("virtual", "acq_from_env", 500000)
        assert bus.channel_info == "Virtual bus channel acq_from_env"
    finally:
        bus.shutdown()


@pytest.mark.parametrize(("number", "says"), [
    (errno.EAFNOSUPPORT, ["kernel offers no SocketCAN", "modprobe can_raw", "--interface slcan",
                          "docs/hardware.md"]),
    (errno.ENODEV, ["ip -brief link show type can", "ip link add dev vcan0 type vcan",
                    "docs/hardware.md"]),
    (errno.ENETDOWN, ["sudo ip link set can7 up type can bitrate", "docs/hardware.md"]),
])
def test_a_socketcan_bus_that_cannot_open_says_what_to_check(monkeypatch, number, says):
    """A machine without SocketCAN, a channel it has not, an interface that is down: each
    is said with what to give and how to check (ip link, vcan, docs/hardware.md)."""
    import evtribo.acquisition.buses.socketcan as sc
    from evtribo.acquisition.buses.bus import open_bus
    from evtribo.errors import AcquisitionError

    def refuse(*_args, **_kwargs):
        raise OSError(number, os.strerror(number))

    monkeypatch.setattr(sc, "SocketcanBus", refuse)
    with pytest.raises(AcquisitionError) as caught:
        open_bus(BusSettings(interface="socketcan", channel="can7"))
    text = str(caught.value)
    assert f"cannot open socketcan can7: [Errno {number}]" in text
    for part in says:
        assert part in text, text


def test_no_interface_anywhere_says_what_to_give(monkeypatch):
    from evtribo.acquisition.buses.bus import open_bus
    from evtribo.errors import ConfigError

    for name in ("CAN_INTERFACE", "CAN_CHANNEL", "CAN_BITRATE", "CAN_CONFIG"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(can.util, "CONFIG_FILES", [])
    with pytest.raises(ConfigError) as caught:
        open_bus(BusSettings())
    text = str(caught.value)
    assert caught.value.key == "--interface"
    assert "no interface given" in text and "None" not in text
    assert "--interface socketcan --channel can0" in text and "docs/hardware.md" in text


def test_options_come_as_one_object_or_as_keywords(tmp_path):
    study = tmp_path / "s"
    options = TrialOptions(duration=0.1, info=TrialInfo(notes="first"),
                           started=rig_heard("acq_options"))
    with can.Bus(interface="virtual", channel="acq_options") as bus:
        assert record_trial(bus, study, "P01", "run-01", options).ended == "completed"
        with pytest.raises(OutputExistsError):
            record_trial(bus, study, "P01", "run-01", options)
        # keywords override the object's fields
        result = record_trial(bus, study, "P01", "run-01", options, force=True,
                              info=TrialInfo(notes="second"))
    assert result.ended == "completed"
    assert json.loads((study / "P01" / "run-01.json").read_text())["notes"] == "second"
    with pytest.raises(ConfigError) as err:
        record_trial(None, study, "P01", "run-02", TrialOptions(duration=-1.0))
    assert err.value.key == "duration"
