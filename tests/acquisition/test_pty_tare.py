"""The simulated rig on a pty lifts the finger at the start of every recording, as an operator
does for the tare stretch, so that each trial of a rehearsed session has its own."""

from __future__ import annotations

import json
import re
import signal

import numpy as np
import pytest

from evtribo.acquisition.simulator.config import SubjectParams
from evtribo.acquisition.simulator.physics import CONTACT_RAMP_S, Contact
from evtribo.analysis.settings import AnalysisSettings
from evtribo.cli import main
from evtribo.results.pipeline import analyze_study

#: The finger lifted at each recording's start, s.
TARE_S = 1.2
#: The simulated rig's frames per second (simulate's default rates: 1000 + 2000 + 50).
RIG_FRAMES_PER_S = 3050.0


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
    sim, path = simulate_pty("--tare-s", str(TARE_S), "--seed", "3")
    study = tmp_path / "study"
    for trial in ("run-01", "run-02"):
        code = main(["acquire", "--study", str(study), "--subject", "P01", "--trial", trial,
                     "--interface", "slcan_bulk", "--channel", path,
                     "--bus-option", "sleep_after_open=0", "--waveform", "square",
                     "--frequency", "10000", "--amplitude", "140", "--condition", "alternating",
                     "--duration", "8", "--tare-s", str(TARE_S), "--quiet"])
        assert code == 0
    sim.send_signal(signal.SIGTERM)
    _out, err = sim.communicate(timeout=60)
    # the frames that came due between the two recordings are said to be unsent, and why
    assert re.search(r"\d+ frames sent in [\d.]+ s, \d+ not sent: .*\d+ while no client "
                     r"had the channel open \(before its 'O', between recordings", err), err
    res = analyze_study(study, tmp_path / "out", jobs=1, settings=AnalysisSettings(n_boot=50))
    assert list(res.trials.trial) == ["run-01", "run-02"]
    summary = json.loads((tmp_path / "out" / "summary.json").read_text(encoding="utf-8"))
    # The rig lifts the finger when the adapter is opened ('O'); what reached the bus's
    # buffers before the trial began is read away as queued before it. A busy machine
    # that took most of the tare stretch between the two leaves less of the lift in the
    # trial: judged by the frames the recording says it discarded.
    for trial in res.trials.itertuples():
        side = json.loads((study / "P01" / f"{trial.trial}.json").read_text())
        left_s = TARE_S - side["discarded_before_start"] / RIG_FRAMES_PER_S
        missing = [w for w in summary["warnings"]
                   if w["trial"] == trial.trial and w["kind"] == "no-lift"]
        if left_s >= 0.5:  # well over the shortest stretch the analysis tares from
            assert "lifted" in trial.tare and not missing, (trial, side, summary["warnings"])
        else:
            assert "lifted" in trial.tare or missing, (trial, side)
