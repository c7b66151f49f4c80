"""Recorded traces replayed through a kernel's CAN stack: can-utils' ``canplayer`` plays a
trial's log into a vcan interface at its frames' times, ``evtribo acquire --interface
socketcan`` records it (and ``candump -L`` beside it) until Ctrl-C once the trace is played.
Every frame must be in the log, in order, with the kernel's times (candump's, to the
microsecond), none dropped (by the socket's queue or before it); and the recorded trial must
be analysed like the trace (F_el within 2 %: the kernel's times carry this busy machine's
scheduling, canplayer sending in bursts when it falls behind, not the trace's).

The traces of the rig at its full rate are a trial of ``data/vcan-traces`` (the reference
study recorded through vcan0) and one of the reference study itself. Held-out traces are
replayed the same way: every trial of each study folder in ``EVTRIBO_REPLAY_STUDIES``
(folders separated by ``:``). The analysis runs on the host (``_socketcan.on_host``)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from _socketcan import (
    DATA,
    HANG_S,
    Candump,
    evtribo,
    frames_of,
    kernel_drops,
    on_host,
    playing,
    stop_when_dumped,
    times_of,
    unzip,
)
from evtribo.study import load_study

pytestmark = pytest.mark.slow

#: Seconds the recording may go on beyond LONGEST_S times the trace's span; it is ended by
#: Ctrl-C once every frame of the trace is on the bus.
SPARE_S = 60.0
#: The longest canplayer may take, in multiples of the trace's span (in a busy machine's VM,
#: a 10-12 s trace took 44-70 s from the recording's start to canplayer's end).
LONGEST_S = 10.0


def _traces() -> list[tuple[Path, str, str]]:
    found = [(DATA / "vcan-traces" / "study", "P01", "run-05"),
             (DATA / "reference-study", "P02", "run-03")]
    for folder in filter(None, os.environ.get("EVTRIBO_REPLAY_STUDIES", "").split(":")):
        study = load_study(folder, with_rig=False)
        found += [(Path(folder), t.subject, t.name) for t in study.trials]
    return found


def _study_like(source: Path, to: Path) -> Path:
    """An empty study with the rig of *source* (its study.toml and DBC)."""
    study = load_study(source)
    assert study.rig is not None
    dbc = Path(study.rig.dbc).resolve()
    assert dbc.is_relative_to(source.resolve()), f"{dbc}: a DBC outside {source}"
    to.mkdir(parents=True)
    shutil.copy2(source / "study.toml", to / "study.toml")
    (to / dbc.relative_to(source.resolve())).parent.mkdir(parents=True, exist_ok=True)
    shutil.copy2(dbc, to / dbc.relative_to(source.resolve()))
    return to


def _trial(source: Path, subject: str, trial: str):
    return next(t for t in load_study(source, with_rig=False).trials
                if (t.subject, t.name) == (subject, trial))


def _metadata(sidecar: dict) -> list[str]:
    args = []
    for key, flag in (("waveform", "--waveform"), ("frequency_Hz", "--frequency"),
                      ("amplitude_V", "--amplitude"), ("condition", "--condition")):
        if sidecar.get(key) is not None:
            args += [flag, str(sidecar[key])]
    return args


def _analysed_like_the_trace(exports: Path) -> None:
    """On the host: the recorded trial's F_el within 2 % of the trace's."""
    from evtribo.results.pipeline import compute_study

    what = json.loads((exports / "replay.json").read_text())
    source, subject, trial = Path(what["source"]), what["subject"], what["trial"]
    ref = _trial(source, subject, trial)
    original = _study_like(source, exports / "original")
    (original / subject).mkdir()
    for path in filter(None, (ref.log_path, ref.sidecar_path)):
        shutil.copy2(path, original / subject / path.name)
    recorded = exports / "recorded"

    def fel(study: Path) -> dict[tuple, float]:
        el = compute_study(study, jobs=1, cache_dir=exports / f"cache-{study.name}")
        return {(r.subject, r.waveform, r.amplitude_V): r.electrostatic_force_N
                for r in el.electrostatic.itertuples()}

    want, have = fel(original), fel(recorded)
    assert want.keys() == have.keys() and want, "no F_el: no steady-sliding window"
    for key, value in want.items():
        assert have[key] == pytest.approx(value, rel=0.02), key


@on_host(after=_analysed_like_the_trace)
@pytest.mark.parametrize("trace", _traces(), ids=lambda t: f"{t[0].name}/{t[1]}/{t[2]}")
def test_a_trace_replayed_into_vcan_is_logged_whole_in_order_with_kernel_times(
        tmp_path, vcan, exports, trace):
    source, subject, trial = trace
    ref = _trial(source, subject, trial)
    log = unzip(ref.log_path, tmp_path) if ref.log_path.suffix == ".gz" else ref.log_path
    lines = log.read_text().splitlines()
    channel = lines[0].split()[1]
    times = [float(t.strip("()")) for t in times_of(lines)]
    side = json.loads(ref.sidecar_path.read_text()) if ref.sidecar_path else {}

    recorded = _study_like(source, exports / "recorded")
    candump = Candump(vcan, tmp_path / "candump.log", count=len(lines))
    before = kernel_drops(vcan)
    proc = evtribo(["acquire", "--study", str(recorded), "--subject", subject, "--trial",
                    trial, "--interface", "socketcan", "--channel", vcan, "--log-channel",
                    channel, "--tare-s", "0", "--duration",
                    f"{max(LONGEST_S * (times[-1] - times[0]) + SPARE_S, HANG_S):.1f}",
                    *_metadata(side)],
                   tmp_path / "acquire.out", setup=playing(log, vcan, from_channel=channel))
    stop_when_dumped(candump, proc)  # Ctrl-C once every frame of the trace is on the bus
    assert proc.wait(SPARE_S + HANG_S) == 0, proc.output()
    dumped = candump.stop()
    assert kernel_drops(vcan) == before  # none lost before a socket
    (exports / "replay.json").write_text(json.dumps(
        {"source": str(source), "subject": subject, "trial": trial}))

    got = (recorded / subject / f"{trial}.log").read_text().splitlines()
    assert frames_of(got) == frames_of(lines)          # every frame, in order
    assert frames_of(dumped) == frames_of(lines)       # (candump too)
    assert times_of(got) == times_of(dumped)           # the kernel's times, to the µs
    new = json.loads((recorded / subject / f"{trial}.json").read_text())
    assert new["ended"] == "interrupted" and new["frames"] == len(lines)  # by Ctrl-C
    assert new["queue_dropped_frames"] == 0 and new["discarded_before_start"] == 0
    if "dropped_frames" in side:  # the trace's own lost frames, found again by the counters
        assert new["dropped_frames"] == side["dropped_frames"]
