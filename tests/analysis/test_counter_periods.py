"""A load cell's rolling counter as firmware has it: modulo 2**bits, modulo 10**k, modulo 15
or 250, from 1 rather than 0, by 2 per frame, or not counting at all. Read as counting by
one to its bit width's top, a counter wrapping at 100 made 37,128 frames "lost" of 36,600
received and moved F_el by 7 %, one wrapping at 250 invented 564 lost frames in silence,
one stuck at 0 millions. The counter's law is learnt from its values and their timing (or
declared in the rig file), said where it is not the width's, and a counter that does not
count is said and ignored: F_el as with the width's counter, and never more lost frames
than the trial's time holds."""

from __future__ import annotations

import dataclasses
import tomllib
from functools import cache

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_trial
from evtribo.acquisition.simulator.realism import real_logger, realistic_rig
from evtribo.analysis.settings import AnalysisSettings
from evtribo.analysis.trial import TrialMeta, analyze_signals
from evtribo.canlog.decode import decode_trial
from evtribo.canlog.rig import Rig, default_rig, default_rig_path
from evtribo.results.aggregate import summarize
from evtribo.warning.catalogue import KINDS

RIG = default_rig()
SETTINGS = AnalysisSettings(n_boot=100)
CELLS = {"FzCell": 0x0C1, "FxCell": 0x0C2}
COUNTER_BYTE = 7


def _fel(frames):
    result = analyze_signals(decode_trial(frames, RIG), TrialMeta("P01", "run-01"),
                             settings=SETTINGS)
    est = summarize(result.windows, pd.DataFrame([result.row]), n_boot=100)[0]
    return result, float(est.electrostatic_force_N.iloc[0])


@cache
def _trial(drop: float):
    """A 12-s trial through a lab's logger (late frames, 1-ms batches, its own clock), no
    outage; *drop*: the share of frames lost one by one."""
    cfg = dataclasses.replace(real_logger(realistic_rig(TrialConfig(duration_s=12.0, seed=1))),
                              outages_per_min=0.0, drop_probability=drop)
    frames, truth = simulate_trial(SubjectParams(), cfg)
    return frames, sum(truth.nodes[n]["dropped"] for n in CELLS), _fel(frames)[1]


def _counting(frames, period: int | None, step: int = 1, start: int = 0):
    """*frames* with each cell's counter counting from *start* by *step*, *period* values
    (None: stuck at 0), every frame sent counted (the lost ones too)."""
    out = frames.take(np.arange(len(frames)))
    out.data = frames.data.copy()
    for ident in CELLS.values():
        rows = np.flatnonzero(frames.arbitration_id == ident)
        c = frames.data[rows, COUNTER_BYTE].astype(np.int64)
        sent = c[0] + np.concatenate([[0], np.cumsum(np.diff(c) % 256)])
        out.data[rows, COUNTER_BYTE] = (np.zeros_like(sent) if period is None
                                        else start + step * (sent % period)).astype(np.uint8)
    return out


@st.composite
def _laws(draw):
    """A counter's law as firmware has them: (period, step, start), or None: stuck at 0."""
    if draw(st.booleans()) and draw(st.booleans()):
        return None
    step = draw(st.sampled_from([1, 1, 2]))
    start = draw(st.sampled_from([0, 1]))
    period = draw(st.one_of(st.integers(2, (256 - start) // step),
                            st.sampled_from([10, 100, 15, 250, 255, 256])))
    assume(start + step * (period - 1) <= 255)
    return period, step, start


@settings(max_examples=14, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(law=_laws(), drop=st.sampled_from([0.0, 0.003]))
def test_any_counter_s_period_or_a_stuck_one_gives_the_undisturbed_f_el(law, drop):
    frames, lost, clean = _trial(drop)
    result, fel = _fel(_counting(frames, *(law or (None,))))
    assert fel == pytest.approx(clean, rel=0.05)
    said = [w.text for w in result.warnings if "counter" in w.text]
    assert all(w.kind in KINDS and not KINDS[w.kind].earlier for w in result.warnings)
    dropped = result.row["dropped_frames"]
    assert dropped <= lost  # never more than were lost
    if law is None:
        assert sum("does not count (it stays at 0)" in w for w in said) == 2, said
        return
    period, step, start = law
    if period >= 8:  # a shorter one cannot tell one frame lost from a whole period
        assert dropped == lost
    top = start + step * (period - 1)
    if period != _width_period(step, start):
        text = f"counts from {start} to {top}" + (f" by {step}" if step > 1 else "")
        assert sum(text in w and f"every {period} frames" in w for w in said) == 2, said
    else:
        assert not said, said


def _width_period(step: int, start: int) -> int | None:
    """The period of an 8-bit counter counting to its top by *step* from *start* (None: it
    starts where no such counter does)."""
    return (256 - start + step - 1) // step if start < step else None


def test_a_lossy_8_bit_counter_whose_top_values_are_lost_keeps_its_width():
    """Frames whose counter reads 250 to 255 all lost, at every wrap: the counter never
    reaches its top, yet counts to it (the timing shows the frames a wrap skips); its period
    is not taken for 250, and the frames are counted lost."""
    frames, _, _ = _trial(0.0)
    keep = np.ones(len(frames), dtype=bool)
    for ident in CELLS.values():
        rows = np.flatnonzero(frames.arbitration_id == ident)
        keep[rows[frames.data[rows, COUNTER_BYTE] >= 250]] = False
    signals = decode_trial(frames.take(keep), RIG)
    assert signals.dropped_frames == int(np.count_nonzero(~keep))
    assert not [w for w in signals.warnings if "counter" in w.text], signals.warnings


def _declared(**periods: int):
    """The default rig with the counters' periods its rig file declares."""
    table = tomllib.loads(default_rig_path().read_text(encoding="utf-8"))
    return Rig.from_mapping({**table, **periods}, default_rig_path().parent)


def test_a_period_declared_in_the_rig_file_is_used_as_it_is():
    frames, _, _ = _trial(0.0)
    rig = _declared(normal_force_counter_period=100, tangential_force_counter_period=100)
    assert rig.fingerprint() != RIG.fingerprint()  # a decoded trial of the other not reused
    signals = decode_trial(_counting(frames, 100), rig)
    assert signals.dropped_frames == 0
    assert (signals.normal.counter_period, signals.tangential.counter_period) == (100, 100)
    assert not [w for w in signals.warnings if "counter" in w.text], signals.warnings


def test_a_period_the_counter_belies_counts_no_more_frames_lost_than_the_time_holds():
    """A rig file that declares 200 for counters that count 0 to 99 would make 100 frames
    lost at every wrap, 36,600 in all of 36,600 received: more than the trial's time holds
    at the cells' rates; the timestamps count them instead, and a note says why."""
    frames, lost, _ = _trial(0.003)
    rig = _declared(normal_force_counter_period=200, tangential_force_counter_period=200)
    signals = decode_trial(_counting(frames, 100), rig)
    assert signals.dropped_frames <= lost
    notes = [w for w in signals.warnings if w.kind == "counter-overcounts"]
    assert {w.value("cell") for w in notes} == {"normal", "tangential"}, signals.warnings
    assert all("it does not count every frame" in w.text for w in notes)
