"""A load cell's rolling counter and the logger's clock, as real logs break them.

One frame received twice was counted as 255 frames lost (the counter stepping by 0 read as
a whole counter period less one), two frames received swapped as 256, a counter that
restarts at 0 as the frames up to its wrap, and a clock stepping back 0.3 s as 175,360:
sorted by time, the frames from before and after the step interleave. Whatever of these a
trial holds, the frames lost are the frames lost, the duplicates are dropped and counted,
and a restart or a step of the clock is said with its time.
"""

from __future__ import annotations

import re
from functools import cache

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from _counter_faults import inject
from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_trial
from evtribo.canlog.decode import decode_trial
from evtribo.canlog.dropped import missing_frames
from evtribo.canlog.rig import default_rig

RIG = default_rig()
#: Counter periods of the cells, s (8-bit counters at 1 and 2 kHz).
PERIODS_S = (256 / 1000.0, 256 / 2000.0)


@cache
def _trial(seed: int, burst_s: float, drop: float):
    return simulate_trial(SubjectParams(), TrialConfig(
        duration_s=10.0, seed=seed, burst_s=burst_s, drop_probability=drop))


def _said(signals, what: str) -> list[float]:
    """Times (s from the trial's start) of the warnings that say *what*."""
    return [float(m.group(1)) for w in signals.warnings if what in w.text
            for m in [re.search(r"at (\d+\.\d+) s", w.text)] if m]


def _check(faulted, truth, *, polled: bool = False):
    """Decode *faulted* and hold its counts against the truth: exact, but for the frames
    lost at a restart when the adapter stamps frames in polls (*polled*): where the cell's
    clock and the poll's drift by a period, such timestamps cannot tell one frame (see
    :mod:`evtribo.canlog.dropped`), and a restart leaves only them to tell."""
    got = decode_trial(faulted.frames, RIG)
    for cell, name in ((got.normal, "FzCell"), (got.tangential, "FxCell")):
        slack = sum(c == name for c, _ in faulted.restarts) if polled else 0
        assert abs(cell.dropped - truth.nodes[name]["dropped"]) <= slack, (name, cell)
        assert cell.duplicates == faulted.duplicates[name], name
        assert np.all(np.diff(cell.t) >= 0)
    assert got.duplicate_frames == sum(faulted.duplicates.values())
    return got


def test_one_frame_received_twice_is_a_duplicate_not_255_lost():
    frames, truth = _trial(1, 0.0, 0.0)
    got = _check(inject(frames, duplicates=[("FzCell", 0.5, 0)]), truth)
    assert got.normal.dropped == 0 and got.normal.duplicates == 1
    assert any(w.kind == "frames-twice" for w in got.warnings)


def test_two_frames_received_swapped_are_put_back_in_order():
    frames, truth = _trial(1, 0.0, 0.0)
    got = _check(inject(frames, swaps=[("FzCell", 0.5)]), truth)
    assert np.all(np.diff(got.normal.counter.astype(np.int64)) % 256 == 1)


def test_a_counter_that_restarts_at_zero_is_said_not_counted_as_lost():
    frames, truth = _trial(1, 0.0, 0.0)
    faulted = inject(frames, restarts=[("FzCell", 0.5)])
    got = _check(faulted, truth)
    (at,) = _said(got, "restarted")
    assert at == pytest.approx(faulted.restarts[0][1], abs=0.01)


@pytest.mark.parametrize("step_s", [-0.3, -0.004, 0.3])
def test_a_step_of_the_clock_is_said_and_invents_no_loss(step_s):
    frames, truth = _trial(1, 0.0, 0.0)
    faulted = inject(frames, clock_step=(0.5, step_s))
    got = _check(faulted, truth)
    (at,) = _said(got, "clock stepped " + ("back" if step_s < 0 else "ahead"))
    assert at == pytest.approx(faulted.clock_step[0], abs=0.01)
    # the frames after the step are put back on the clock of those before
    assert np.ptp(got.normal.t) == pytest.approx(np.ptp(frames.timestamp), abs=0.01)


def test_a_counter_that_stands_still_is_no_255_frames_lost_a_step():
    """A cell whose counter stood still for 50 frames (the same value, other forces): each
    of its 49 steps read as 255 frames lost and the step out of it as 49, 12,544 in all;
    the frames are the next ones all the same, and the step out of it the counter's own."""
    frames, truth = _trial(1, 0.0, 0.0)
    stuck = frames.take(np.arange(len(frames)))
    stuck.data = frames.data.copy()
    rows = np.flatnonzero(frames.arbitration_id == 0x0C1)[5000:5050]
    stuck.data[rows, 7] = stuck.data[rows[0], 7]
    got = decode_trial(stuck, RIG)
    assert got.normal.dropped == truth.nodes["FzCell"]["dropped"] == 0
    (said,) = [w.text for w in got.warnings if w.kind == "counter-stood"]
    assert "for 49 frames" in said
    assert not [w for w in got.warnings if w.kind == "clock-step"]


