"""``evtribo calibrate``: the load cells' cross-talk matrix from a recording of the finger
pressing without sliding and from sliding trials (docs/analysis.md, "Cross-talk")."""

from __future__ import annotations

import ast
import dataclasses
import re

import numpy as np
import pytest

from evtribo.acquisition.simulator import TrialConfig, default_subjects, write_trial
from evtribo.acquisition.simulator.realism import human, realistic_rig
from evtribo.cli import main

#: The rig's cross-talk: the normal cell reads 3 % of the tangential force, the tangential
#: cell -3.5 % of the normal force.
CROSSTALK = ((1.0, 0.03), (-0.035, 1.0))


@pytest.fixture(scope="module")
def calibration_study(tmp_path_factory):
    root = tmp_path_factory.mktemp("cal") / "study"
    subject = human(default_subjects(1, seed=4)[0], seed=4)
    for i in range(6):
        press = i == 0
        cfg = realistic_rig(TrialConfig(duration_s=16.0, crosstalk=CROSSTALK,
                                        press_only=press, seed=40 + i,
                                        condition="off" if press else "alternating"))
        write_trial(root, f"run-{i + 1:02d}", subject, cfg)
    return root


@pytest.mark.slow
def test_the_matrix_undoes_the_rig_s_cross_talk(calibration_study, capsys):
    assert main(["calibrate", str(calibration_study), "--press", "P01/run-01"]) == 0
    out = capsys.readouterr().out
    b, b_se = (float(x) for x in re.search(
        r"tangential cell reads ([-+\d.]+) % \(\+/- ([\d.]+)\)", out).groups())
    a, a_se = (float(x) for x in re.search(
        r"normal cell reads ([-+\d.]+) % \(\+/- ([\d.]+)\) of the tangential force "
        r"\((\d+) reversals", out).groups()[:2])
    assert abs(b - (-3.5)) <= 2.5 * b_se and b_se < 1.5
    assert abs(a - 3.0) <= 2.5 * a_se and a_se < 1.5
    matrix = ast.literal_eval(re.search(r"matrix = (\[\[.*\]\])", out).group(1))
    # the matrix given undoes the one measured: M @ [[1, a], [b, 1]] = I
    measured = np.array([[1.0, a / 100], [b / 100, 1.0]])
    np.testing.assert_allclose(np.asarray(matrix) @ measured, np.eye(2), atol=1e-4)
    assert "[rig.calibration]" in out


def test_without_pressing_or_reversals_it_says_what_to_record(tmp_path, capsys):
    root = tmp_path / "study"
    cfg = realistic_rig(TrialConfig(duration_s=6.0, press_only=True, seed=2,
                                    condition="off"))
    write_trial(root, "run-01", human(default_subjects(1, seed=2)[0], seed=2),
                dataclasses.replace(cfg, tare_s=1.0))
    code = main(["calibrate", str(root), "--slide", "P01/run-01"])
    assert code == 1
    assert "nothing to calibrate from" in capsys.readouterr().err

