"""A full disk while recording: the sidecar says ``disk-error``, the log ends with whole
lines, and nothing half-written (a trial, a new study's DBC) blocks the next attempt.

:class:`FullDisk` gives a folder a disk of its own with a set number of free bytes: every
write under it (``open``, ``os.pwrite``, ``os.posix_fallocate``, ``shutil.copyfile``)
takes room, files removed or truncated give it back, and a write that does not fit writes
what fits and then fails with ``ENOSPC``, as a real disk does.
"""

from __future__ import annotations

import builtins
import errno
import io
import json
import os
import shutil
import threading
import time

import can
import cantools
import pytest

from _rigcells import rig_heard
from evtribo.acquisition.rigfile import default_rig_path
from evtribo.acquisition.trial import RESERVE_BYTES, TrialPaths, record_trial
from evtribo.cli import main
from evtribo.errors import AcquisitionError

DBC = cantools.database.load_file(str(default_rig_path().with_name("default.dbc")))


def _enospc():
    return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


class _File:
    """A file object under a :class:`FullDisk`."""

    def __init__(self, real, disk):
        self._real = real
        self._disk = disk

    def write(self, data):
        size = len(data.encode() if isinstance(data, str) else data)
        room = self._disk.room()
        if isinstance(self._real, io.RawIOBase):          # unbuffered: a short write
            if room == 0 and size:
                raise _enospc()
            return self._real.write(memoryview(data)[:room])
        if isinstance(self._real, io.TextIOBase):
            if size > room:
                raise _enospc()
            n = self._real.write(data)
        else:
            n = self._real.write(memoryview(data)[:room])
        self._real.flush()
        if size > room:
            raise _enospc()
        return n

    def __getattr__(self, name):
        return getattr(self._real, name)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self._real.close()

    def __iter__(self):
        return iter(self._real)


class FullDisk:
    """The folder *root* on a disk with :meth:`fill`-set room left."""

    def __init__(self, root, monkeypatch):
        self.root = os.path.realpath(root)
        self.limit = None
        real_open, real_pwrite = io.open, os.pwrite
        real_fallocate = os.posix_fallocate

        def open_(file, mode="r", *args, **kwargs):
            real = real_open(file, mode, *args, **kwargs)
            if set(mode) & set("wax+") and self._ours(file):
                return _File(real, self)
            return real

        def pwrite(fd, data, offset):
            if self._ours(fd) and self._need(fd, offset + len(data)) > self.room():
                raise _enospc()
            return real_pwrite(fd, data, offset)

        def fallocate(fd, offset, length):
            if self._ours(fd) and self._need(fd, offset + length) > self.room():
                raise _enospc()
            return real_fallocate(fd, offset, length)

        monkeypatch.setattr(builtins, "open", open_)
        monkeypatch.setattr(io, "open", open_)
        monkeypatch.setattr(os, "pwrite", pwrite)
        monkeypatch.setattr(os, "posix_fallocate", fallocate)
        monkeypatch.setattr(shutil, "_USE_CP_SENDFILE", False)  # copy through write()

    def _ours(self, file):
        if isinstance(file, int):
            try:
                file = os.readlink(f"/proc/self/fd/{file}")
            except OSError:
                return False
        return os.path.realpath(os.fspath(file)).startswith(self.root + os.sep)

    @staticmethod
    def _need(fd, end):
        return max(end - os.fstat(fd).st_size, 0)

    def used(self):
        """Bytes in the files under the folder."""
        return sum(os.path.getsize(os.path.join(d, f))
                   for d, _, files in os.walk(self.root) for f in files)

    def room(self):
        return 10**12 if self.limit is None else max(self.limit - self.used(), 0)

    def fill(self, free):
        """Leave *free* bytes (None: as much as wanted)."""
        self.limit = None if free is None else self.used() + free


@pytest.fixture
def disk(tmp_path, monkeypatch):
    return FullDisk(tmp_path, monkeypatch)


class FastBus(can.BusABC):
    """FzCell frames with a rolling counter, as fast as they can be made."""

    def __init__(self, **kwargs):
        super().__init__(channel="fast", **kwargs)
        self.i = 0

    def _recv_internal(self, timeout):
        data = DBC.get_message_by_name("FzCell").encode(
            {"Fz": 0.5, "FzStatus": 0, "FzTemp": 25, "FzCounter": self.i % 256})
        self.i += 1
        return can.Message(timestamp=time.time(), arbitration_id=0xC1, is_extended_id=False,
                           data=data), False

    def send(self, msg, timeout=None):
        raise can.CanOperationError("read-only")


def check_whole_lines(log, frames):
    data = log.read_bytes()
    assert data.endswith(b"\n"), "the last line is cut"
    assert len(list(can.CanutilsLogReader(log))) == data.count(b"\n") == frames