def test_timestamps_that_stand_still_between_pauses_leave_the_counters_count():
    """Two blocks of frames stamped alike, a second apart, 10 frames lost between them by
    the counter: the timing has no period to look for whole counter periods with (it
    failed with 'cannot convert float NaN to integer')."""
    t = 1.76e9 + np.r_[np.zeros(500), np.ones(500)]
    counter = np.r_[np.arange(500), np.arange(510, 1010)] % 256
    found = missing_frames(t, counter, 256)
    assert found.count == 10 and [n.kind for n in found.notes] == ["periods-unsure-still"]


def _far_from_whole_counter_periods(step: float) -> bool:
    """A step ahead by whole counter periods is, to any logger, that many frames lost."""
    return all(abs(step / p - round(step / p)) * p > 0.01 for p in PERIODS_S)


@st.composite
def _faults(draw):
    """Faults at places 0.6 s apart at least and 1.5 s or more from the trial's ends, and
    at most one step of the clock (back, or ahead by other than whole counter periods)."""
    slots = draw(st.lists(st.integers(0, 11), min_size=1, max_size=6, unique=True))
    step = draw(st.one_of(st.none(), st.floats(-0.9, -0.002),
                          st.floats(0.01, 0.9).filter(_far_from_whole_counter_periods)))
    share = [(1.5 + 0.6 * s) / 10.0 for s in slots]
    faults: dict = {"duplicates": [], "swaps": [], "restarts": [],
                    "clock_step": None if step is None else (share.pop(), step)}
    later = draw(st.integers(0, 3))
    for where in share:
        kind = draw(st.sampled_from(["duplicates", "swaps", "restarts"]))
        cell = draw(st.sampled_from(["FzCell", "FxCell"]))
        faults[kind].append((cell, where, later) if kind == "duplicates" else (cell, where))
    return faults


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2), burst_s=st.sampled_from([0.0, 1e-3, 8e-3]),
       drop=st.sampled_from([0.0, 0.01]), faults=_faults())
def test_any_duplicates_swaps_restarts_and_one_clock_step_lose_no_frame_and_invent_none(
        seed, burst_s, drop, faults):
    """The frames lost by the simulated bus are counted exactly (to a frame per restart
    where the adapter stamps frames in polls), whatever was injected, and each restart and
    the step of the clock are said: any step of 10 ms or more, and of a poll and a quarter
    or more where the logger stamps its polls (a step within a poll is no step of the
    timestamps, and is counted without being said)."""
    step = faults["clock_step"]
    assume(step is None or abs(step[1]) >= 1.25 * burst_s)
    frames, truth = _trial(seed, burst_s, drop)
    faulted = inject(frames, **faults)
    got = _check(faulted, truth, polled=burst_s > 0)
    assert len(_said(got, "restarted")) == len(faulted.restarts)
    steps = _said(got, "clock stepped")
    assert len(steps) == (0 if step is None else 1 if abs(step[1]) >= 0.01 else len(steps))


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2), drop=st.sampled_from([0.0, 0.01]), share=st.floats(0.15, 0.85),
       step_s=st.one_of(st.floats(0.010, 0.024), st.floats(-0.024, -0.010)))
def test_a_clock_step_within_three_polls_is_found_and_invents_no_lost_frame(seed, drop,
                                                                           share, step_s):
    """A logger's clock stepping 10-24 ms ahead or back where the adapter stamps frames in
    8-ms polls: no single step of the timestamps stands out of the polls' jitter (the
    candidates' rule looks for three polls), and the clock step left in read as counter
    jumps and 759 frames lost of 205. The upper envelope of the frames' lead drops (or
    rises) for good there: the step is found, said once, and taken out."""
    frames, truth = _trial(seed, 8e-3, drop)
    faulted = inject(frames, clock_step=(share, step_s))
    got = _check(faulted, truth, polled=True)
    (at,) = _said(got, "clock stepped " + ("back" if step_s < 0 else "ahead"))
    assert at == pytest.approx(faulted.clock_step[0], abs=0.02)
    assert not _said(got, "jumped") and not _said(got, "restarted")


@settings(max_examples=300, deadline=None)
@given(steps=st.lists(st.one_of(st.floats(-2.0, 2.0), st.sampled_from([0.0, 1e-3, -1e-3, 1e4])),
                      min_size=0, max_size=400),
       counter=st.one_of(st.none(), st.lists(st.integers(0, 255), min_size=400, max_size=400)),
       modulus=st.sampled_from([4, 16, 256]))
