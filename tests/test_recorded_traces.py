"""The recorded reference study in ``data/`` (made by ``scripts/record_traces.py``).

- replayed through python-can's ``virtual`` bus into the acquisition, a recorded log comes
  back frame for frame;
- analysed, it gives back what the simulator was given (``truth.json``).
"""

import hashlib
import json
import threading
from pathlib import Path

import can
import numpy as np
import pandas as pd
import pytest

from _checks import fel_ok
from evtribo.acquisition.buses.bus import BusSettings
from evtribo.acquisition.trial import TrialInfo, record_trial
from evtribo.canlog.dropped import missing_frames
from evtribo.canlog.io import read_frames
from evtribo.fit.tables import read_results
from evtribo.report.compare import compare
from evtribo.report.study_report import build_report
from evtribo.results.pipeline import SINE_TRACE_FILE, analyze_study
from evtribo.study import load_study

STUDY = Path(__file__).resolve().parents[1] / "data" / "reference-study"
TRUTH = json.loads((STUDY / "truth.json").read_text(encoding="utf-8"))


def test_the_study_is_small_compressed_and_on_vcan0():
    files = [p for p in STUDY.rglob("*") if p.is_file()]
    assert sum(p.stat().st_size for p in files) < 15e6
    study = load_study(STUDY)
    assert len(study.trials) == 18 and study.subjects == ["P01", "P02", "P03"]
    assert all(t.log_path.name.endswith(".log.gz") for t in study.trials)
    assert not list(STUDY.rglob("*.log"))
    sidecar = json.loads((STUDY / "P02" / "run-03.json").read_text(encoding="utf-8"))
    assert sidecar["log_channel"] == "vcan0" and sidecar["ended"] == "completed"
    assert sidecar["log"] == "run-03.log.gz"
    frames, report = read_frames(STUDY / "P02" / "run-03.log.gz")
    assert frames.channel == "vcan0" and report.skipped_lines == 0
    assert len(frames) == sidecar["frames"]
    # the rig's counters are named, so the analysis counts missing frames by them
    assert "normal_force_counter" in (STUDY / "study.toml").read_text(encoding="utf-8")


def test_a_recorded_log_replays_through_the_virtual_bus_frame_for_frame(tmp_path):
    original, _ = read_frames(STUDY / "P01" / "run-06.log.gz")
    channel = "replay-recorded-traces"
    rx = can.Bus(interface="virtual", channel=channel)
    tx = can.Bus(interface="virtual", channel=channel, preserve_timestamps=True)
    done = threading.Event()

    def play() -> None:
        for i in range(len(original)):
            dlc = int(original.dlc[i])
            tx.send(can.Message(
                timestamp=float(original.timestamp[i]),
                arbitration_id=int(original.arbitration_id[i]),
                is_extended_id=bool(original.is_extended[i]),
                is_remote_frame=bool(original.is_remote[i]),
                is_error_frame=bool(original.is_error[i]), dlc=dlc,
                data=original.data[i, :dlc].tobytes()))
        done.set()

    player = threading.Thread(target=play, daemon=True)
    try:
        result = record_trial(
            rx, tmp_path / "replay", "P01", "run-06", duration=None,
            info=TrialInfo(waveform="sine", frequency_Hz=10.0, amplitude_V=140.0,
                           condition="alternating"),
            settings=BusSettings(interface="virtual", channel=channel), log_channel="vcan0",
            should_stop=lambda: done.is_set() and rx.queue.empty(),
            started=lambda _paths: player.start())
        player.join(5)
    finally:
        rx.shutdown()
        tx.shutdown()
    assert result.exit_code == 0
    copy, report = read_frames(result.paths.log)
    assert report.skipped_lines == 0
    assert len(copy) == len(original) == result.sidecar["frames"]
    np.testing.assert_array_equal(copy.arbitration_id, original.arbitration_id)
    np.testing.assert_array_equal(copy.is_extended, original.is_extended)
    np.testing.assert_array_equal(copy.dlc, original.dlc)
    np.testing.assert_array_equal(copy.data, original.data)
    np.testing.assert_allclose(copy.timestamp, original.timestamp, rtol=0, atol=1e-6)
    assert copy.channel == "vcan0"
    # the counters of the replayed log show the same frames missing as the original's
    assert result.sidecar["dropped_frames_by_message"] == json.loads(
        (STUDY / "P01" / "run-06.json").read_text(encoding="utf-8"))["dropped_frames_by_message"]


@pytest.fixture(scope="module")
def analysed(tmp_path_factory):
    out = tmp_path_factory.mktemp("out")
    return analyze_study(STUDY, out, jobs=2, cache_dir=tmp_path_factory.mktemp("cache"),
                         force=True)


