"""evtribo.util.median.median is numpy's median, bit for bit, on the arrays the analysis meets
(time steps with jitter, rounding and pauses) and on any other, NaN included; and
evtribo.util.running's counts are numpy's cumsum."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.util.median import SAMPLE, SMALL, _bracketed, median
from evtribo.util.running import running_count


@st.composite
def arrays(draw):
    """Arrays of any length, even or odd: time steps of a clock (µs-rounded, jittered, with
    pauses), few distinct values (ties across the middle), heavy tails, sorted or reversed
    runs, two halves far apart, a strided sample unlike the rest; sometimes a NaN."""
    n = draw(st.integers(SMALL, 5 * SMALL)) if draw(st.integers(0, 5)) else draw(
        st.integers(0, SMALL))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    kind = draw(st.sampled_from(["steps", "ties", "grid", "tails", "sorted", "halves",
                                  "unlike"]))
    if kind == "steps":
        t = np.round(np.cumsum(5e-4 + rng.normal(0, draw(st.sampled_from([0, 1e-6, 1e-4])),
                                                 n + 1)), 6)
        t[rng.integers(0, n + 1, 3)] += 0.5  # pauses and a step back
        x = np.diff(t)
    elif kind == "ties":
        x = rng.integers(0, draw(st.integers(1, 5)), n).astype(float)
    elif kind == "grid":  # the steps of a grid of float times: a few values, one of them most
        x = np.diff(draw(st.floats(0, 1e9)) + np.arange(n + 1) / draw(st.sampled_from(
            [1000.0, 2000.0, 4000.0, 1234.5])))
    elif kind == "tails":
        x = rng.standard_cauchy(n)
    elif kind == "sorted":
        x = np.sort(rng.normal(size=n))[::draw(st.sampled_from([1, -1]))]
    elif kind == "unlike":  # the sampled values all one value, the others not
        x = rng.normal(size=n)
        x[::max(1, n // SAMPLE)] = draw(st.sampled_from([100.0, 0.0]))
    else:  # two halves apart: the middle values far from each other
        x = np.concatenate([rng.normal(size=n // 2), 1e9 + rng.normal(size=n - n // 2)])
    if n and draw(st.integers(0, 20)) == 0:
        x[draw(st.integers(0, n - 1))] = np.nan
    return x


@settings(max_examples=300, deadline=None)
@given(arrays())
def test_the_median_is_numpys_bit_for_bit(x):
    expect = float(np.median(x)) if x.size else float("nan")
    got = median(x)
    assert got == expect or (np.isnan(got) and np.isnan(expect))
    assert np.float64(got).tobytes() == np.float64(expect).tobytes()


@settings(max_examples=300, deadline=None)
@given(st.integers(1, 60), st.integers(0, 2**32 - 1), st.integers(0, 3), st.data())
def test_any_bracket_gives_numpys_median_or_nothing(n, seed, distinct, data):
    """Whatever values bracket the middle (the sample's guess, right or wrong; at, inside or
    past the middle positions, or none of the array's values), the median from the values
    between them is numpy's, bit for bit, or is not given."""
    rng = np.random.default_rng(seed)
    x = (rng.integers(0, distinct + 1, n) if distinct else rng.normal(size=n)).astype(float)
    pool = sorted({*x.tolist(), -np.inf, np.inf, *(x + 0.5).tolist()})
    lo = data.draw(st.sampled_from(pool))
    hi = data.draw(st.sampled_from([v for v in pool if v >= lo]))
    got = _bracketed(x, lo, hi)
    if got is not None:
        assert np.float64(got).tobytes() == np.float64(np.median(x)).tobytes()
    s = np.sort(x)
    middle = (s[(n - 1) // 2], s[n // 2])
    if lo != hi and lo <= middle[0] and middle[1] <= hi:
        assert got is not None  # both middle values bracketed: given


@settings(max_examples=200, deadline=None)
@given(st.lists(st.booleans(), max_size=300), st.booleans())
def test_running_counts_are_numpys_cumsum(mask, initial):
    """Counted in 32 bits, the running count of a mask is numpy's cumsum (a 0 first when
    asked)."""
    got = running_count(np.array(mask, dtype=bool), initial=initial)
    expect = np.cumsum(np.array(mask, dtype=bool))
    assert got.tolist() == ([0] if initial else []) + expect.tolist()
