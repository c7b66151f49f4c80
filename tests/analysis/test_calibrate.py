"""``evtribo calibrate``: the load cells' cross-talk matrix from a recording of the finger
pressing without sliding and from sliding trials (docs/analysis.md, "Cross-talk"); a matrix
only of what was measured precisely and found, the press recording rehearsed with
``evtribo simulate --press-only``."""

from __future__ import annotations

import ast
import dataclasses
import math
import re

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from evtribo.acquisition.simulator import TrialConfig, default_subjects, write_trial
from evtribo.acquisition.simulator.realism import human, realistic_rig
from evtribo.analysis.calibration import MAX_SE, SIGNIFICANT_SE, CrossTalk
from evtribo.cli import main

#: The rig's cross-talk: the normal cell reads 5 % of the tangential force, the tangential
#: cell -3.5 % of the normal force.
CROSSTALK = ((1.0, 0.05), (-0.035, 1.0))


def _study(root, crosstalk):
    """A press recording made as a user rehearses one (``simulate --press-only``), then
    five sliding trials of one subject."""
    (a_from, b_from) = crosstalk[0][1], crosstalk[1][0]
    assert main(["simulate", "--study", str(root), "--subject", "P01", "--trial", "run-01",
                 "--press-only", "--duration", "16", "--seed", "40",
                 "--crosstalk", str(a_from), str(b_from)]) == 0
    subject = human(default_subjects(1, seed=4)[0], seed=4)
    for i in range(1, 6):
        cfg = realistic_rig(TrialConfig(duration_s=16.0, crosstalk=crosstalk, seed=40 + i,
                                        condition="alternating"))
        write_trial(root, f"run-{i + 1:02d}", subject, cfg)
    return root


@pytest.fixture(scope="module")
def calibration_study(tmp_path_factory):
    return _study(tmp_path_factory.mktemp("cal") / "study", CROSSTALK)


def _share(out, cell):
    m = re.search(rf"the {cell} cell reads ([-+\d.]+) % \(\+/- ([\d.]+)\)", out)
    return float(m.group(1)), float(m.group(2))


@pytest.mark.slow
def test_the_matrix_undoes_the_rig_s_cross_talk(calibration_study, capsys):
    assert main(["calibrate", str(calibration_study), "--press", "P01/run-01"]) == 0
    out = capsys.readouterr().out
    b, b_se = _share(out, "tangential")
    a, a_se = _share(out, "normal")
    assert abs(b - (-3.5)) <= 2.5 * b_se and b_se < 100 * MAX_SE
    assert abs(a - 5.0) <= 2.5 * a_se and a_se < 100 * MAX_SE
    assert "too uncertain" not in out and "no cross-talk" not in out
    matrix = ast.literal_eval(re.search(r"matrix = (\[\[.*\]\])", out).group(1))
    # the matrix given undoes the one measured: M @ [[1, a], [b, 1]] = I
    measured = np.array([[1.0, a / 100], [b / 100, 1.0]])
    np.testing.assert_allclose(np.asarray(matrix) @ measured, np.eye(2), atol=1e-4)
    assert "[rig.calibration]" in out


@pytest.mark.slow
def test_a_rig_without_cross_talk_gets_no_matrix(tmp_path, capsys):
    study = _study(tmp_path / "study", ((1.0, 0.0), (0.0, 1.0)))
    capsys.readouterr()
    assert main(["calibrate", str(study), "--press", "P01/run-01"]) == 0
    out = capsys.readouterr().out
    for cell in ("tangential", "normal"):
        value, se = _share(out, cell)
        assert abs(value) <= SIGNIFICANT_SE * se
    assert out.count("no cross-talk found (within 2 standard errors of zero)") == 2
    assert "no [rig.calibration] matrix to give" in out and "matrix =" not in out


def test_a_sliding_trial_given_as_the_press_is_refused_with_the_evidence(calibration_study,
                                                                         capsys):
    assert main(["calibrate", str(calibration_study), "--press", "P01/run-02"]) == 2
    out, err = capsys.readouterr()
    assert "P01/run-02.log: key '--press': not a recording of the finger pressing without " \
           "sliding" in err
    share = int(re.search(r"over 25 % of the normal force in (\d+) % of the time", err)[1])
    assert share > 50
    assert "so the finger slid" in err and "evtribo simulate --study STUDY --press-only" in err
    assert "matrix" not in out


