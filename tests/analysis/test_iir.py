"""The notch filters without scipy.signal are scipy.signal's: the same coefficients, and
the same filtered signal to within rounding, for any notch, signal and padding."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal

from evtribo.analysis import iir


@given(st.floats(0.5, 999.0), st.floats(0.5, 100.0), st.sampled_from([2000.0, 4000.0, 10000.0]))
def test_the_notch_is_scipys(w0, q, fs):
    b, a = iir.iirnotch(w0, q, fs)
    b_ref, a_ref = signal.iirnotch(w0, q, fs=fs)
    np.testing.assert_array_equal(b, b_ref)
    np.testing.assert_array_equal(a, a_ref)


def _signal(n, fs, seed, offset):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    return offset + 0.01 * np.sin(2 * np.pi * 50.0 * t) + 1e-3 * rng.standard_normal(n)


@settings(max_examples=60, deadline=None)
@given(n=st.integers(0, 3000), order=st.integers(1, 2), scale=st.floats(-2.0, 2.0),
       seed=st.integers(0, 2**32 - 1), fs=st.sampled_from([2000.0, 4000.0]),
       freq=st.sampled_from([50.0, 60.0, 150.0]))
def test_lfilter_is_scipys(*, n, order, scale, seed, fs, freq):
    """A notch, two in cascade (fourth order), any initial state, signals as short as none."""
    b, a = np.array([1.0]), np.array([1.0])
    for k in range(order):
        bk, ak = signal.iirnotch(freq * (k + 1), 30.0, fs=fs)
        b, a = np.convolve(b, bk), np.convolve(a, ak)
    x = _signal(n, fs, seed, 0.3)
    zi = scale * signal.lfilter_zi(b, a)
    ref = signal.lfilter(b, a, x, zi=zi)[0]
    got = iir.lfilter(b, a, x, zi)
    assert got.shape == ref.shape
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-11 * (1 + np.abs(x).max(initial=0.0)))
    np.testing.assert_allclose(iir.lfilter(b, a, x), signal.lfilter(b, a, x), rtol=0,
                               atol=1e-11 * (1 + np.abs(x).max(initial=0.0)))


@settings(max_examples=60, deadline=None)
@given(n=st.integers(2, 40_000), seed=st.integers(0, 2**32 - 1),
       fs=st.sampled_from([2000.0, 4000.0]), freq=st.sampled_from([50.0, 60.0, 100.0, 350.0]),
       offset=st.sampled_from([0.0, 0.3, -40.0]), data=st.data())
def test_filtfilt_is_scipys(*, n, seed, fs, freq, offset, data):
    """As the hum's removal runs it: the padding a few time constants of the notch, or any
    shorter one (none, one sample)."""
    b, a = signal.iirnotch(freq, 30.0, fs=fs)
    x = _signal(n, fs, seed, offset)
    padlen = data.draw(st.sampled_from([0, 1, min(n - 1, int(3 * 30.0 * fs / freq))]))
    ref = signal.filtfilt(b, a, x, padlen=padlen)
    got = iir.filtfilt(b, a, x, padlen)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-11 * (1 + np.abs(x).max(initial=0.0)))


def test_bad_filters_and_signals_are_refused():
    b, a = iir.iirnotch(50.0, 30.0, 2000.0)
    with pytest.raises(ValueError, match="padlen"):
        iir.filtfilt(b, a, np.zeros(10), 10)
    with pytest.raises(ValueError, match="a\\[0\\]"):
        iir.lfilter(b, 2 * a, np.zeros(10))
    with pytest.raises(ValueError, match="w0"):
        iir.iirnotch(1500.0, 30.0, 2000.0)
