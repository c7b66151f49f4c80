"""A trial's analysis on damaged recordings: gaps, a load cell or the amplifier missing,
duplicated or backwards blocks, corrupted payloads, a trial cut to a few frames, any
sidecar values. The result is a row and windows, or an AnalysisError the study run reports
as a failed trial; never another exception (which would stop the whole study's analysis)."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
from hypothesis import event, given
from hypothesis import strategies as st

from evtribo.acquisition.simulator import TrialConfig, simulate_trial
from evtribo.analysis.trial import AnalysisSettings, TrialMeta, analyze_signals
from evtribo.canlog.decode import decode_trial
from evtribo.canlog.io import FrameTable
from evtribo.canlog.rig import default_rig
from evtribo.errors import AnalysisError, UserInputError

RIG = default_rig()
SETTINGS = AnalysisSettings(n_boot=50)


@cache
def recorded() -> FrameTable:
    """6 s of an alternating 140 V square-wave trial (about 18,000 frames)."""
    frames, _ = simulate_trial(config=TrialConfig(duration_s=6.0, seed=11))
    return frames


@st.composite
def damaged_frames(draw):
    frames = recorded()
    ts = frames.timestamp.copy()
    data = frames.data.copy()
    keep = np.ones(len(frames), dtype=bool)
    order = np.arange(len(frames))
    for _ in range(draw(st.integers(1, 4))):
        n = len(order)
        if n == 0:
            break
        a = draw(st.integers(0, n - 1))
        b = draw(st.integers(a, min(n, a + draw(st.sampled_from((5, 200, 3000, n))))))
        op = draw(st.sampled_from(("gap", "cell", "duplicate", "backwards", "payload",
                                   "cut", "constant_time", "constant_value")))
        if op == "gap":
            keep[order[a:b]] = False
        elif op == "cell":  # one load cell or the amplifier never sent anything
            can_id = draw(st.sampled_from((0x0C1, 0x0C2, 0x1A0)))
            keep &= frames.arbitration_id != can_id
        elif op == "duplicate":
            order = np.concatenate([order[:b], order[a:b], order[b:]])
        elif op == "backwards":
            ts[order[a:b]] -= draw(st.sampled_from((0.001, 0.5, 3.0)))
        elif op == "payload":
            rows = order[a:b]
            data[rows, draw(st.integers(0, 7))] = draw(st.integers(0, 255))
        elif op == "cut":
            order = order[:draw(st.integers(0, 30))]
        elif op == "constant_time":
            ts[order[a:b]] = ts[order[a]]
        else:
            data[order[a:b], :2] = data[order[a], :2]
    order = order[keep[order]]
    table = FrameTable(timestamp=ts, arbitration_id=frames.arbitration_id,
                       is_extended=frames.is_extended, is_remote=frames.is_remote,
                       is_error=frames.is_error, is_fd=frames.is_fd, dlc=frames.dlc, data=data)
    return table.take(order)


metas = st.builds(
    TrialMeta, subject=st.just("P01"), trial=st.just("run-01"),
    waveform=st.sampled_from((None, "square", "sine")),
    frequency_Hz=st.sampled_from((None, 0.0, 10.0, 1e4, 1e12)),
    amplitude_V=st.sampled_from((None, 0.0, 140.0, 1e9)),
    condition=st.sampled_from((None, "on", "off", "alternating")))


@pytest.fixture(scope="module", autouse=True)
def _warm():
    recorded()


@given(frames=damaged_frames(), meta=metas)
def test_a_damaged_trial_is_analysed_or_refused_cleanly(frames, meta):
    signals = decode_trial(frames, RIG)
    try:
        result = analyze_signals(signals, meta, settings=SETTINGS)
    except (AnalysisError, UserInputError) as err:
        event(f"refused: {type(err).__name__}")
        message = str(err)
        # a refusal says why, in a sentence of its own (not an empty or internal error)
        assert message.strip(), f"{type(err).__name__} refused the trial without saying why"
        assert "Traceback" not in message and not message.startswith(("(", "[", "<"))
        return
    event("analysed")
    assert set(result.windows.condition.unique()) <= {"on", "off"}
    assert (result.windows.t_end_s >= result.windows.t_start_s).all()
