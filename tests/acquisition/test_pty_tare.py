"""The simulated rig on a pty lifts the finger at the start of every recording, as an operator
does for the tare stretch, so that each trial of a rehearsed session has its own."""

from __future__ import annotations

import json
import signal

import numpy as np
import pytest

from evtribo.acquisition.simulator.config import SubjectParams
from evtribo.acquisition.simulator.physics import CONTACT_RAMP_S, Contact
from evtribo.analysis.settings import AnalysisSettings
from evtribo.cli import main
from evtribo.results.pipeline import analyze_study


def test_a_lift_inserted_later_replaces_the_lift_offs_it_overlaps():
    contact = Contact(np.array([-CONTACT_RAMP_S, 5.0, 9.0]), np.array([1.6, 5.5, 9.4]))
    lifted = contact.lifted_at(4.8, 1.5)
    assert lifted.start.tolist() == [-CONTACT_RAMP_S, 4.8, 9.0]
    assert lifted.end.tolist() == pytest.approx([1.6, 4.8 + 1.5 + 2 * CONTACT_RAMP_S, 9.4])
    t = np.array([4.79, 5.0, 6.0, 6.5])
    np.testing.assert_allclose(lifted.factor(t), [1.0, 0.0, 0.0, 1.0], atol=1e-9)
    assert lifted.lifted(20.0)[1] == pytest.approx((4.8 + CONTACT_RAMP_S, 6.3 + CONTACT_RAMP_S))
    assert SubjectParams().lifts_per_min == 0  # the default finger lifts only when asked


@pytest.mark.slow
def test_each_recording_on_the_simulated_pty_starts_with_the_finger_lifted(
        tmp_path, simulate_pty):
    sim, path = simulate_pty("--tare-s", "1.2", "--seed", "3")
    study = tmp_path / "study"
    for trial in ("run-01", "run-02"):
        code = main(["acquire", "--study", str(study), "--subject", "P01", "--trial", trial,
                     "--interface", "slcan_bulk", "--channel", path,
                     "--bus-option", "sleep_after_open=0", "--waveform", "square",
                     "--frequency", "10000", "--amplitude", "140", "--condition", "alternating",
                     "--duration", "8", "--tare-s", "1.2", "--quiet"])
        assert code == 0
    sim.send_signal(signal.SIGTERM)
    sim.communicate(timeout=10)
    res = analyze_study(study, tmp_path / "out", jobs=1, settings=AnalysisSettings(n_boot=50))
    assert list(res.trials.trial) == ["run-01", "run-02"]
    assert res.trials.tare.str.contains("lifted").all(), res.trials.tare
    summary = json.loads((tmp_path / "out" / "summary.json").read_text(encoding="utf-8"))
    assert not [w for w in summary["warnings"] if "no finger-lifted stretch" in w]