@pytest.mark.parametrize("log_room", [2_000, 33_333, 150_001])
def test_disk_full_mid_trial_the_sidecar_says_so_and_the_log_has_whole_lines(
        tmp_path, disk, log_room):
    """The disk fills at three moments (cutting a line each time at another place)."""
    study = tmp_path / "study"
    paths = TrialPaths.of(study, "P01", "run-01")
    bus = FastBus()
    try:
        record_trial(bus, study, "P01", "run-00", duration=0.05,
                     started=rig_heard("full-disk-start"))   # the study exists
        disk.fill(RESERVE_BYTES + 3_000 + log_room)
        result = record_trial(bus, study, "P01", "run-01", duration=10.0)
    finally:
        bus.shutdown()
    assert (result.ended, result.exit_code) == ("disk-error", 1)
    side = json.loads(paths.sidecar.read_text())
    assert side["ended"] == "disk-error" and side == result.sidecar
    assert "No space left on device" in side["end_detail"]
    assert "the log ends with the last whole line written" in side["end_detail"]
    assert side["duration_s"] < 10.0                   # ended by the fault, not its duration
    check_whole_lines(paths.log, side["frames"])
    assert side["frames"] > log_room // 60           # the room left was used
    assert sum(side["frames_by_id"].values()) == side["frames"]
    assert sorted(p.name for p in paths.folder.iterdir()) == \
        ["run-00.json", "run-00.log", "run-01.json", "run-01.log"]


def test_a_disk_too_full_to_start_leaves_nothing_that_blocks_a_retry(tmp_path, disk):
    study = tmp_path / "study"
    with can.Bus(interface="virtual", channel="full-disk-start") as bus:
        record_trial(bus, study, "P01", "run-00", duration=0.05,
                     started=rig_heard("full-disk-start"))
        disk.fill(RESERVE_BYTES // 2)
        with pytest.raises(AcquisitionError, match="the disk is full"):
            record_trial(bus, study, "P01", "run-01", duration=1.0)
        assert sorted(p.name for p in (study / "P01").iterdir()) == ["run-00.json",
                                                                    "run-00.log"]
        disk.fill(None)
        assert record_trial(bus, study, "P01", "run-01", duration=0.05,
                            started=rig_heard("full-disk-start")).ended == "completed"


class Sender(threading.Thread):
    """Sends FzCell frames on a virtual channel until stopped."""

    def __init__(self, channel):
        super().__init__(daemon=True)
        self.channel = channel
        self.done = threading.Event()

    def run(self):
        with can.Bus(interface="virtual", channel=self.channel) as bus:
            k = 0
            while not self.done.is_set():
                for _ in range(50):
                    bus.send(can.Message(arbitration_id=0xC1, is_extended_id=False,
                                         data=bytes(7) + bytes([k % 256])))
                    k += 1
                time.sleep(0.005)


@pytest.mark.usefixtures("rig_heard_by_acquire")
def test_acquire_on_a_full_disk_exits_1_saying_what_is_kept(tmp_path, disk, capsys):
    study = tmp_path / "study"
    argv = ["acquire", "--study", str(study), "--subject", "P01", "--interface", "virtual",
            "--channel", "full-disk-cli", "--quiet"]
    assert main([*argv, "--trial", "run-00", "--duration", "0.1"]) == 0
    sender = Sender("full-disk-cli")
    sender.start()
    try:
        disk.fill(RESERVE_BYTES + 3_000 + 20_000)
        capsys.readouterr()
        code = main([*argv, "--trial", "run-01", "--duration", "20"])
    finally:
        sender.done.set()
        sender.join()
    err = capsys.readouterr().err
    assert code == 1, err
    assert "No space left on device; the log ends with the last whole line written" in err
    assert "P01/run-01: disk-error," in err and "Traceback" not in err
    paths = TrialPaths.of(study, "P01", "run-01")
    side = json.loads(paths.sidecar.read_text())
    assert side["ended"] == "disk-error"
    check_whole_lines(paths.log, side["frames"])


@pytest.mark.parametrize("command", ["acquire", "simulate"])
@pytest.mark.parametrize("room", [0, 1_000])
@pytest.mark.usefixtures("rig_heard_by_acquire")
def test_a_new_study_on_a_full_disk_leaves_nothing_that_blocks_a_retry(
        tmp_path, disk, capsys, command, room):
    """The DBC copy and study.toml are written whole or not at all: the retry, with room
    again, creates the study (it is not refused by a half-written DBC)."""
    study = tmp_path / "study"
    argv = {"acquire": ["acquire", "--study", str(study), "--subject", "P01", "--trial",
                        "run-01", "--interface", "virtual", "--channel", "full-disk-new",
                        "--duration", "0.1", "--quiet"],
            "simulate": ["simulate", "--study", str(study), "--subject", "P01", "--trial",
                         "run-01", "--duration", "0.5"]}[command]
    disk.fill(room)
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 1, err
    assert "No space left on device" in err and "Traceback" not in err
    assert not study.exists()
    disk.fill(None)
    assert main(argv) == 0, capsys.readouterr().err
    assert (study / "rig" / "default.dbc").read_bytes() == \
        default_rig_path().with_name("default.dbc").read_bytes()
    assert sorted(p.name for p in study.iterdir()) == ["P01", "rig", "study.toml"]
