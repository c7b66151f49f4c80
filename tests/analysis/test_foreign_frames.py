"""Frames that share a load cell's ID but are not its message (CAN FD frames on a classic
cell's ID) change no result: they are counted with the frames the DBC does not describe,
and the warnings in summary.json name them."""

from __future__ import annotations

import json

import pandas as pd

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_study
from evtribo.results.pipeline import analyze_study


def _with_fd_frames(log, every: int = 50) -> int:
    """Insert, after every *every*-th line, a CAN FD frame (``##1``, 12 bytes) on the normal
    cell's ID with other data; return how many."""
    lines = log.read_text(encoding="ascii").splitlines(keepends=True)
    out, n = [], 0
    for i, line in enumerate(lines):
        out.append(line)
        if i % every == 25 and line.startswith("("):
            stamp, channel, _ = line.split(" ", 2)
            out.append(f"{stamp} {channel} 0C1##1{(i * 7919) % 2**96:024X}\n")
            n += 1
    log.write_text("".join(out), encoding="ascii")
    return n


def test_fd_frames_on_a_cells_id_change_no_result_and_are_named(tmp_path):
    study = tmp_path / "study"
    simulate_study(study, [SubjectParams(name="P01")], amplitudes=(80.0,),
                   config=TrialConfig(duration_s=6.0, tare_s=1.0), sine_trial=False)
    clean = analyze_study(study, tmp_path / "clean", jobs=1, cache_dir=tmp_path / "c1")
    logs = sorted(study.rglob("*.log"))
    added = {log.stem: _with_fd_frames(log) for log in logs}
    fd = analyze_study(study, tmp_path / "fd", jobs=1, cache_dir=tmp_path / "c2")
    a = clean.trials.set_index("trial")
    b = fd.trials.set_index("trial")
    assert all(added.values())
    pd.testing.assert_series_equal(a.dropped_frames, b.dropped_frames)
    pd.testing.assert_series_equal(a.frames, b.frames)  # the frames decoded
    pd.testing.assert_frame_equal(clean.electrostatic, fd.electrostatic)
    summary = json.loads((tmp_path / "fd" / "summary.json").read_text(encoding="utf-8"))
    said = " ".join(" ".join(w["text"] for w in summary["warnings"]).split())
    for stem, n in added.items():
        assert f"{n} CAN FD frames have the standard (11-bit) ID 0x0C1 of the DBC's classic " \
               "CAN message FzCell" in said, stem
