"""A counter's law from its values and timing (:mod:`evtribo.canlog.counters.law`), and a
count of lost frames that the trial's time bounds (:mod:`evtribo.canlog.dropped`)."""

from __future__ import annotations

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from evtribo.canlog.counters.law import counter_law
from evtribo.canlog.dropped import SLACK_SHARE, missing_frames


def _width_period(step: int, start: int) -> int | None:
    """The period of an 8-bit counter counting to its top by *step* from *start* (None: it
    starts where no such counter does)."""
    return (256 - start + step - 1) // step if start < step else None


@settings(max_examples=60, deadline=None)
@given(period=st.integers(2, 256), step=st.sampled_from([1, 2]), start=st.sampled_from([0, 1]),
       batch_s=st.sampled_from([0.0, 1e-3]), ppm=st.floats(-300, 300),
       rate=st.sampled_from([333.0, 1000.0, 2000.0]), seed=st.integers(0, 10))
def test_a_counter_s_period_is_read_from_its_timing(period, step, start, batch_s, ppm, rate,  # noqa: PLR0917
                                                    seed):
    """Any period from 2 to the bit width's, from 0 or 1, by 1 or 2, through a logger that
    stamps frames one by one or in 1-ms batches, on its own clock: the law is the
    firmware's."""
    assume(start + step * (period - 1) <= 255)
    rng = np.random.default_rng(seed)
    n = int(12 * rate)
    t = np.arange(n) / rate * (1 + 1e-6 * ppm) + 2e-4 + rng.exponential(1e-4, n)
    if batch_s:
        t = np.ceil(t / batch_s) * batch_s
    t = np.maximum.accumulate(t)
    law = counter_law(t, start + step * (np.arange(n) % period), 8)
    assert law.counts and law.step == step
    if period == _width_period(step, start):  # to the width's top
        assert law.period == period and law.note is None and not law.learnt
    else:
        assert (law.start, law.period, law.learnt) == (start, period, True), law


@settings(max_examples=100, deadline=None)
@given(values=st.lists(st.integers(0, 255), min_size=400, max_size=400),
       counting=st.floats(0.0, 1.0), modulus=st.sampled_from([None, 16, 100, 256]),
       seed=st.integers(0, 5))
def test_no_counter_counts_more_frames_lost_than_the_time_holds(values, counting, modulus,
                                                                seed):
    """Whatever a counter's values (counting by one for a share of the frames, anything
    elsewhere) and the period it is read with, the frames counted lost are at most those
    the stream's time holds at its rate, beyond the slack allowed."""
    rng = np.random.default_rng(seed)
    n = len(values)
    t = 1.76e9 + np.arange(n) * 1e-3 + rng.exponential(5e-5, n)
    c = np.where(rng.uniform(size=n) < counting, np.arange(n) % (modulus or 256),
                 np.asarray(values))
    found = missing_frames(np.sort(t), c, modulus)
    held = (t.max() - t.min()) / 1e-3 - (n - 1)
    assert found.count <= held + SLACK_SHARE * n + 12, found


@settings(max_examples=100, deadline=None)
@given(steps=st.lists(st.one_of(st.floats(0.0, 0.01), st.sampled_from([0.0, 1e-3])),
                      min_size=1, max_size=150),
       counter=st.one_of(st.none(), st.just(0)))
def test_a_short_irregular_stream_is_counted_without_failing(steps, counter):
    """A few dozen frames stamped in bursts, without a counter or with one stuck at 0 (a
    cell that sent little, a recording just begun): too few for the timing's windows, and
    the count failed ('cannot convert float NaN to integer'); none is counted, and the note
    says why."""
    t = 1.76e9 + np.cumsum(np.r_[0.0, steps])
    found = missing_frames(t, None if counter is None else np.zeros(t.size, np.int64))
    assert found.count >= 0


@settings(max_examples=40, deadline=None)
@given(period=st.integers(8, 255), start=st.sampled_from([0, 1]),
       received=st.lists(st.tuples(st.integers(50, 5_000), st.integers(-1, 3)), min_size=1,
                         max_size=4),
       batch_s=st.sampled_from([0.0, 1e-3]), seed=st.integers(0, 10))
def test_a_counter_s_period_is_read_whatever_frames_came_twice_or_late(period, start, received,
                                                                       batch_s, seed):
    """A frame received twice (a few frames after itself, stamped as the frame it follows)
    or late (after the frame sent after it): read as a step ahead by nearly a period, it put
    every later frame's place a period off the timing's line, and one such frame in a
    trial left a counter counting 0 to 99 taken for its width's (156 frames lost a wrap,
    the counter ignored for counting more than the time holds)."""
    rng = np.random.default_rng(seed)
    n = 6000
    t = np.arange(n) / 1000.0 + 2e-4 + rng.exponential(1e-4, n)
    c = start + np.arange(n) % period
    order = list(range(n))
    for at, later in sorted(received, reverse=True):
        if later < 0:
            order[at], order[at + 1] = order[at + 1], order[at]      # late
        else:
            order.insert(at + later + 1, -1 - at)                     # twice
    rows = np.array([k if k >= 0 else -1 - k for k in order])
    stamp = t[rows]
    for i, k in enumerate(order):  # a copy is stamped as the frame it follows
        if k < 0:
            stamp[i] = stamp[i - 1]
    stamp = np.maximum.accumulate(stamp)
    if batch_s:
        stamp = np.ceil(stamp / batch_s) * batch_s
    law = counter_law(stamp, c[rows], 8)
    if period == 256 - start:  # to the width's top
        assert law.period == period and law.note is None
    else:
        assert (law.start, law.period, law.learnt) == (start, period, True), law


@settings(max_examples=60, deadline=None)
@given(n=st.integers(8, 15), step=st.sampled_from([1, 2]), first=st.integers(0, 200),
       lost=st.sets(st.integers(1, 6), max_size=1))
def test_a_few_frames_say_their_counter_s_step(n, step, first, lost):
    """A recording just begun (under 16 frames of a cell): too few to read a period, but a
    counter counting by 2 steps by 2 (its start, odd or even, kept); read as stepping by 1,
    each of its frames counted one lost on the live display."""
    sent = [k for k in range(n) if k not in lost]
    c = (first * step + step * np.asarray(sent)) % 256
    law = counter_law(np.asarray(sent) * 1e-3, c, 8)
    assert (law.step, law.sure) == (step, False), law
    assert law.start == (first * step) % step
    place = law.place(c)
    assert int(np.count_nonzero(np.mod(np.diff(place), law.period) != 1)) == len(lost)