def test_any_stream_is_put_in_an_order_without_failing(steps, counter, modulus):
    """Whatever the timestamps and the counter, every frame but the duplicates is kept
    once, in increasing time within each stretch."""
    from evtribo.canlog.sequence import sending_order

    t = 1.76e9 + np.cumsum(np.r_[0.0, steps])
    c = None
    if counter is not None:  # a counter stepping by one but where it does not
        odd = np.asarray(counter[:t.size - 1])
        c = np.cumsum(np.r_[0, np.where(odd < 200, 1, odd % 9 - 3)]).astype(np.int64) % modulus
    got = sending_order(t, c, modulus if c is not None else None,
                        np.zeros((t.size, 8), np.uint8))
    assert np.unique(got.rows).size == got.rows.size == t.size - got.duplicates
    assert np.sort(got.by_time).tolist() == list(range(got.rows.size))
    assert np.isfinite(got.t).all()


@st.composite
def _restarted(draw):
    """A cell's frames at 2 kHz whose firmware restarts once, its counter on from any value
    (a step that runs ahead of the clock by more than the timing's noise), its timer begun
    anew: the first frame after the restart comes *silent* periods late, at another phase,
    sooner than a period after the last one where none is silent. Returns the timestamps
    (in periods), the counter and the frames lost by the timing (the periods silent)."""
    n = 24_000  # a count of 255 too few frames lost for the time they span to belie it
    at = draw(st.integers(2_000, n - 2_000))
    silent = draw(st.integers(0, 3))
    phase = draw(st.floats(-0.9 if silent == 0 else -0.4, 0.4))
    new = draw(st.integers(0, 255))
    assume((new - (at - 1)) % 256 - 1 - silent >= 8)
    k = np.arange(n)
    counter = np.where(k < at, k, new + k - at) % 256
    late = k + np.where(k >= at, silent + phase, 0.0)
    return late, counter, silent


@settings(max_examples=40, deadline=None)
@given(restarted=_restarted(), poll_s=st.sampled_from([0.0, 1e-3, 8e-3]),
       jitter=st.floats(0.0, 0.2), seed=st.integers(0, 2**32 - 1))
def test_a_restart_whose_first_frame_comes_within_a_period_counts_no_whole_period(
        restarted, poll_s, jitter, seed):
    """Where the timing puts the counter's whole step down to the restart (its first frame
    sooner than a period after the last, or a poll's stamps making it look so), the counter
    rebuilt from the timing stepped by 0 there and 255 frames were counted lost of none (257
    of 2, 258 of 3): a restart keeps the counter stepping by one at least, and the frames
    lost there are the timing's count (to one frame where the adapter stamps its polls)."""
    from evtribo.canlog.dropped import missing_frames_received
    from evtribo.canlog.sequence import sending_order

    late, counter, silent = restarted
    rng = np.random.default_rng(seed)
    t = 1.76e9 + (late + rng.uniform(0, jitter, late.size)) / 2000.0
    if poll_s:
        t = np.ceil(t / poll_s) * poll_s
    payload = np.zeros((t.size, 8), np.uint8)
    payload[:, 0] = rng.integers(0, 256, t.size)
    payload[:, 7] = counter
    seq = sending_order(t, counter, 256, payload)
    found = missing_frames_received(seq.t, seq.counter, 256)
    assert abs(found.count - silent) <= (1 if poll_s else 0), (found, seq.jumps)


@st.composite
def _standing(draw):
    """A cell's frames whose counter stands still for a run of frames (the value of the
    frame before, other forces: each frame the next one all the same) before it goes on
    at its own value; some frames lost elsewhere, one by one. Returns the frames' numbers,
    their counter and the frames lost."""
    n = draw(st.integers(40, 600))
    a = draw(st.integers(2, n - 12))
    m = draw(st.integers(1, min(40, n // 3, n - a - 8)))  # most steps by one: a counter
    lost = draw(st.sets(st.integers(1, n - 2).filter(lambda k: not a - 1 <= k <= a + m + 1),
                        max_size=4))
    sent = [k for k in range(n) if k not in lost]
    counter = [(a - 1 if a <= k < a + m else k) % 256 for k in sent]
    return sent, counter, len(lost)


@settings(max_examples=60, deadline=None)
@given(standing=_standing())
def test_a_counter_that_stands_still_holds_the_places_it_steps_over(standing):
    """The frames a counter stood still for are the next frames: the step out of the run
    steps over their places, and is no loss. A stream too short for the timing to judge
    (under 64 frames) counted them lost there (14 of 5), a longer one took the step out
    for the counter jumping (a restart said where there was none)."""
    from evtribo.canlog.dropped import missing_frames_received
    from evtribo.canlog.sequence import sending_order

    sent, counter, lost = standing
    t = 1.76e9 + np.asarray(sent, dtype=np.float64) * 1e-3
    payload = np.zeros((t.size, 8), np.uint8)
    payload[:, 0] = np.arange(t.size) % 251  # another force in every frame
    payload[:, 7] = counter
    seq = sending_order(t, np.asarray(counter), 256, payload)
    assert missing_frames_received(seq.t, seq.counter, 256).count == lost
    assert not seq.jumps
