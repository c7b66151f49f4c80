"""Steps of the alignment and of the steady-sliding search held against their plain
definitions: the means of samples at one time, the erosion of a stroke's steady points and
the split of a steady run into windows."""

import itertools

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.analysis.forces.align import _group_means
from evtribo.analysis.friction.windows import _Grid, _split, _steady


@settings(max_examples=300, deadline=None)
@given(st.integers(1, 60), st.integers(0, 6), st.data())
def test_a_point_is_steady_when_every_point_within_half_a_span_is(n, h, data):
    """Eroded by h: a point stays steady when the 2h + 1 points about it are all inside
    the stroke and all steady (the ratio and the normal force at least their fractions of
    the stroke's medians)."""
    span = 2 * h + 1
    fn = np.array(data.draw(st.lists(st.sampled_from([0.5, 1.0, 1.5]), min_size=n,
                                     max_size=n)))
    ft = np.array(data.draw(st.lists(st.sampled_from([-0.4, 0.1, 0.5, 0.6]), min_size=n,
                                     max_size=n)))
    a = data.draw(st.integers(0, 3))
    pad = np.ones(a)
    grid = _Grid(1e-3, np.r_[pad, fn, pad], np.r_[pad, ft, pad], np.r_[pad, fn, pad],
                 np.r_[pad, ft, pad], span, np.empty((0, 2), dtype=np.intp))
    got = _steady(grid, a, a + n, level_fraction=0.5, contact_fraction=0.8)
    r = np.abs(ft) / fn
    point = (r >= 0.5 * np.median(r)) & (fn >= 0.8 * np.median(fn))
    expect = [all(0 <= j < n and point[j] for j in range(i - h, i + h + 1))
              for i in range(n)]
    assert got.tolist() == expect


@settings(max_examples=500, deadline=None)
@given(st.integers(0, 10_000), st.integers(0, 3000), st.integers(1, 400),
       st.integers(1, 2000), st.integers(1, 300))
def test_a_steady_run_splits_into_whole_quanta_about_its_middle(start, length, min_len,
                                                                 max_len, q):
    """Windows of a run: a whole number of quanta, trimmed about the run's middle, in parts
    as equal as whole quanta allow, each shorter than max_len plus a quantum and at least
    min_len long; none when the quanta that fit fall short of min_len."""
    stop = start + length
    got = _split(start, stop, min_len, max_len, q)
    n_q = length // q
    if n_q * q < min_len:
        assert got == []
        return
    first = start + (length - n_q * q) // 2
    parts = max(1, min(n_q, -(-n_q * q // max_len)))
    sizes = [n_q // parts + (1 if k < n_q % parts else 0) for k in range(parts)]
    edges = [first + q * sum(sizes[:k]) for k in range(parts + 1)]
    expect = [(x, y) for x, y in itertools.pairwise(edges) if y - x >= min_len]
    assert got == expect
    assert all(type(x) is int and type(y) is int for x, y in got)
    assert all(start <= x < y <= stop and (y - x) % q == 0 for x, y in got)
    assert all(y - x < max_len + q for x, y in got)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.floats(allow_nan=False, allow_infinity=False, width=64), min_size=1,
                max_size=60), st.data())
def test_repeated_times_average_as_one_reduceat_does(values, data):
    """The means of groups of samples at one time (most groups one sample) equal one
    ``np.add.reduceat`` over every group divided by the counts, bit for bit, signed
    zeros, huge values and a last group that runs to the end included."""
    value = np.array(values)
    starts = sorted(set(data.draw(st.lists(st.integers(1, len(values) - 1), max_size=20))
                        if len(values) > 1 else []))
    first = np.array([0, *starts], dtype=np.intp)
    counts = np.diff(np.append(first, value.size))
    with np.errstate(over="ignore", invalid="ignore"):
        expect = np.add.reduceat(value, first) / counts
        got = _group_means(value, first)
    assert got.tobytes() == expect.tobytes()
