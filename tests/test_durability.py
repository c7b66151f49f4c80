"""Nothing recorded is lost, nothing written is overwritten, raw logs are only read.

- SIGKILL mid-trial: the ``.log.part`` holds whole lines up to the last flush, is read as a
  candump log, and ``evtribo analyze`` analyses it with a warning in summary.json.
- A log that is no log at all is reported as a failed trial; the study's other trials are
  analysed.
- ``analyze``, ``compare``, ``report`` and ``decode`` refuse to overwrite without ``--force``.
- With the study read-only, ``analyze``, ``compare``, ``report``, ``inspect`` and ``decode``
  work, open the study's files only for reading, and leave their bytes and times unchanged.

(SIGTERM, the adapter vanishing, a full disk and a second ``acquire`` into a trial are in
``tests/acquisition``.)
"""

from __future__ import annotations

import builtins
import hashlib
import io
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import can
import pandas as pd
import pytest

import evtribo.acquisition.logger as logger_module
from _process import kill_and_reap
from evtribo.acquisition.logger import FLUSH_INTERVAL_S, LogWriter
from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_trial
from evtribo.canlog.io import read_frames, write_candump
from evtribo.canlog.rig import default_rig_path
from evtribo.cli import main

DBC = default_rig_path().with_name("default.dbc")

#: Streams a simulated trial in time-lapse on a virtual bus and records it with the code
#: ``evtribo acquire`` runs, until killed.
RECORDER = textwrap.dedent("""
    import sys, threading, uuid
    import can
    from evtribo.acquisition.simulator import Simulator, SubjectParams, TrialConfig
    from evtribo.acquisition.trial import TrialInfo, record_trial

    study = sys.argv[1]
    channel = uuid.uuid4().hex
    tx = can.Bus(interface="virtual", channel=channel, preserve_timestamps=True)
    rx = can.Bus(interface="virtual", channel=channel)
    config = TrialConfig(duration_s=60.0, amplitude_V=140.0, seed=5)
    sim = Simulator(SubjectParams(), config, speed=8.0)
    thread = threading.Thread(target=sim.run, args=(tx,), kwargs={"duration": 60.0},
                              daemon=True)
    info = TrialInfo(waveform="square", frequency_Hz=10000.0, amplitude_V=140.0,
                     condition="alternating")
    record_trial(rx, study, "P01", "run-01", duration=None, info=info, log_channel="vcan0",
                 started=lambda _paths: thread.start())
""")


