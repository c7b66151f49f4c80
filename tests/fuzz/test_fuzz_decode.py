"""The decoder on arbitrary frame tables: the rig's IDs with any payload and length, other
IDs, remote and error frames, NaN / infinite / huge / duplicate / backwards timestamps.
It decodes what it can, counts the rest, and never raises or warns (numpy's overflow and
invalid-cast warnings are errors under the suite's ``filterwarnings = error``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from evtribo.canlog.decode import decode_messages, decode_trial
from evtribo.canlog.decode_table import decoded_table
from evtribo.canlog.dropped import count_dropped
from evtribo.canlog.io import FrameTable
from evtribo.canlog.rig import default_rig, load_rig

RIGS = {"default": default_rig(),
        "motorola": load_rig(Path(__file__).parents[1] / "data" / "rigs" / "motorola.toml")}

ODD_TIMES = (np.nan, np.inf, -np.inf, 1e308, -1e308, 0.0, -1.0, 1e16, 5e-324)


@st.composite
def frame_tables(draw, rig):
    ids = sorted({ref.message.frame_id for ref in rig.roles.values()})
    ext = {ref.message.frame_id: bool(ref.message.is_extended_frame)
           for ref in rig.roles.values()}
    n = draw(st.integers(0, 80))
    width = draw(st.sampled_from((8, 64)))
    rows = []
    t = 1_763_700_000.0
    for _ in range(n):
        rig_frame = draw(st.booleans())
        can_id = draw(st.sampled_from(ids)) if rig_frame else draw(st.integers(0, 0x1FFFFFFF))
        is_ext = ext[can_id] if rig_frame and draw(st.integers(0, 9)) else draw(st.booleans())
        t += draw(st.sampled_from((1e-3, 1e-3, 5e-4, 0.0, -2e-3, 0.5, 100.0)))
        ts = draw(st.sampled_from(ODD_TIMES)) if draw(st.integers(0, 15)) == 0 else t
        dlc = draw(st.sampled_from((8, 8, 8, 0, 1, 4, 7, 12, 64)))
        dlc = min(dlc, width)
        payload = draw(st.binary(min_size=dlc, max_size=dlc))
        kind = draw(st.sampled_from(("data",) * 8 + ("remote", "error")))
        rows.append((ts, can_id, is_ext, kind, dlc, payload))
    data = np.zeros((n, width), np.uint8)
    for i, r in enumerate(rows):
        data[i, :r[4]] = np.frombuffer(r[5], np.uint8)
    return FrameTable(
        timestamp=np.array([r[0] for r in rows], dtype=np.float64),
        arbitration_id=np.array([r[1] for r in rows], dtype=np.uint32),
        is_extended=np.array([r[2] and r[3] != "error" for r in rows], dtype=bool),
        is_remote=np.array([r[3] == "remote" for r in rows], dtype=bool),
        is_error=np.array([r[3] == "error" for r in rows], dtype=bool),
        is_fd=np.array([r[4] > 8 for r in rows], dtype=bool),
        dlc=np.array([r[4] for r in rows], dtype=np.uint8),
        data=data)


def check_cell(cell):
    assert cell.t.shape == cell.value.shape
    assert cell.counter is None or cell.counter.shape == cell.t.shape
    assert cell.dropped >= 0
    assert np.isfinite(cell.t).all(), "a sample at a time that is no number"
    assert (np.diff(cell.t) >= 0).all(), "samples out of time order"


@pytest.mark.parametrize("rig_name", sorted(RIGS))
@given(data=st.data())
def test_decode_trial_never_fails(rig_name, data):
    rig = RIGS[rig_name]
    frames = data.draw(frame_tables(rig))
    trial = decode_trial(frames, rig)
    check_cell(trial.normal)
    check_cell(trial.tangential)
    assert trial.frames + trial.ignored_frames == len(frames)
    assert trial.frames >= len(trial.normal.t) + len(trial.tangential.t) - 0
    if trial.excitation is not None:
        ex = trial.excitation
        assert np.isfinite(ex.t).all() and (np.diff(ex.t) >= 0).all()
        for name in ("enabled", "amplitude", "frequency", "waveform"):
            values = getattr(ex, name)
            assert values is None or len(values) == len(ex.t), name


@pytest.mark.parametrize("rig_name", sorted(RIGS))
@given(data=st.data())
def test_decode_messages_and_the_decode_table_never_fail(rig_name, data):
    rig = RIGS[rig_name]
    frames = data.draw(frame_tables(rig))
    decoded = decode_messages(frames, rig.database)
    for msg in decoded.values():
        assert len(msg.index) == len(msg.timestamp)
        for name in msg.raw:
            assert msg.scaled(name).shape == msg.timestamp.shape
    table = decoded_table(frames, rig.database, choices=data.draw(st.booleans()))
    assert len(table) == sum(len(m) for m in decoded.values())


@given(t=st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=50),
       counter=st.none() | st.lists(st.integers(-(2**40), 2**40), max_size=50))
def test_dropped_frames_of_any_timestamps(t, counter):
    t = np.asarray(t, dtype=np.float64)
    count = None if counter is None else np.resize(np.asarray(counter, np.int64), len(t))
    assert count_dropped(t, count, None if count is None else 256) >= 0
