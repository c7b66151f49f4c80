"""The simulated rig speaking a lab's own DBC: trials written into a study for that rig are
analysed back to the simulated truth."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest

from _checks import fel_ok
from evtribo.acquisition.simulator import SubjectParams, TrialConfig, write_trial
from evtribo.canlog.io import read_frames
from evtribo.canlog.rig import default_rig, load_rig
from evtribo.errors import RigConfigError
from evtribo.results.pipeline import analyze_study
from evtribo.study import load_study

RIGS = Path(__file__).parents[1] / "data" / "rigs"


@pytest.mark.parametrize("rig_file", ["lab.toml", "motorola.toml"])
def test_a_study_of_another_rig_is_analysed_back_to_the_truth(rig_file, tmp_path):
    rig = load_rig(RIGS / rig_file)
    study = tmp_path / "study"
    truths = {}
    for i, (subject, amp) in enumerate([("P01", 80.0), ("P01", 140.0), ("P02", 120.0)]):
        person = SubjectParams(name=subject, mu=0.45 + 0.1 * (subject == "P02"),
                               h_L=5e-6 if subject == "P01" else 7e-6)
        config = TrialConfig(duration_s=12.0, amplitude_V=amp, seed=40 + i,
                             drop_probability=0.002)
        truths[(subject, amp)] = write_trial(study, f"run-{i + 1:02d}", person, config,
                                             rig=rig)
    # the study is the rig's: its DBC copied, its roles, its frames
    loaded = load_study(study)
    assert {r: ref.qualified_name for r, ref in loaded.rig.roles.items()} == \
        {r: ref.qualified_name for r, ref in rig.roles.items()}
    frames, _ = read_frames(study / "P01" / "run-01.log")
    ids = set(zip(frames.arbitration_id.tolist(), frames.is_extended.tolist(), strict=True))
    for ref in rig.measured_roles.values():
        assert (ref.message.frame_id, bool(ref.message.is_extended_frame)) in ids
    sidecar = json.loads((study / "P01" / "run-01.json").read_text())
    assert sidecar["rig"]["dbc"] == f"rig/{rig.dbc.name}"
    # analysed with the study's own rig, back to the truth
    analyze_study(study, tmp_path / "out", cache_dir=tmp_path / "cache")
    el = pd.read_csv(tmp_path / "out" / "electrostatic.csv", dtype={"subject": str})
    for (subject, amp), truth in truths.items():
        row = el[(el.subject == subject) & (el.amplitude_V == amp)]
        assert len(row) == 1
        assert fel_ok(row.iloc[0].electrostatic_force_N, truth.electrostatic_force_N), (
            subject, amp, row.iloc[0].electrostatic_force_N, truth.electrostatic_force_N)
        assert row.iloc[0].mu == pytest.approx(truth.subject.mu, rel=0.03)


def test_a_study_keeps_its_rig(tmp_path):
    write_trial(tmp_path / "s", "run-01", SubjectParams(), TrialConfig(duration_s=3.0))
    with pytest.raises(RigConfigError, match="the study's rig is"):
        write_trial(tmp_path / "s", "run-02", SubjectParams(), TrialConfig(duration_s=3.0),
                    rig=load_rig(RIGS / "lab.toml"))
    # the default rig asked of a default-rig study is no conflict
    write_trial(tmp_path / "s", "run-02", SubjectParams(), TrialConfig(duration_s=3.0),
                rig=default_rig())


@pytest.mark.parametrize("rig_file", ["lab.toml", "motorola.toml"])
def test_the_sidecar_names_the_rig_s_own_messages(rig_file, tmp_path):
    """The simulator's record in the sidecar names the messages of the rig it spoke, with
    their identifiers and the frames each sent, not the default rig's."""
    rig = load_rig(RIGS / rig_file)
    write_trial(tmp_path / "s", "run-01", SubjectParams(),
                TrialConfig(duration_s=3.0, drop_probability=0.002, seed=3), rig=rig)
    sidecar = json.loads((tmp_path / "s" / "P01" / "run-01.json").read_text())
    nodes = sidecar["simulation"]["nodes"]
    spoken = {ref.message.name: ref.message for ref in rig.measured_roles.values()}
    assert set(nodes) == set(spoken)
    frames, _ = read_frames(tmp_path / "s" / "P01" / "run-01.log")
    for name, node in nodes.items():
        assert node["frame_id"] == spoken[name].frame_id
        sent = int(((frames.arbitration_id == spoken[name].frame_id)
                    & (frames.is_extended == bool(spoken[name].is_extended_frame))).sum())
        assert sent == node["frames"]
    assert sidecar["frames"] == len(frames)
    assert sidecar["dropped_frames"] == sum(n["dropped"] for n in nodes.values())
