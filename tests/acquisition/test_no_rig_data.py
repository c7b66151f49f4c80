"""The wrong rig: when none of the rig's load-cell messages arrives within a few seconds,
the display says so, the trial ends as ``no-rig-data`` (exit 1) and its log is kept; a new
study made without ``--rig`` says which rig it assumed."""

from __future__ import annotations

import io
import json
import re
import threading
import time
from pathlib import Path

import can
import pytest

from evtribo.acquisition.live.monitor import Monitor, Snapshot, render_line, render_status
from evtribo.acquisition.logger import LogStats
from evtribo.acquisition.rigfile import default_rig_path, load_rig_toml
from evtribo.acquisition.trial import RIG_DATA_TIMEOUT_S, record_trial
from evtribo.cli import main

MOTOROLA = Path(__file__).parents[1] / "data" / "rigs" / "motorola.toml"


class Sender(threading.Thread):
    """Sends frames with identifiers *ids* on a virtual channel (FzCell's data, counting),
    after *lead* frames of another device (0x123), until stopped or, with *rounds*, that
    many rounds of *ids* (then :attr:`sent` is set)."""

    def __init__(self, channel, ids, lead=0, rounds=None):
        super().__init__(daemon=True)
        self.channel, self.ids, self.lead, self.rounds = channel, ids, lead, rounds
        self.done = threading.Event()
        self.sent = threading.Event()
        self.bus = can.Bus(interface="virtual", channel=channel)

    def run(self):
        for k in range(self.lead):
            self.bus.send(can.Message(arbitration_id=0x123, is_extended_id=False,
                                      data=bytes([k % 256])))
        k = 0
        while not self.done.is_set() and (self.rounds is None or k < self.rounds):
            for ident in self.ids:
                self.bus.send(can.Message(arbitration_id=ident, is_extended_id=ident > 0x7FF,
                                          data=bytes(7) + bytes([k % 256])))
            k += 1
            time.sleep(0.002)
        self.sent.set()

    def __enter__(self):
        self.start()
        return self

    def __exit__(self, *exc):
        self.done.set()
        self.join()
        self.bus.shutdown()


def test_the_timeout_is_a_named_constant_of_a_few_seconds():
    assert 1.0 <= RIG_DATA_TIMEOUT_S <= 5.0


@pytest.mark.parametrize(("ids", "lead", "ended"), [
    ((0x123, 0x18FF0001), 0, "no-rig-data"),   # traffic, none of it the rig's
    ((0x0C2,), 0, "completed"),                # the tangential cell alone will do
    ((0x0C1, 0x123), 300, "completed"),        # the rig, after another device's frames
])
def test_a_trial_without_the_rigs_frames_ends_as_no_rig_data(tmp_path, ids, lead, ended):
    """The trial lasts longer than the time allowed for the rig's frames: one without them
    ends as no-rig-data when that time is up (not as completed at its end, however late a
    busy machine checks), one with them runs until its source is done (the senders begin as
    the trial does; the times allowed that are not the subject, 60 s, guard against a hang
    only)."""
    channel = f"no-rig-{ids[0]}-{lead}"
    rig = ended != "no-rig-data"
    sender = Sender(channel, ids, lead, rounds=500 if rig else None)
    try:
        with can.Bus(interface="virtual", channel=channel) as bus:
            result = record_trial(bus, tmp_path / "s", "P01", "run-01",
                                  duration=None if rig else 60.0,
                                  rig_data_timeout=60.0 if rig else 0.8,
                                  until=sender.sent.is_set if rig else None,
                                  started=lambda _paths: sender.start())
    finally:
        sender.done.set()
        sender.join(60)
        sender.bus.shutdown()
    side = json.loads((tmp_path / "s" / "P01" / "run-01.json").read_text())
    assert (result.ended, side["ended"]) == (ended, ended)
    assert result.exit_code == (1 if ended == "no-rig-data" else 0)
    log = tmp_path / "s" / "P01" / "run-01.log"
    assert len(list(can.LogReader(log))) == side["frames"] > 0   # the log is kept
    if ended == "no-rig-data":
        assert side["duration_s"] < 60.0                        # it did not run its 60 s
        assert "FzCell (0x0C1), FxCell (0x0C2)" in side["end_detail"]
        assert "0.8 s" in side["end_detail"]


def test_a_trial_shorter_than_the_wait_without_the_rig_is_not_completed(tmp_path, capsys):
    """A trial over before the rig's time is up, that heard nothing of the rig (a misspelt
    study beside the real one, a silent bus): no-rig-data and exit 1, never "completed"."""
    argv = ["acquire", "--study", str(tmp_path / "s"), "--subject", "P01", "--trial",
            "run-01", "--interface", "virtual", "--channel", "short-silent", "--duration",
            "0.3", "--quiet"]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "P01/run-01: no-rig-data, 0 frames" in err
    assert re.search(r"none of the rig's load-cell messages \(FzCell \(0x0C1\), FxCell "
                     r"\(0x0C2\)\) arrived within [\d.]+ s", err), err
    side = json.loads((tmp_path / "s" / "P01" / "run-01.json").read_text())
    assert side["ended"] == "no-rig-data" and side["frames"] == 0


