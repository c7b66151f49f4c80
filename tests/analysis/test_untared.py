"""A trial whose tangential zero is unknown (no tare stretch, no calibration, no friction
loop) and whose ON windows slid the other way from its OFF windows: the cell's offset adds
to the friction one way and subtracts the other, and nothing in the trial tells it from
the electrostatic force. Such ON windows are left out, and said (data/README.md,
``untared-session``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from hypothesis import given
from hypothesis import strategies as st

from evtribo.analysis.settings import AnalysisSettings
from evtribo.analysis.tared_windows import _like_with_like
from evtribo.results.pipeline import analyze_study
from evtribo.warning.collect import collecting

UNTARED = Path(__file__).resolve().parents[2] / "data" / "untared-session"


def test_a_recorded_trial_with_its_directions_confounded_gives_no_force_and_says_why(
        tmp_path):
    res = analyze_study(UNTARED, tmp_path / "out", jobs=1,
                        settings=AnalysisSettings(n_boot=100))
    warnings = [w["text"] for w in res.summary["warnings"]]
    assert any("P01/run-01: the tangential cell's zero is unknown" in w for w in warnings)
    left_out = [w for w in warnings if "ON windows are left out" in w]
    assert len(left_out) == 1 and left_out[0].startswith("P01/run-01: 3 of 3 ON windows")
    assert "tangential_offset_N" in left_out[0] and "--tare-s" in left_out[0]
    # before, F_el came out -20 mN [-65, +26] where the rig's truth is about +60 mN: now
    # the trial has no force rather than a wrong one
    assert res.electrostatic.empty
    windows = pd.read_csv(tmp_path / "out" / "windows.csv")
    assert (windows.condition == "off").all() and len(windows) == 4
    assert set(windows.direction) == {1}


@given(st.lists(st.tuples(st.sampled_from(["on", "off"]), st.sampled_from([-1, 1])),
                max_size=12))
def test_only_on_windows_of_a_direction_no_off_window_slid_are_left_out(rows):
    w = pd.DataFrame(rows, columns=["condition", "direction"])
    amps = np.arange(len(w), dtype=np.float64)
    with collecting(quiet=True) as records:
        kept, kept_amps = _like_with_like(w, amps)
    said = [r.text for r in records]
    off_ways = set(w.direction[w.condition == "off"])
    # a trial without OFF windows is compared with other trials': its windows stay
    expected = [(c == "off" or d in off_ways or not off_ways) for c, d in rows]
    assert kept.values.tolist() == w[expected].values.tolist()
    assert kept_amps.tolist() == amps[expected].tolist()  # the amplitudes stay aligned
    assert len(said) == (0 if all(expected) else 1)
    if said:
        assert said[0].startswith(f"{len(w) - sum(expected)} of "
                                  f"{int((w.condition == 'on').sum())} ON windows")
