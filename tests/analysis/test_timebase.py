"""Sample times taken back from the timestamps a logger gives: jitter, batches, a clock of its
own, stalls, lost frames with and without a counter; the amplifier's status placed among the
load cells' frames."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.analysis.forces.timebase import placed_among, sample_times

RATE = 1000.0


def _stream(seed: int, n: int = 6000, *, jitter_s: float = 1e-3, burst_s: float = 1e-3,
            ppm: float = 100.0, lost: tuple[int, int] | None = None):
    """True sample times of a 1 kHz cell, the frames kept, and the logger's timestamps."""
    rng = np.random.default_rng(seed)
    k = np.arange(n)
    true = 12.0 + k / (RATE * (1 + 40e-6))
    keep = np.ones(n, dtype=bool)
    if lost is not None:
        keep[lost[0]:lost[0] + lost[1]] = False
    rx = true + 2e-4 + rng.exponential(jitter_s, n) if jitter_s else true + 2e-4
    rx = np.maximum.accumulate(rx)
    if burst_s:
        rx = np.ceil(rx / burst_s) * burst_s
    stamps = 12.0 + (rx - 12.0) * (1 + ppm * 1e-6)
    return true[keep], k[keep], stamps[keep]


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10_000), jitter=st.sampled_from([0.0, 2e-4, 1e-3, 3e-3]),
       burst=st.sampled_from([0.0, 1e-3, 5e-3]), ppm=st.floats(-200, 200))
def test_with_a_counter_the_samples_are_evenly_spaced_whatever_the_logger_did(
        seed, jitter, burst, ppm):
    true, k, stamps = _stream(seed, jitter_s=jitter, burst_s=burst, ppm=ppm)
    got = sample_times(stamps, k % 256)
    step = np.diff(got)
    assert np.all(step > 0)
    # evenly spaced on the logger's clock: the cell's period, stretched by the logger's ppm
    np.testing.assert_allclose(step, np.median(step), rtol=1e-6)
    # and where the samples were, but for the latency the line keeps (its mean, and its
    # slow wander over a knot's span: a fraction of the jitter, where the raw stamps stray
    # by several times it)
    offset = got - (12.0 + (true - 12.0) * (1 + ppm * 1e-6))
    assert np.ptp(offset) < 2e-4 + 0.4 * (jitter + burst)
    latency = stamps - (12.0 + (true - 12.0) * (1 + ppm * 1e-6))
    assert abs(np.mean(offset) - np.mean(latency)) < 1e-5 + 0.1 * (jitter + burst)


def test_raw_jittered_timestamps_reorder_samples_the_taken_back_ones_do_not():
    _true, k, stamps = _stream(1, jitter_s=1e-3, burst_s=1e-3)
    assert np.any(np.diff(stamps) == 0)  # batches: many frames at one time
    got = sample_times(stamps, k % 256)
    assert np.all(np.diff(got) > 0.9e-3)


def test_lost_frames_keep_their_places_with_a_counter_and_a_long_outage_counts_whole_periods():
    for lost in ((1000, 37), (2000, 600)):  # a short loss, an outage longer than 256 frames
        true, k, stamps = _stream(2, lost=lost)
        got = sample_times(stamps, k % 256)
        np.testing.assert_allclose(np.diff(got), np.diff(true) * (1 + 100e-6), rtol=1e-4)


def test_without_a_counter_a_loss_is_told_from_a_stalled_logger():
    true, _, stamps = _stream(3, lost=(3000, 80))
    got = sample_times(stamps)
    np.testing.assert_allclose(np.diff(got), np.diff(true) * (1 + 100e-6), rtol=0.05)
    # a stall: 0.3 s without frames, then the backlog at once, nothing lost
    true, k, stamps = _stream(4, jitter_s=2e-4, burst_s=0.0)
    stalled = stamps.copy()
    stalled[(stamps > stamps[2500]) & (stamps < stamps[2500] + 0.3)] = stamps[2500] + 0.3
    got = sample_times(stalled)
    assert np.ptp(np.diff(got)) < 1e-5
    np.testing.assert_allclose(got[-1] - got[0], stamps[-1] - stamps[0], atol=2e-3)
    # with the counter too: the backlog is no outage
    got = sample_times(stalled, k % 256)
    np.testing.assert_allclose(np.diff(got), np.diff(true) * (1 + 100e-6), rtol=1e-4)


def test_a_stream_that_is_not_periodic_keeps_its_timestamps():
    rng = np.random.default_rng(5)
    t = np.sort(rng.uniform(0, 10, 400)) ** 2  # sent on change, ever less often
    np.testing.assert_array_equal(sample_times(t), t)
    short = np.array([0.0, 0.001, 0.002])
    np.testing.assert_array_equal(sample_times(short, np.arange(3)), short)


def _stalled_bus(seed: int, stall_s: float, seconds: float = 8.0):
    """Two 1 kHz cells (counters) and a 50 Hz status on one bus, sent in order, stamped by a
    logger that stalls now and then for up to *stall_s* and then takes its backlog at once
    (as a busy replay or receiver does): the true times and the stamps of each stream."""
    rng = np.random.default_rng(seed)
    cells = np.arange(0.0, seconds, 1e-3) + 3.0
    status = np.arange(0.0, seconds, 0.02) + 3.0 + 3.3e-4
    sent = np.concatenate([cells, cells + 1.1e-4, status])
    kind = np.repeat([0, 1, 2], [cells.size, cells.size, status.size])
    order = np.argsort(sent, kind="stable")
    sent, kind = sent[order], kind[order]
    ready = sent + 1.5e-4 + rng.exponential(5e-5, sent.size)  # the bus and the driver
    for start in rng.uniform(3.0, 3.0 + seconds, 4):  # stalls: nothing read until they end
        end = start + rng.uniform(0.2, 1.0) * stall_s
        ready[(ready > start) & (ready < end)] = end
    step = np.arange(sent.size) * 2e-6  # the reader takes a frame in 2 µs at best
    stamps = np.maximum.accumulate(ready - step) + step
    return [(sent[kind == j], stamps[kind == j]) for j in range(3)]


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), stall=st.sampled_from([0.0, 0.05, 0.4, 0.9]))
def test_the_status_is_placed_among_the_cells_frames_however_late_they_were_stamped(
        seed, stall):
    (tn, sn), (_, st_), (ts, ss) = _stalled_bus(seed, stall)
    fn = sample_times(sn, np.arange(sn.size) % 256)
    ft = sample_times(st_, np.arange(st_.size) % 256)
    placed = placed_among(ss, np.concatenate([sn, st_]), np.concatenate([fn, ft]))
    # against the cells' sample times, each status frame is where it was sent (a
    # millisecond: the cells' period), whatever the stalls made of the cells' own line
    where = np.interp(ts, tn, fn)
    assert np.abs(placed - where).max() < 1.5e-3
    if stall >= 0.4:  # where its own stamps were off by the stall
        assert np.abs(ss - where).max() > 0.1
