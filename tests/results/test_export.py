"""``evtribo export STUDY -o OUT.mf4``: each trial's aligned forces and conditions, read
back by asammdf, are those the analysis worked on (:func:`view_trial`), value for value."""

from __future__ import annotations

import numpy as np
import pytest

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, write_trial
from evtribo.acquisition.simulator.realism import human, realistic_rig
from evtribo.analysis.forces.conditions import ON
from evtribo.cli import main
from evtribo.results.trial_view import view_trial

asammdf = pytest.importorskip("asammdf")


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """Two trials of a real rig's subject: one square, one sine."""
    root = tmp_path_factory.mktemp("export") / "study"
    for name, wave, seed in (("run-01", "square", 1), ("run-02", "sine", 2)):
        write_trial(root, name, human(SubjectParams(), seed=seed),
                    realistic_rig(TrialConfig(duration_s=8.0, waveform=wave, seed=seed)))
    return root


def test_each_trial_s_forces_round_trip_through_asammdf(study, tmp_path, capsys):
    out = tmp_path / "forces.mf4"
    assert main(["export", str(study), "-o", str(out)]) == 0
    said = capsys.readouterr()
    assert "[2/2] P01/run-02" in said.err and "2 trials' aligned forces" in said.out
    with asammdf.MDF(out) as mdf:
        names = [g.channel_group.acq_name for g in mdf.groups]
        assert names == ["P01/run-01", "P01/run-02"]
        for gi, trial in enumerate(("run-01", "run-02")):
            check = view_trial(study, "P01", trial)
            [piece] = check.pieces
            normal = mdf.get("normal_force", gi)
            assert normal.unit == "N"
            np.testing.assert_array_equal(normal.samples, piece.forces.normal)
            np.testing.assert_array_equal(mdf.get("tangential_force", gi).samples,
                                          piece.forces.tangential)
            np.testing.assert_array_equal(normal.timestamps, piece.forces.t - check.t0)
            codes = mdf.get("condition", gi, raw=True).samples
            np.testing.assert_array_equal(codes, piece.condition)
            text = mdf.get("condition", gi).samples
            assert set(text[codes == ON]) == {b"ON"}
            wave = "square" if trial == "run-01" else "sine"
            assert f"waveform {wave}" in mdf.groups[gi].channel_group.comment
    assert main(["export", str(study), "-o", str(out)]) == 2  # exists: not without --force
    assert main(["export", str(study), "-o", str(out), "--force", "--subject", "P01"]) == 0
