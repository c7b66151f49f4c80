"""The recorder's own count of lost frames (the sidecar's ``dropped_frames``), as frames
arrive: a frame received twice was 255 frames lost, two frames received swapped 256, a
counter that restarts at 0 the frames up to its wrap. A duplicate is counted as one, a late
frame counts its loss back, a restart is kept with its time."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from evtribo.acquisition.counters import CounterSpec, CounterTracker
from evtribo.canlog.signal_codec import SignalCodec

SPEC = CounterSpec(message="FzCell", arbitration_id=0x0C1, codec=SignalCodec(
    "FzCounter", start=56, length=8, byte_order="little_endian", is_signed=False,
    is_float=False, scale=1, offset=0))
PERIOD_S = 1e-3


def _frame(k: int, counter: int) -> bytes:
    """Frame *k*'s payload: a force that changes from frame to frame, and the counter."""
    return int(1000 + 37 * k % 4001).to_bytes(3, "little") + bytes(4) + bytes([counter % 256])


@st.composite
def _received(draw):
    """Frames as received: each lost with some chance, some received twice, some swapped
    with the next, the counter restarting at 0 once; and the frames truly lost."""
    n = 1500
    restart = draw(st.one_of(st.none(), st.integers(300, n - 300).filter(
        lambda k: (k - 1) % 256 < 256 - 10)))  # a restart from 247 on is a wrap to see
    # frames lost at a restart cannot be counted (the sidecar says so): none are
    lost = draw(st.sets(st.integers(1, n - 2).filter(
        lambda k: restart is None or k not in (restart - 1, restart)), max_size=40))
    sent = [k for k in range(n) if k not in lost]
    counter = {k: k - restart if restart is not None and k >= restart else k for k in sent}
    frames = [(k, counter[k]) for k in sent]
    for i in sorted(draw(st.sets(st.integers(1, len(frames) - 3), max_size=5)), reverse=True):
        if draw(st.booleans()):
            frames.insert(i + 1, frames[i])                  # received twice
        elif frames[i][0] + 1 == frames[i + 1][0]:
            frames[i], frames[i + 1] = frames[i + 1], frames[i]   # swapped
    dupes = len(frames) - len(sent)
    return frames, len(lost), dupes, restart


@settings(max_examples=40, deadline=None)
@given(received=_received(), batch=st.integers(1, 50))
def test_the_recorders_count_is_the_frames_lost_whatever_was_received(received, batch):
    frames, lost, dupes, restart = received
    tracker = CounterTracker([SPEC])
    payloads = [_frame(k, c) for k, c in frames]
    times = [1.76e9 + k * PERIOD_S + 1e-4 for k, _ in frames]
    for a in range(0, len(frames), batch):
        tracker.update_many(SPEC.key, payloads[a:a + batch], times[a:a + batch])
    tracker.settle()  # the trial ends: the steps that skipped values judged
    assert tracker.dropped == lost
    assert tracker.duplicates == dupes
    restarts = tracker.restarts_by_message(since=1.76e9)
    assert len(restarts.get("FzCell", [])) == (restart is not None)
    if restart is not None:
        assert np.isclose(restarts["FzCell"][0], restart * PERIOD_S + 1e-4)


def test_one_frame_received_twice_and_two_swapped_count_no_frame_lost():
    tracker = CounterTracker([SPEC])
    order = [0, 1, 2, 3, 3, 4, 6, 5, 7, 8]
    for k in order:
        tracker.update_many(SPEC.key, [_frame(k, k)], [k * PERIOD_S])
    assert (tracker.dropped, tracker.duplicates) == (0, 1)


def test_a_counter_that_stands_still_counts_no_frame_lost():
    """Frames 10-19 all read 10 (other forces): no 255 frames lost a step (nor one less),
    and the 10 places the counter steps over after them are theirs; frames 30-34 lost."""
    tracker = CounterTracker([SPEC])
    frames = [(k, 10 if 10 <= k < 20 else k) for k in range(40) if not 30 <= k < 35]
    tracker.update_many(SPEC.key, [_frame(k, c) for k, c in frames],
                        [k * PERIOD_S for k, _ in frames])
    assert tracker.dropped == 5 and tracker.duplicates == 0


@st.composite
def _rebooted(draw):
    """A cell's frames whose firmware restarts once (silent for a while, then its counter on
    from 0 or a low value), some frames lost around it; the frames lost by the timing
    (those lost, and the periods it was silent: a log cannot tell them apart)."""
    n = 3000
    at = draw(st.integers(600, n - 900))        # the first frame after the restart
    new = draw(st.integers(0, 12))             # its counter, had no frame been lost
    silent = draw(st.integers(0, 60))          # periods the cell was silent
    # the counter's step runs ahead of the time by more than the timing's noise (a restart
    # that skips fewer values is frames lost to any reader)
    assume((new - (at - 1)) % 256 - 1 - silent >= 8)
    lost = draw(st.sets(st.integers(at - 6, at + 6), max_size=5))
    sent = [k for k in range(n) if k not in lost]
    counter = [(k if k < at else new + k - at) % 256 for k in sent]
    late = [k + (silent if k >= at else 0) for k in sent]   # in periods from the first
    return sent, counter, np.asarray(late, dtype=np.float64), len(lost) + silent, at


def _as_the_analysis_counts(times, payloads, counter) -> int:
    """The frames lost, as the analysis counts them in a log (canlog/sequence.py, then
    canlog/dropped.py)."""
    from evtribo.canlog.dropped import missing_frames_received
    from evtribo.canlog.sequence import sending_order

    rows = np.frombuffer(b"".join(payloads), dtype=np.uint8).reshape(len(payloads), 8)
    seq = sending_order(times, counter, 256, rows)
    return missing_frames_received(seq.t, seq.counter, 256).count


@settings(max_examples=40, deadline=None)
@given(rebooted=_rebooted(), batch=st.integers(1, 60), jitter=st.floats(0, 0.2),
       seed=st.integers(0, 2**32 - 1), polled=st.booleans())
def test_a_counter_that_restarts_is_counted_as_the_analysis_counts_it(rebooted, batch, jitter,
                                                                      seed, polled):
    """A restart to 0 or a low value, after a silence or none, is no wrap with hundreds of
    frames lost: the recorder counts the frames lost by the timing, as the analysis does
    with the same frames (exactly, frames stamped one by one; to a frame, stamped in an
    adapter's 1-ms polls, which hide where in a poll the restart was)."""
    sent, counter, late, lost, at = rebooted
    rng = np.random.default_rng(seed)
    times = 1.76e9 + (late + rng.uniform(0, jitter, late.size)) * PERIOD_S
    if polled:
        times = np.ceil(times / 1e-3) * 1e-3
    payloads = [_frame(k, c) for k, c in zip(sent, counter, strict=True)]
    tracker = CounterTracker([SPEC])
    for a in range(0, len(sent), batch):
        tracker.update_many(SPEC.key, payloads[a:a + batch], times[a:a + batch])
    tracker.settle()
    restarts = tracker.restarts_by_message()["FzCell"]
    assert restarts == [pytest.approx(times[np.searchsorted(sent, at)], abs=1e-6)] \
        or (polled and len(restarts) == 1)
    if polled:
        assert abs(tracker.dropped - lost) <= 1
    else:
        assert tracker.dropped == lost == _as_the_analysis_counts(times, payloads, counter)
