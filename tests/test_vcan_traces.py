"""The reference study recorded through a kernel's CAN stack (``data/vcan-traces``, made by
``scripts/record_vcan_traces.py``): ``evtribo acquire --interface socketcan`` and ``candump
-L`` recorded the same frames at the same kernel times, every frame of the reference study
in order, and the analysis finds what it finds in the reference study."""

import gzip
import json
from pathlib import Path

import pytest

from _bursts import expect_bursts
from _checks import fel_ok
from evtribo.results.pipeline import compute_study
from evtribo.study import load_study

DATA = Path(__file__).resolve().parents[1] / "data"
TRACES = DATA / "vcan-traces"
REFERENCE = DATA / "reference-study"
TRUTH = json.loads((REFERENCE / "truth.json").read_text(encoding="utf-8"))


def _lines(path: Path) -> list[str]:
    with gzip.open(path, "rt") as fh:
        return fh.read().splitlines()


def test_acquire_and_candump_recorded_every_frame_at_the_same_kernel_times():
    study = load_study(TRACES / "study")
    assert len(study.trials) == 18
    for trial in study.trials:
        side = json.loads(trial.sidecar_path.read_text())
        assert (side["interface"], side["channel"], side["ended"]) == \
            ("socketcan", "vcan0", "completed")
        assert side["receive"]["timestamps"] == "kernel" and side["receive"]["queue"]["forced"]
        assert side["queue_dropped_frames"] == 0 and side["discarded_before_start"] == 0
        ours = _lines(trial.log_path)
        theirs = _lines(TRACES / "candump" / trial.subject / trial.log_path.name)
        assert ours == theirs, trial.key  # the same frames, the same times, to the µs
        reference = _lines(REFERENCE / trial.subject / trial.log_path.name)
        assert [ln.split()[2] for ln in ours] == [ln.split()[2] for ln in reference]
        assert side["frames"] == len(ours)
        ref_side = json.loads((REFERENCE / trial.subject / f"{trial.name}.json").read_text())
        assert side["dropped_frames"] == ref_side["dropped_frames"]  # the trace's own losses


@pytest.mark.slow
def test_the_analysis_finds_in_them_what_it_finds_in_the_reference_study(tmp_path):
    def analysed_alike() -> None:
        vcan = compute_study(TRACES / "study", jobs=2, cache_dir=tmp_path / "a").electrostatic
        ref = compute_study(REFERENCE, jobs=2, cache_dir=tmp_path / "b").electrostatic
        both = vcan.merge(ref, on=["subject", "waveform", "amplitude_V"], suffixes=("", "_ref"))
        assert len(both) == len(vcan) == len(ref) == 18
        for row in both.itertuples():
            # the kernel's times carry the replaying machine's scheduling jitter
            assert row.electrostatic_force_N == pytest.approx(row.electrostatic_force_N_ref,
                                                              rel=0.02), row
            truth = next(t for t in TRUTH["trials"].values() if t["subject"] == row.subject
                         and t["waveform"] == row.waveform
                         and t["amplitude_V"] == row.amplitude_V)
            assert fel_ok(row.electrostatic_force_N, truth["electrostatic_force_N"]), row

    expect_bursts(analysed_alike, sorted((TRACES / "study").glob("P*/run-*.log.gz")),
                  [0x0C1, 0x0C2])
