"""Welch's density in numpy is scipy.signal.welch's (a periodic Hann window, each segment's
mean or linear trend removed, zero-padded or not) to within a few units in the last place,
for any length, segment, transform length and rate."""

import numpy as np
import pytest
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


@settings(max_examples=150, deadline=None)
@given(nperseg=st.integers(3, 3000), extra=st.integers(0, 3000), pad=st.integers(0, 3),
       fs=st.sampled_from([1.0, 100.0, 2000.0]), seed=st.integers(0, 2**32 - 1),
       offset=st.sampled_from([0.0, 1e-3, 5.0, 1e6]), drift=st.sampled_from([0.0, 1.0, -40.0]))
def test_linear_detrend_and_padding_are_scipys(*, nperseg, extra, pad, fs, seed, offset, drift):
    """As :func:`evtribo.analysis.spectra.dominant_frequency` calls it: each segment's line
    removed, transformed over as many points or up to the next powers of two."""
    rng = np.random.default_rng(seed)
    n = nperseg + extra
    t = np.arange(n) / fs
    x = (offset + drift * t + rng.normal(size=n)
         + 0.3 * np.sin(2 * np.pi * 0.12 * fs * t))
    nfft = nperseg if pad == 0 else int(2 ** (np.ceil(np.log2(nperseg)) + pad - 1))
    nfft = max(nfft, nperseg)
    f_ref, p_ref = signal.welch(x, fs=fs, window="hann", nperseg=nperseg, nfft=nfft,
                                detrend="linear")
    f, p = welch(x, fs, nperseg, nfft=nfft, detrend="linear")
    np.testing.assert_array_equal(f, f_ref)
    # removing a line from samples far from zero leaves errors of eps * |x| in each sample
    # (scipy by least squares, here in closed form): bound the density's difference so
    rounding = 1e-12 * np.abs(x).max() * np.sqrt(p_ref.max())
    np.testing.assert_allclose(p, p_ref, rtol=1e-8, atol=1e-11 * p_ref.max() + rounding)


def test_bad_arguments_are_refused():
    x = np.zeros(100)
    with pytest.raises(ValueError, match="nfft"):
        welch(x, 1.0, 50, nfft=40)
    with pytest.raises(ValueError, match="detrend"):
        welch(x, 1.0, 50, detrend="quadratic")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="nperseg"):
        welch(x, 1.0, 101)
