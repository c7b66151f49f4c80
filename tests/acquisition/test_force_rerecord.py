"""A trial recorded again over itself (``acquire --force``) never loses the one recorded
before: the old trial (a complete log, or the ``.log.part`` of a recording that was killed,
and its sidecar) stays as it was until the new one has frames of the rig and is whole, and
stays for good when the new one fails or is stopped before any. Killed at any step, the
study holds one whole recording of the trial, the old one or the new one, and reads it."""

from __future__ import annotations

import json
import multiprocessing
import os
import shutil
import signal
import threading
import time
from pathlib import Path

import can
import pytest

from evtribo.acquisition.replace import finish
from evtribo.acquisition.trial import TrialInfo, TrialPaths, record_trial
from evtribo.canlog.rig import default_rig
from evtribo.cli import main
from evtribo.documents.replacing import stages
from evtribo.study import discover_trials

FORK = multiprocessing.get_context("fork")
FZ, FX = (default_rig().database.get_message_by_name(m) for m in ("FzCell", "FxCell"))


def cell_frames(n: int, start: float) -> list[can.Message]:
    """*n* frames of the default rig's two load cells, 1 ms apart from *start* (s)."""
    out = []
    for k in range(n):
        msg, signals = (FZ, {"Fz": 0.5, "FzStatus": 0, "FzTemp": 25, "FzCounter": k // 2 % 256}
                        ) if k % 2 == 0 else (FX, {"Fx": 0.2, "FxStatus": 0, "FxTemp": 25,
                                                   "FxCounter": k // 2 % 256})
        out.append(can.Message(timestamp=start + k * 5e-4, arbitration_id=msg.frame_id,
                               is_extended_id=False, data=msg.encode(signals)))
    return out


class Cells(threading.Thread):
    """Sends the load cells' frames on a virtual channel (*n* of them, or until stopped),
    each stamped with its time on the bus."""

    def __init__(self, channel: str, n: int | None) -> None:
        super().__init__(daemon=True)
        self.channel, self.n = channel, n
        self.done = threading.Event()

    def run(self) -> None:
        with can.Bus(interface="virtual", channel=self.channel, preserve_timestamps=True) as bus:
            k = 0
            while self.n is None or k < self.n:
                for msg in cell_frames(200, time.time()):
                    bus.send(msg)
                k += 200
                time.sleep(0.001)
        self.done.set()


def record(study: Path, channel: str, n: int | None, notes: str, *, force: bool) -> object:
    """Record P01/run-01 from the load cells on *channel* (*n* frames, or until killed)."""
    cells = Cells(channel, n)
    with can.Bus(interface="virtual", channel=channel) as bus:
        return record_trial(bus, study, "P01", "run-01", duration=None, force=force,
                            info=TrialInfo(notes=notes), log_channel="vcan0",
                            until=cells.done.is_set,
                            started=lambda _paths: cells.start())


def _record_until_killed(study: Path) -> None:
    record(study, "force_killed_old", None, "old", force=False)


def killed_recording(study: Path) -> None:
    """What a recording killed with SIGKILL leaves: ``run-01.log.part``, holding frames,
    and the sidecar it began with (``"ended": "recording"``)."""
    part = study / "P01" / "run-01.log.part"
    child = FORK.Process(target=_record_until_killed, args=(study,))
    child.start()
    deadline = time.monotonic() + 120
    while not (part.exists() and part.stat().st_size > 100_000):
        assert child.is_alive() and time.monotonic() < deadline, "the recorder wrote nothing"
        time.sleep(0.02)
    os.kill(child.pid, signal.SIGKILL)
    child.join()
    side = json.loads((study / "P01" / "run-01.json").read_text())
    assert side["ended"] == "recording" and side["log"] == "run-01.log.part"


def old_trial(study: Path, kind: str) -> dict[str, bytes]:
    """The trial recorded first (*kind*: ``complete``, or ``killed`` mid-recording), its
    files' bytes by name."""
    if kind == "killed":
        killed_recording(study)
    else:
        record(study, f"force_old_{os.getpid()}", 2000, "old", force=False)
    folder = study / "P01"
    return {p.name: p.read_bytes() for p in folder.iterdir()
            if p.name.startswith("run-01.") and p.name != "run-01.lock"}


def the_trial(study: Path) -> tuple[bytes, dict]:
    """The trial as the study reads it: its log's bytes and its sidecar."""
    trials, _ = discover_trials(study)
    (trial,) = trials
    assert trial.sidecar_path is not None
    return trial.log_path.read_bytes(), json.loads(trial.sidecar_path.read_text())


def is_old(study: Path, old: dict[str, bytes]) -> bool:
    log, side = the_trial(study)
    logs = [v for k, v in old.items() if ".log" in k]
    return log in logs and side == json.loads(old["run-01.json"])


def is_new_and_whole(study: Path) -> bool:
    log, side = the_trial(study)
    return (side.get("notes") == "new" and side["ended"] == "completed"
            and side["frames"] == log.count(b"\n") > 0 and side["log"] == "run-01.log")


@pytest.mark.parametrize("kind", ["killed", "complete"])
def test_a_forced_trial_that_receives_nothing_keeps_the_one_recorded_before(tmp_path, kind,
                                                                             capsys):
    """``acquire --force`` on a bus where nobody sends: exit 1 after 3 s, and the trial
    recorded before (a killed recording's 100 kB of frames, or a complete one) is there,
    byte for byte, as the message says; nothing of the new one is left."""
    study = tmp_path / "ST"
    before = old_trial(study, kind)
    code = main(["acquire", "--study", str(study), "--subject", "P01", "--trial", "run-01",
                 "--force", "--interface", "virtual", "--channel", "nobody", "--duration", "3",
                 "--quiet"])
    err = capsys.readouterr().err
    assert code == 1
    after = {p.name: p.read_bytes() for p in (study / "P01").iterdir()}
    assert after == before  # nor the killed recording's lock and reserve: cleared
    assert is_old(study, before)
    assert "the trial recorded before is, as it was" in err
    assert all(str(study / "P01" / name) in err for name in sorted(before))


def test_a_forced_trial_stopped_before_the_rig_is_heard_keeps_the_one_recorded_before(
        tmp_path):
    """Ctrl-C (a stop) before any frame of the rig's load cells, only another device's
    frames received: the trial recorded before stays (it was replaced by an empty log)."""
    study = tmp_path / "ST"
    before = old_trial(study, "complete")
    stop = threading.Event()
    with can.Bus(interface="virtual", channel="force_stopped") as bus, \
            can.Bus(interface="virtual", channel="force_stopped") as other:
        def started(_paths):
            other.send(can.Message(arbitration_id=0x300, data=bytes(8)))
            stop.set()
        result = record_trial(bus, study, "P01", "run-01", duration=30.0, force=True,
                              should_stop=stop.is_set, started=started)
    assert (result.ended, result.exit_code, result.kept_previous) == ("interrupted", 0, True)
    assert {p.name: p.read_bytes() for p in (study / "P01").iterdir()} == before


@pytest.mark.parametrize("kind", ["killed", "complete"])
def test_a_forced_trial_that_records_replaces_the_one_recorded_before(tmp_path, kind):
    study = tmp_path / "ST"
    old_trial(study, kind)
    result = record(study, "force_new", 1000, "new", force=True)
    assert result.ended == "completed" and not result.kept_previous
    assert sorted(p.name for p in (study / "P01").iterdir()) == ["run-01.json", "run-01.log"]
    assert is_new_and_whole(study)


def _rerecord_until_killed(study: Path) -> None:
    record(study, "force_killed_new", None, "new", force=True)


def test_a_re_recording_killed_mid_way_is_kept_beside_the_trial_and_said(tmp_path):
    """``kill -9`` of a forced re-recording: the trial is still the one recorded before,
    and what the new one received stays beside it, said by the study's reader, until a
    re-recording finishes."""
    study = tmp_path / "ST"
    before = old_trial(study, "complete")
    child = FORK.Process(target=_rerecord_until_killed, args=(study,))
    child.start()
    deadline = time.monotonic() + 120
    while not any((s / "run-01.log.part").exists()
                  and (s / "run-01.log.part").stat().st_size > 50_000
                  for s in stages(study / "P01").get("run-01", [])):
        assert child.is_alive() and time.monotonic() < deadline, "the recorder wrote nothing"
        time.sleep(0.02)
    os.kill(child.pid, signal.SIGKILL)
    child.join()
    assert is_old(study, before)
    (stage,) = stages(study / "P01")["run-01"]
    assert json.loads((stage / "run-01.json").read_text())["notes"] == "new"
    _, warnings = discover_trials(study)
    assert any(str(stage) in w.text and w.kind == "rerecording-unfinished" for w in warnings)
    assert record(study, "force_after_killed", 1000, "new", force=True).ended == "completed"
    assert is_new_and_whole(study) and not stages(study / "P01")


# --- killed at every step ------------------------------------------------------------------

_STEPS = ("replace", "rename", "unlink", "rmdir", "fsync", "mkdir")


def _rerecord_killed_at(study: Path, stop_at: int | None, counted) -> None:
    """Record the trial again with --force, SIGKILLed at the *stop_at*-th change of a file
    or folder (or a flush to the disk); *counted* gets how many there were."""
    count = [0]

    def wrap(owner, name):
        real = getattr(owner, name)

        def step(*args, **kwargs):
            count[0] += 1
            if count[0] == stop_at:
                os.kill(os.getpid(), signal.SIGKILL)
            return real(*args, **kwargs)
        setattr(owner, name, step)

    for name in _STEPS:
        wrap(os, name)
    for name in ("unlink", "rmdir", "replace", "rename"):
        wrap(Path, name)
    record(study, f"force_step_{os.getpid()}", 1000, "new", force=True)
    counted.value = count[0]


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["killed", "complete"])
def test_killed_at_any_step_the_trial_is_the_old_one_or_the_new_one(tmp_path, kind):
    origin = tmp_path / "origin"
    before = old_trial(origin, kind)
    counted = FORK.Value("i", 0)
    dry = tmp_path / "dry"
    shutil.copytree(origin, dry)
    child = FORK.Process(target=_rerecord_killed_at, args=(dry, None, counted))
    child.start()
    child.join(120)
    assert child.exitcode == 0 and is_new_and_whole(dry)
    outcomes = set()
    for stop_at in range(1, counted.value + 2):
        study = tmp_path / f"k{stop_at}"
        shutil.copytree(origin, study)
        child = FORK.Process(target=_rerecord_killed_at, args=(study, stop_at, counted))
        child.start()
        child.join(120)
        assert child.exitcode in (0, -signal.SIGKILL)
        old = is_old(study, before)
        assert old or is_new_and_whole(study), stop_at   # one whole recording, read
        outcomes.add("old" if old else "new")
        # what the next recording of the trial finds first: the trial as it was read
        paths = TrialPaths.of(study, "P01", "run-01")
        finish(paths.folder, "run-01")
        assert is_old(study, before) if old else is_new_and_whole(study), stop_at
        left = [s for found in stages(paths.folder).values() for s in found]
        assert not old or not any((s / ".evtribo-commit").exists() for s in left)
        if not old:  # nothing of the old trial nor of the re-recording left beside it (a
            # killed process's lock and reserved space: cleared by the next recording)
            assert sorted(p.name for p in paths.folder.iterdir() if p.name.startswith(
                ("run-01.", ".run-01.evtribo-new-")) and p != paths.lock) == \
                ["run-01.json", "run-01.log"]
    assert outcomes == {"old", "new"}


def test_a_session_finishes_a_replacement_cut_short_before_it_looks_at_the_trial(tmp_path):
    """A re-recording made the trial, killed before its files were moved: the session's
    look at the trial's files (to set a leftover aside) sees the new trial, whole, in the
    subject's folder, and nothing of the old one."""
    from evtribo.session.trialfiles import trial_files

    study = tmp_path / "ST"
    old_trial(study, "killed")
    folder = study / "P01"
    stage = folder / ".run-01.evtribo-new-abcd1234"
    stage.mkdir()
    (stage / "run-01.log").write_text("(1.000000) vcan0 0C1#00\n")
    (stage / "run-01.json").write_text(json.dumps(
        {"subject": "P01", "notes": "new", "ended": "completed", "frames": 1,
         "log": "run-01.log"}))
    (stage / ".evtribo-commit").touch()
    assert is_new_and_whole(study)                  # what the study reads meanwhile
    assert [p.name for p in trial_files(folder, "run-01")] == ["run-01.json", "run-01.log"]
    assert is_new_and_whole(study) and not stages(folder)
    assert not (folder / "run-01.log.part").exists()
