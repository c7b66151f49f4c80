"""A log line stamped at a time no clock gives (2**63 s: a logger's clock read before it was
set) was read as a frame: the trial's clock then seemed to jump by 292 billion years and
back, its frames after it were moved by as much (losing their milliseconds to the float's
precision), and the trial's F_el row could go missing with only the clock warnings to say
why. Such a line is damaged: skipped and named (file and line), the rest analysed as if
it were not there."""

from __future__ import annotations

import logging

import can
import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_trial
from evtribo.analysis.settings import AnalysisSettings
from evtribo.analysis.trial import TrialMeta, analyze_signals
from evtribo.canlog.decode import decode_trial
from evtribo.canlog.io.candump_writer import write_candump
from evtribo.canlog.io.registry import read_frames
from evtribo.canlog.io.table import IMPOSSIBLE_TIMESTAMP
from evtribo.canlog.rig import default_rig
from evtribo.errors import LogFormatError
from evtribo.results.aggregate import summarize

RIG = default_rig()
T0 = 1763700000.0
FRAME = "vcan0 0C1#1122334455667788"

#: Times no clock gives: 2**63 or more (a 64-bit clock's range), as a log writes them.
IMPOSSIBLE = st.one_of(st.sampled_from([2.0**63, 2.0**64, 1e19]),
                       st.floats(IMPOSSIBLE_TIMESTAMP, 1e30))


def _stamp(t: float) -> str:
    return f"({t:.6f})"


@settings(max_examples=60, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(bad=IMPOSSIBLE, where=st.integers(0, 39))
def test_a_candump_line_stamped_2_63_or_more_is_skipped_and_named(tmp_path, bad, where):
    """Whatever the time and wherever the line, it is damaged and every other frame read."""
    times = T0 + 1e-3 * np.arange(40)
    lines = [f"{_stamp(t)} {FRAME}" for t in times]
    lines[where] = f"{_stamp(bad)} {FRAME}"
    path = tmp_path / "trial.log"
    path.write_text("\n".join(lines) + "\n")
    frames, report = read_frames(path)
    assert report.skipped_lines == 1 and report.skipped[0][0] == where + 1
    assert "beyond any clock's range" in report.skipped[0][1]
    np.testing.assert_array_equal(frames.timestamp, np.delete(times, where))
    with pytest.raises(LogFormatError) as err:
        read_frames(path, strict=True)
    assert err.value.line == where + 1


@pytest.mark.parametrize("bad", [2.0**63, -(2.0**63), 1e20])
def test_a_python_can_record_stamped_2_63_or_more_is_skipped(tmp_path, caplog, bad):
    path = tmp_path / "trial.csv"
    with can.Logger(path) as writer:
        for i, t in enumerate([T0, T0 + 1e-3, bad, T0 + 3e-3]):
            writer.on_message_received(can.Message(timestamp=t, arbitration_id=0xC1 + i % 2,
                                                   is_extended_id=False, data=bytes(8)))
    with caplog.at_level(logging.WARNING):
        frames, report = read_frames(path)
    assert report.skipped_lines == 1 and "beyond any clock's range" in report.skipped[0][1]
    np.testing.assert_allclose(frames.timestamp - T0, [0.0, 1e-3, 3e-3], atol=1e-6)
    assert "skipped damaged line" in caplog.text


def _fel(signals):
    settings_ = AnalysisSettings(n_boot=200)
    result = analyze_signals(signals, TrialMeta("P01", "run-01"), settings=settings_)
    est = summarize(result.windows, pd.DataFrame([result.row]), n_boot=200)[0]
    return result, float(est.electrostatic_force_N.iloc[0])


@pytest.mark.parametrize("bad", [2.0**63, 2.0**64])
def test_a_trial_with_a_line_stamped_2_63_s_is_analysed_as_without_it(tmp_path, bad):
    frames, _ = simulate_trial(SubjectParams(), TrialConfig(duration_s=12.0, seed=4))
    path = tmp_path / "run-01.log"
    write_candump(path, frames)
    lines = path.read_text().splitlines(keepends=True)
    where = len(lines) // 2
    lines[where] = f"{_stamp(bad)} {lines[where].split(' ', 1)[1]}"
    path.write_text("".join(lines))
    read, report = read_frames(path)
    assert report.skipped == [(where + 1, report.skipped[0][1])]
    result, fel = _fel(decode_trial(read, RIG))
    _, clean = _fel(decode_trial(frames, RIG))
    assert fel == pytest.approx(clean, rel=0.01)
    assert result.row["duration_s"] == pytest.approx(12.0, abs=0.05)
    said = " | ".join(w.text for w in result.warnings)
    assert "clock stepped" not in said and "no frame of the load cells" not in said, said