def test_acquire_with_the_wrong_rig_says_so_and_exits_1(tmp_path, capsys):
    """The study's DBC is another rig's (extended NormalCell...), the bus carries the
    default rig's FzCell/FxCell: the display's line says so, exit 1, not "completed"."""
    study = tmp_path / "study"
    with Sender("wrong-rig", (0x0C1, 0x0C2)):
        code = main(["acquire", "--study", str(study), "--subject", "P01", "--trial",
                     "run-01", "--interface", "virtual", "--channel", "wrong-rig",
                     "--duration", "20", "--rig", str(MOTOROLA), "--tare-s", "0"])
    out, err = capsys.readouterr()
    assert code == 1, err
    assert "NO DATA FROM THE RIG: no NormalCell (0x" in out and "TangentialCell" in out
    assert "error: none of the rig's load-cell messages (NormalCell" in err
    assert "P01/run-01: no-rig-data," in err
    assert "has no study.toml" not in err                     # --rig was given
    side = json.loads((study / "P01" / "run-01.json").read_text())
    assert side["ended"] == "no-rig-data" and side["frames"] > 100
    assert side["duration_s"] < 20                     # ended before its --duration


@pytest.mark.usefixtures("rig_heard_by_acquire")
def test_a_new_study_without_rig_says_which_rig_it_assumed(tmp_path, capsys):
    study = tmp_path / "study"
    argv = ["acquire", "--study", str(study), "--subject", "P01", "--interface", "virtual",
            "--channel", "default-rig-line", "--duration", "0.1", "--quiet"]
    assert main([*argv, "--trial", "run-01"]) == 0
    err = capsys.readouterr().err
    assert (f"evtribo acquire: {study} has no study.toml: it is made for the default rig, "
            f"{default_rig_path()}: FzCell (0x0C1): normal_force; FxCell (0x0C2): "
            "tangential_force; HvStatus (0x1A0): excitation_enabled") in err
    assert main([*argv, "--trial", "run-02"]) == 0            # an existing study: no word
    assert "default rig" not in capsys.readouterr().err
    assert main(["simulate", "--study", str(tmp_path / "sim"), "--duration", "0.5"]) == 0
    assert "has no study.toml: it is made for the default rig" in capsys.readouterr().err


def test_the_display_shows_the_alert_on_a_terminal_and_in_its_line():
    snap = Snapshot(elapsed_s=3.2, alert="NO DATA FROM THE RIG: no FzCell")
    assert render_status(snap, target=0.5)[-1] == "NO DATA FROM THE RIG: no FzCell"
    assert "\x1b[31mNO DATA FROM THE RIG" in render_status(snap, colour=True)[-1]
    assert render_line(snap).endswith("NO DATA FROM THE RIG: no FzCell")
    assert "NO DATA" not in "".join(render_status(Snapshot(elapsed_s=3.2)))


@pytest.mark.parametrize("rig_frames", [False, True])
def test_the_monitor_raises_the_alert_only_without_the_rigs_frames(rig_frames):
    rig = load_rig_toml(default_rig_path())
    out = io.StringIO()
    mon = Monitor(rig, out, duration=10.0, tty=False, rig_data_timeout=3.0)
    stats = LogStats()
    if rig_frames:
        stats.latest[0x0C2] = can.Message(arbitration_id=0x0C2, data=bytes(8))
    mon.start(stats, time.monotonic() - 1.0)
    assert mon.snapshot().alert == ""                          # not yet
    mon._t0 -= 2.5
    alert = mon.snapshot().alert
    assert bool(alert) != rig_frames
    mon.stop()                                                 # a pipe: a last line, if alert
    assert ("NO DATA FROM THE RIG: no FzCell (0x0C1) or FxCell (0x0C2) frame in 3 s"
            in out.getvalue()) != rig_frames


@pytest.mark.usefixtures("rig_heard_by_acquire")
def test_a_misspelt_study_beside_the_one_meant_is_refused_unless_a_new_one_is_asked_for(
        tmp_path, capsys):
    """``--study my-stuyd`` beside my-study: "did you mean", exit 2, nothing made; with
    --new-study, or with no similar study beside it, the new study is made."""
    base = ["--subject", "P01", "--trial", "run-01", "--interface", "virtual", "--channel",
            "misspelt", "--duration", "0.1", "--quiet"]
    assert main(["simulate", "--study", str(tmp_path / "my-study"), "--duration", "1"]) == 0
    capsys.readouterr()
    assert main(["acquire", "--study", str(tmp_path / "my-stuyd"), *base]) == 2
    err = capsys.readouterr().err
    assert f"did you mean {tmp_path / 'my-study'}, the study beside it?" in err
    assert "--new-study" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["my-study"]
    assert main(["acquire", "--study", str(tmp_path / "my-stuyd"), *base, "--new-study"]) == 0
    assert (tmp_path / "my-stuyd" / "study.toml").is_file()
    assert main(["acquire", "--study", str(tmp_path / "pilot"), *base]) == 0  # nothing like it
    assert (tmp_path / "pilot" / "P01" / "run-01.json").is_file()