def test_a_trial_given_twice_with_slide_counts_once(calibration_study, capsys):
    counts = []
    for slides in (["P01/run-02"], ["P01/run-02", "P01/run-02"]):
        assert main(["calibrate", str(calibration_study),
                     *[x for s in slides for x in ("--slide", s)]]) == 0
        out = capsys.readouterr().out
        assert "sliding from 1 trial(s)" in out
        counts.append(re.search(r"\((\d+) reversals\)", out)[1])
    assert counts[0] == counts[1]


@given(a=st.floats(-0.2, 0.2), b=st.floats(-0.2, 0.2), a_se=st.floats(0.0, 0.3),
       b_se=st.floats(0.0, 0.3), measured=st.tuples(st.booleans(), st.booleans()))
def test_the_matrix_holds_only_the_shares_found_precisely(a, b, a_se, b_se, measured):
    """A share goes into the matrix only when measured with a standard error within
    MAX_SE and beyond SIGNIFICANT_SE of them from zero; no matrix without one."""
    nan = float("nan")
    found = CrossTalk(a if measured[0] else nan, a_se if measured[0] else nan,
                      b if measured[1] else nan, b_se if measured[1] else nan, 10, 10.0)
    used = {}
    for term, value, se, here in (("a", a, a_se, measured[0]), ("b", b, b_se, measured[1])):
        kept = here and se <= MAX_SE and abs(value) > SIGNIFICANT_SE * se
        assert (found.verdict(term) == "found") == kept
        used[term] = value if kept else 0.0
    if not any(used.values()):
        assert found.matrix is None
    else:
        undo = np.asarray(found.matrix) @ np.array([[1.0, used["a"]], [used["b"], 1.0]])
        np.testing.assert_allclose(undo, np.eye(2), atol=1e-5)


def test_an_uncertain_share_is_said_with_the_recording_that_makes_it_precise(
        calibration_study, capsys, monkeypatch):
    """A pressing estimate of +/- 19 % is not put into the matrix, and the command says what
    to record instead."""
    from evtribo.analysis import calibration

    uncertain = CrossTalk(a=0.05, a_se=0.005, b=-0.45, b_se=0.19, reversals=80, press_s=2.1)
    monkeypatch.setattr(calibration, "crosstalk_matrix", lambda *_a, **_k: uncertain)
    assert main(["calibrate", str(calibration_study), "--press", "P01/run-01"]) == 0
    out = capsys.readouterr().out
    assert "the tangential cell reads -45.00 % (+/- 19.00) of the normal force (2.1 s of " \
           "pressing): too uncertain to correct for" in out
    assert "a longer recording of the finger pressing still (10-20 s)" in out
    matrix = ast.literal_eval(re.search(r"matrix = (\[\[.*\]\])", out).group(1))
    assert math.isclose(matrix[1][0], 0.0, abs_tol=1e-9)   # b left out
    assert math.isclose(matrix[0][1], -0.05, abs_tol=1e-6)  # a kept


def test_without_pressing_or_reversals_it_says_what_to_record(tmp_path, capsys):
    root = tmp_path / "study"
    cfg = realistic_rig(TrialConfig(duration_s=6.0, press_only=True, seed=2,
                                    condition="off"))
    write_trial(root, "run-01", human(default_subjects(1, seed=2)[0], seed=2),
                dataclasses.replace(cfg, tare_s=1.0))
    code = main(["calibrate", str(root), "--slide", "P01/run-01"])
    assert code == 1
    assert "nothing to calibrate from" in capsys.readouterr().err


def test_simulate_press_only_leaves_the_amplifier_off(tmp_path, capsys):
    assert main(["simulate", "--study", str(tmp_path / "s"), "--press-only",
                 "--condition", "on", "--duration", "4"]) == 2
    assert "'--condition'" in capsys.readouterr().err
    assert not (tmp_path / "s").exists()