def test_the_analysis_recovers_what_the_simulator_was_given(analysed):
    el, trials = analysed.electrostatic, analysed.trials
    assert len(el) == 3 * 6
    for key, truth in TRUTH["trials"].items():
        subject, trial = key.split("/")
        row = el[(el.subject == subject) & (el.waveform == truth["waveform"])
                 & (el.amplitude_V == truth["amplitude_V"])]
        assert len(row) == 1, key
        row = row.iloc[0]
        assert row.mu == pytest.approx(truth["mu"], rel=0.02), key
        assert fel_ok(row.electrostatic_force_N, truth["electrostatic_force_N"]), (
            key, row.electrostatic_force_N, truth["electrostatic_force_N"])
        tr = trials[(trials.subject == subject) & (trials.trial == trial)].iloc[0]
        # counters miss only frames lost before the first or after the last one received
        lost = truth["dropped_by_simulator"]["FzCell"] + truth["dropped_by_simulator"]["FxCell"]
        assert lost - 2 <= tr.dropped_frames <= lost, key
        if truth["waveform"] == "sine":
            assert tr.friction_modulation_Hz == pytest.approx(2 * truth["frequency_Hz"],
                                                              rel=0.02)
        else:
            assert pd.isna(tr.friction_modulation_Hz)
    for subject in TRUTH["subjects"]:
        square = [t for t in TRUTH["trials"].values()
                  if t["subject"] == subject and t["waveform"] == "square"]
        u = np.array([t["amplitude_V"] for t in square])
        f = np.array([t["electrostatic_force_N"] for t in square])
        true_exponent = np.polyfit(np.log(u), np.log(f), 1)[0]
        ex = analysed.exponents
        ex = ex[(ex.subject == subject) & (ex.waveform == "square")].iloc[0]
        assert ex.exponent == pytest.approx(true_exponent, abs=0.05), subject


def test_sine_traces_and_provenance_are_what_the_report_reads(analysed):
    tables = read_results(analysed.out_dir)
    trace = tables.sine_trace
    assert trace is not None and (analysed.out_dir / SINE_TRACE_FILE).is_file()
    assert set(trace.subject) == {"P01", "P02", "P03"}
    one = trace[trace.subject == "P01"]
    assert set(one.trial) == {"run-06"}
    t = one.time_s.to_numpy()
    assert np.all(np.diff(t) > 0) and 1 / np.median(np.diff(t)) <= 1000.5
    assert 1.0 < t[-1] - t[0] < 5.0
    on = one.amplitude_V > 0
    assert on.any() and (~on).any() and set(one.amplitude_V[on]) == {140.0}
    assert (one.frequency_Hz == 10.0).all()
    # OFF, friction / normal force is the subject's mu (inside steady sliding)
    off = one[~on]
    ratio = np.nanmedian(off.friction_force_N / off.normal_force_N)
    assert ratio == pytest.approx(TRUTH["subjects"]["P01"]["mu"], rel=0.02)

    summary = tables.summary
    assert summary["study_dir"] == str(STUDY.resolve())
    inputs = {r["file"]: r for r in summary["inputs"]}
    assert {"study.toml", "rig/default.dbc", "P01/run-01.log.gz",
            "P01/run-01.json"} <= set(inputs)
    assert len([r for r in summary["inputs"] if r["role"] == "log"]) == 18
    record = inputs["P03/run-06.log.gz"]
    assert record["bytes"] == (STUDY / "P03" / "run-06.log.gz").stat().st_size
    assert record["sha256"] == hashlib.sha256(
        (STUDY / "P03" / "run-06.log.gz").read_bytes()).hexdigest()
    assert summary["rig"]["normal_force"] == "FzCell.Fz"
    assert summary["rig"]["normal_force_counter"] == "FzCell.FzCounter"
    assert summary["software"]["python-can"] == can.__version__
    assert summary["software"]["cantools"] and summary["software"]["evtribo"]
    assert summary["started"].endswith("Z") and summary["settings"]["n_boot"] > 0


def test_the_report_shows_the_recorded_provenance_and_the_measured_sine_trace(analysed):
    compare(analysed.out_dir, dpi=50, formats=("png",))
    html_path = analysed.out_dir / "report.html"
    build_report(analysed.out_dir, html_path, dpi=50)
    html = html_path.read_text(encoding="utf-8")
    summary = json.loads((analysed.out_dir / "summary.json").read_text(encoding="utf-8"))
    log_record = next(r for r in summary["inputs"] if r["file"] == "P02/run-04.log.gz")
    assert "Input files (as recorded in summary.json)" in html
    assert log_record["sha256"] in html
    assert "python-can (analysis)" in html and "cantools (analysis)" in html
    assert "FzCell.FzCounter" in html  # the rig's roles
    fit = json.loads((analysed.out_dir / "fit.json").read_text(encoding="utf-8"))
    assert not any("No sine_trace.csv" in n for n in fit.get("notes", []))


def test_without_counters_the_timing_of_the_recorded_logs_counts_the_lost_frames():
    # software timestamps of a real-time recording; the counters are ignored here
    for key in ("P01/run-01", "P02/run-03", "P03/run-06"):
        frames, _ = read_frames(STUDY / f"{key}.log.gz")
        for frame_id, name in ((0x0C1, "FzCell"), (0x0C2, "FxCell")):
            t = frames.timestamp[frames.arbitration_id == frame_id]
            lost = TRUTH["trials"][key]["dropped_by_simulator"][name]
            got = missing_frames(t)
            assert not got.notes and abs(got.count - lost) <= 2, (key, name, got, lost)
