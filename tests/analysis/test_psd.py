"""Welch's density in numpy is scipy.signal.welch's (its defaults, the mean of each segment
removed) to within a few units in the last place, for any length, segment and rate."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal

from evtribo.analysis.psd import welch


@settings(max_examples=150, deadline=None)
@given(st.integers(2, 6000), st.integers(0, 3000), st.sampled_from([1.0, 100.0, 2000.0, 4000.0]),
       st.integers(0, 2**32 - 1), st.sampled_from([0.0, 1e-3, 5.0, 1e6]))
def test_welch_is_scipys(nperseg, extra, fs, seed, offset):
    rng = np.random.default_rng(seed)
    n = nperseg + extra
    t = np.arange(n) / fs
    x = offset + rng.normal(size=n) + 0.3 * np.sin(2 * np.pi * 0.12 * fs * t)  # a line
    f_ref, p_ref = signal.welch(x, fs=fs, nperseg=nperseg, detrend="constant")
    f, p = welch(x, fs, nperseg)
    np.testing.assert_array_equal(f, f_ref)
    np.testing.assert_allclose(p, p_ref, rtol=1e-9, atol=1e-12 * p_ref.max())
