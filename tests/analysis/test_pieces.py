"""Timestamps that jump, and timestamps that are not seconds: memory follows the frames,
never the time span; the jump is reported and the trial analysed in its continuous pieces."""

from __future__ import annotations

import re
import tracemalloc

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_trial
from evtribo.analysis.forces.pieces import continuous_pieces
from evtribo.analysis.settings import AnalysisSettings
from evtribo.analysis.trial import TrialMeta, analyze_signals
from evtribo.canlog.decode import decode_trial
from evtribo.canlog.rig import default_rig
from evtribo.errors import AnalysisError

RIG = default_rig()
SETTINGS = AnalysisSettings(n_boot=100)


def _trial(shift_s: float = 0.0, scale: float = 1.0, seed: int = 1):
    """A 12-s trial whose second half of frames (in the log's order) is shifted by
    *shift_s*, and all of whose timestamps are multiplied by *scale*."""
    frames, truth = simulate_trial(SubjectParams(), TrialConfig(duration_s=12.0, seed=seed))
    t = frames.timestamp.copy()
    t[len(t) // 2:] += shift_s
    frames.timestamp = t * scale
    return decode_trial(frames, RIG), truth


def _peak_bytes(signals) -> tuple[int, object]:
    tracemalloc.start()
    try:
        result = analyze_signals(signals, TrialMeta("P01", "run-01"), settings=SETTINGS)
        return tracemalloc.get_traced_memory()[1], result
    finally:
        tracemalloc.stop()


@pytest.mark.parametrize("shift_s", [-3 * 3600.0, 24 * 3600.0, -20 * 365 * 86400.0])
def test_a_jump_of_the_clock_costs_no_memory_and_is_reported(shift_s):
    signals, _ = _trial()
    baseline, plain = _peak_bytes(signals)
    jumped_signals, _ = _trial(shift_s)
    peak, result = _peak_bytes(jumped_signals)
    # a grid across 3 h asked for 2.4 GB, across 24 h for 14 GB, across years 1.4 TiB
    assert peak < 2 * baseline + 20e6, (peak, baseline)
    jump = [w.text for w in result.warnings if w.kind == "pause"]
    assert len(jump) == 1
    found = re.search(r"\((\d+\.\d+) s\) after (\d+\.\d+) s", jump[0])
    assert found is not None, jump[0]
    gap = abs(shift_s) - (12.0 if shift_s < 0 else 0.0)  # a shift back folds the halves
    assert float(found.group(1)) == pytest.approx(gap, abs=0.05)
    assert float(found.group(2)) == pytest.approx(6.0, abs=0.05)  # where: half-way
    assert any("analysed in 2 continuous pieces" in w.text for w in result.warnings)
    assert result.row["duration_s"] == pytest.approx(12.0, abs=0.1)  # the frames' time
    assert len(result.windows) >= len(plain.windows) - 2
    assert result.windows.t_end_s.max() - result.windows.t_start_s.min() > abs(shift_s) - 12


def test_millisecond_timestamps_are_refused_with_their_likely_cause():
    signals, _ = _trial(scale=1000.0)
    with pytest.raises(AnalysisError, match="in milliseconds") as err:
        analyze_signals(signals, TrialMeta("P01", "run-01"), settings=SETTINGS)
    assert "12000 s long" in str(err.value) or "11999 s long" in str(err.value)


@settings(deadline=None, max_examples=25)
@given(shift=st.one_of(st.floats(-1e9, -13.5), st.floats(13.5, 1e9)), seed=st.integers(0, 50))
def test_pieces_follow_the_frames_whatever_the_jump(shift, seed):
    signals, _ = _trial(shift, seed=seed)
    pieces = continuous_pieces(signals)
    assert len(pieces) == 2
    assert sum(b - a for a, b in pieces) == pytest.approx(12.0, abs=0.05)
    t = np.concatenate([signals.normal.t, signals.tangential.t])
    assert min(a for a, _ in pieces) == t.min() and max(b for _, b in pieces) == t.max()


def test_only_the_piece_holding_the_trial_s_start_looks_for_its_tare_stretch():
    # a trial with a tare stretch at its start and a gap of its load cells' frames in the
    # middle (a busy machine): the later piece has no stretch of its own to find, and
    # nothing says one is missing
    frames, _ = simulate_trial(SubjectParams(), TrialConfig(duration_s=12.0, seed=2,
                                                            tare_s=1.2))
    t = frames.timestamp.copy()
    t[len(t) // 2:] += 2.0
    frames.timestamp = t
    result = analyze_signals(decode_trial(frames, RIG), TrialMeta("P01", "run-01",
                                                                  tare_s=1.2),
                             settings=SETTINGS)
    assert any("analysed in 2 continuous pieces" in w.text for w in result.warnings)
    assert "lifted" in result.row["tare"]
    assert not [w for w in result.warnings if w.kind == "no-lift"]