def test_sigkill_mid_trial_then_analyze_uses_the_partial_trial(tmp_path):
    study = tmp_path / "study"
    part = study / "P01" / "run-01.log.part"
    proc = subprocess.Popen([sys.executable, "-c", RECORDER, str(study)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        # about 7 s of the trial (3,050 frames/s, 44 bytes a line): OFF, ON, OFF phases
        while not (part.exists() and part.stat().st_size > 950_000):
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, "the recorder wrote too little"
            time.sleep(0.05)
    finally:
        kill_and_reap(proc)
    assert proc.returncode == -signal.SIGKILL
    assert not (study / "P01" / "run-01.log").exists()
    sidecar = json.loads((study / "P01" / "run-01.json").read_text())
    assert sidecar["ended"] == "recording" and sidecar["log"] == "run-01.log.part"

    data = part.read_bytes()
    assert data.endswith(b"\n"), "a line cut in two"
    frames, report = read_frames(part)               # the registry reads .log.part as candump
    assert report.format == ".log" and report.skipped_lines == 0
    assert len(frames) == data.count(b"\n") > 20_000

    out = tmp_path / "results"
    assert main(["analyze", str(study), "--out", str(out), "--jobs", "1"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["trials_analysed"] == 1 and summary["failed_trials"] == []
    assert any("run-01.log.part" in w["text"] and w["kind"] == "log-partial"
               for w in summary["warnings"])
    trials = pd.read_csv(out / "trials.csv")
    assert trials.frames[0] == len(frames) and trials.skipped_lines[0] == 0
    assert trials.duration_s[0] > 5.0
    windows = pd.read_csv(out / "windows.csv")
    assert set(windows.condition) == {"on", "off"}
    assert part.read_bytes() == data                 # analysed, not touched


# --- a small real study: one subject, three amplitudes ------------------------------------

AMPLITUDES = (80.0, 110.0, 140.0)


def write_study(root: Path) -> None:
    """A study folder of simulated trials (6 s each), as ``evtribo acquire`` lays it out."""
    (root / "rig").mkdir(parents=True)
    (root / "rig" / "default.dbc").write_bytes(DBC.read_bytes())
    (root / "study.toml").write_text(
        'name = "durability"\n\n[rig]\ndbc = "rig/default.dbc"\nnormal_force = "FzCell.Fz"\n'
        'tangential_force = "FxCell.Fx"\nexcitation_enabled = "HvStatus.HvOn"\n'
        'excitation_amplitude = "HvStatus.HvAmp"\n', encoding="utf-8")
    (root / "P01").mkdir()
    for k, amp in enumerate(AMPLITUDES):
        frames, _ = simulate_trial(SubjectParams(),
                                   TrialConfig(duration_s=6.0, amplitude_V=amp, seed=k))
        write_candump(root / "P01" / f"run-{k + 1:02d}.log", frames)
        (root / "P01" / f"run-{k + 1:02d}.json").write_text(json.dumps(
            {"subject": "P01", "waveform": "square", "frequency_Hz": 10000,
             "amplitude_V": amp, "condition": "alternating"}), encoding="utf-8")


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    root = tmp_path_factory.mktemp("durability") / "study"
    write_study(root)
    return root


def snapshot(root: Path) -> dict[str, tuple[str, int, int]]:
    """SHA-256, mode and mtime (ns) of every file and folder under *root*."""
    out = {}
    for p in sorted([root, *root.rglob("*")]):
        st = p.stat()
        digest = hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "dir"
        out[os.fspath(p.relative_to(root))] = (digest, st.st_mode, st.st_mtime_ns)
    return out


def test_a_file_that_is_no_log_is_one_failed_trial_not_a_failed_study(tmp_path):
    bad = tmp_path / "study"
    write_study(bad)
    (bad / "P01" / "run-09.blf").write_bytes(b"")               # an empty binary log
    (bad / "P01" / "run-09.json").write_text('{"condition": "off"}')
    out = tmp_path / "results"
    assert main(["analyze", str(bad), "--out", str(out), "--jobs", "1"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["trials"] == 4 and summary["trials_analysed"] == 3
    [failed] = summary["failed_trials"]
    assert failed["trial"] == "P01/run-09" and "run-09.blf" in failed["error"]


def _outputs(folder: Path) -> dict[str, tuple[str, int, int]]:
    return {k: v for k, v in snapshot(folder).items() if k != "."}


def test_outputs_are_never_overwritten_without_force(study, tmp_path, capsys):
    out = tmp_path / "results"
    report = tmp_path / "report.html"
    decoded = tmp_path / "run-01.csv"
    log = study / "P01" / "run-01.log"
    runs = {
        "analyze": ["analyze", str(study), "--out", str(out), "--jobs", "1"],
        "compare": ["compare", str(out)],
        "report": ["report", str(out), "-o", str(report)],
        "decode": ["decode", str(log), "--dbc", str(DBC), "-o", str(decoded)],
    }
    for argv in runs.values():
        assert main(argv) == 0, capsys.readouterr().err
    assert (out / "fit.csv").exists() and any((out / "figures").iterdir())
    before = _outputs(tmp_path)
    capsys.readouterr()
    for name, argv in runs.items():
        assert main(argv) == 2, name
        err = capsys.readouterr().err
        assert "--force" in err and "Traceback" not in err, (name, err)
        assert _outputs(tmp_path) == before, f"{name} changed a file without --force"
    for name, argv in runs.items():
        assert main([*argv, "--force"]) == 0, name
    after = _outputs(tmp_path)
    for name in ("results/trials.csv", "results/fit.csv", "report.html", "run-01.csv"):
        assert after[name][2] > before[name][2], f"{name} not rewritten with --force"


class OpenRecorder:
    """Records how every file under a folder is opened (``open``, ``io.open``, ``os.open``)."""

    WRITE_FLAGS = os.O_WRONLY | os.O_RDWR | os.O_CREAT | os.O_TRUNC | os.O_APPEND

    def __init__(self, root: Path, monkeypatch: pytest.MonkeyPatch) -> None:
        self.root = os.path.realpath(root)
        self.reads: list[str] = []
        self.writes: list[tuple[str, str]] = []
        real_open, real_os_open = builtins.open, os.open

        def ours(file: object) -> str | None:
            if isinstance(file, int):
                return None
            path = os.path.realpath(os.fspath(file))  # type: ignore[arg-type]
            return path if path.startswith(self.root + os.sep) else None

        def open_(file, mode="r", *args, **kwargs):
            path = ours(file)
            if path is not None:
                if set(mode) & set("wax+"):
                    self.writes.append((path, mode))
                else:
                    self.reads.append(path)
            return real_open(file, mode, *args, **kwargs)

        def os_open(file, flags, *args, **kwargs):
            path = ours(file)
            if path is not None:
                if flags & self.WRITE_FLAGS:
                    self.writes.append((path, f"flags {flags:#o}"))
                else:
                    self.reads.append(path)
            return real_os_open(file, flags, *args, **kwargs)

        monkeypatch.setattr(builtins, "open", open_)
        monkeypatch.setattr(io, "open", open_)
        monkeypatch.setattr(os, "open", os_open)


def test_read_only_study_every_command_but_acquire_only_reads(study, tmp_path, monkeypatch,
                                                              capsys):
    ro = tmp_path / "ro-study"
    write_study(ro)
    for p in ro.rglob("*"):
        if p.is_file():
            p.chmod(0o444)
    for p in sorted([ro, *(d for d in ro.rglob("*") if d.is_dir())], reverse=True):
        p.chmod(0o555)
    before = snapshot(ro)
    rec = OpenRecorder(ro, monkeypatch)
    out, dec = tmp_path / "results", tmp_path / "decoded.parquet"
    log = ro / "P01" / "run-02.log"
    try:
        for argv in (["analyze", str(ro), "--out", str(out), "--jobs", "1"],
                     ["compare", str(out)],
                     ["report", str(out), "-o", str(tmp_path / "report.html")],
                     ["inspect", str(log), "--dbc", str(ro / "rig" / "default.dbc")],
                     ["decode", str(log), "--dbc", str(ro / "rig" / "default.dbc"),
                      "-o", str(dec)]):
            assert main(argv) == 0, (argv[0], capsys.readouterr().err)
    finally:
        for p in [ro, *ro.rglob("*")]:
            p.chmod(0o755 if p.is_dir() else 0o644)
    assert rec.writes == []
    logs = {os.path.realpath(p) for p in ro.glob("P01/*.log")}
    assert logs <= set(rec.reads), "the logs were not read through the recorded openers"
    after = snapshot(ro)
    for p in [ro, *ro.rglob("*")]:  # the modes were restored above; compare the rest
        key = os.fspath(p.relative_to(ro))
        assert after[key][0] == before[key][0] and after[key][2] == before[key][2], key
    assert set(after) == set(before), "files appeared in the study"


def test_the_log_reaches_the_disk_while_frames_keep_coming(tmp_path, monkeypatch):
    """The logger's writer makes each frame readable by another reader (as after a crash)
    without closing the file, and fsyncs them (so they survive a power cut) while frames
    keep coming: continuous traffic does not postpone the sync. Its interval is at most
    half a second; how soon a busy machine gets there is printed, not asserted."""
    assert FLUSH_INTERVAL_S <= 0.5
    synced = []
    real_fsync = os.fsync

    def fsync(fd):
        synced.append(time.monotonic())
        real_fsync(fd)

    monkeypatch.setattr(logger_module.os, "fsync", fsync)
    path = tmp_path / "run-01.log.part"
    fh = path.open("wb", buffering=0)
    writer = LogWriter(fh, "vcan0").start()
    deadline = time.monotonic() + 120.0  # ends a hang only
    try:
        t_first = time.monotonic()
        for k in range(3):
            msg = can.Message(timestamp=1763700000.0 + k, arbitration_id=0xC1,
                              is_extended_id=False, data=bytes(8))
            writer.put([msg])
            while path.read_bytes().count(b"\n") < k + 1:
                assert time.monotonic() < deadline, "never on disk"
                time.sleep(0.01)
        # continuous traffic (a frame every 20 ms) must not postpone the fsync
        k = 3
        while not synced and time.monotonic() < deadline:
            writer.put([can.Message(timestamp=1763700000.0 + k, arbitration_id=0xC1,
                                    is_extended_id=False, data=bytes(8))])
            k += 1
            time.sleep(0.02)
        assert synced, "no fsync while recording"
        print(f"first fsync {synced[0] - t_first:.3f} s after the first frame, "
              f"{k - 3} frames of traffic meanwhile")
    finally:
        writer.close()
        fh.close()
    assert len(read_frames(path)[0]) == k
