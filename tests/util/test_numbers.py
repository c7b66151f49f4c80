"""Numbers for people (evtribo.util.numbers), against values worked by hand."""

from __future__ import annotations

import math
import re

import pytest
from hypothesis import given
from hypothesis import strategies as st

from evtribo.util.numbers import (
    UNBOUNDED,
    auto_prefix,
    decimals_for,
    frequency,
    plain,
    quantity,
    r_squared,
    significant,
    voltage,
    with_interval,
)


@pytest.mark.parametrize(("value", "text"), [
    (0.0264716, "0.0265"), (148.3, "148"), (9.996, "10.0"), (0.0009996, "0.00100"),
    (12345.0, "12300"), (-0.0001234, "-0.000123"), (3e-6, "0.00000300"), (0.0, "0.00"),
    (-0.0001, "-0.000100"), (math.nan, "—"), (None, "—"), (math.inf, "∞"),
    (5.55e-14, "< 0.000001"), (-2e-9, "> -0.000001")])
def test_significant(value, text):
    assert significant(value) == text
    assert "e" not in text.lower()


def test_decimals_carry_into_the_next_decade():
    assert decimals_for(9.996) == 1 and decimals_for(9.94) == 2 and decimals_for(250.0) == 0


def test_interval_has_the_values_decimals():
    assert with_interval(26.47, 25.71, 27.41) == "26.5 [25.7, 27.4]"
    assert with_interval(148.4, 99.26, 197.6) == "148 [99, 198]"
    assert with_interval(1.0, math.nan, 2.0) == "1.00 (no interval)"
    assert with_interval(math.nan, 1, 2) == "—"
    # not finer than the interval's half-width to two figures: one rule for a table's cells
    assert with_interval(71.5, -398.0, 541.0) == "72 [-398, 541]"
    assert with_interval(198.2, -168.1, 619.4) == "198 [-168, 619]"
    assert with_interval(0.02647, 0.02571, 0.02741) == "0.0265 [0.0257, 0.0274]"
    # half-widths of 15 and 9.8 give the same decimals
    assert with_interval(70.0, 55.0, 85.0) == "70 [55, 85]"
    assert with_interval(97.7, 87.9, 107.5) == "98 [88, 108]"
    assert with_interval(26.4, 25.2, 27.6) == "26.4 [25.2, 27.6]"
    # a fit that does not determine its value: no interval rather than 10^160 digits
    assert with_interval(16.0, -160.0, 2.4e166) == "16.0 (no interval)"


@given(st.floats(-1e6, 1e6), st.floats(0, 1e6), st.floats(0, 1e6))
def test_an_interval_s_three_numbers_share_their_decimals(value, below, above):
    text = with_interval(value, value - below, value + above)
    if max(abs(value - below), abs(value + above)) > UNBOUNDED * abs(value) and value != 0:
        assert text.endswith(" (no interval)"), text  # an interval that bounds nothing
        return
    numbers = re.findall(r"-?\d+(?:\.(\d+))?", text)
    assert len(numbers) == 3 and len({len(d) for d in numbers}) == 1, text
    assert "e" not in text and len(text) < 60, text


@pytest.mark.parametrize(("value", "text"), [
    (0.15, "0.15"), (2000.0, "2000"), (1e-6, "0.000001"), (0.95, "0.95"), (7, "7"),
    (2.5e-7, "0.00000025")])
def test_settings_are_printed_as_given(value, text):
    assert plain(value) == text


@pytest.mark.parametrize(("r2", "text"), [
    (0.99999942, "> 0.9999"), (0.99953, "0.9995"), (1.0, "1"), (0.87, "0.8700"),
    (-0.2, "-0.2000"), (math.nan, "—")])
def test_r_squared(r2, text):
    assert r_squared(r2) == text


def test_quantities_with_prefixes():
    assert quantity(3.0001e-6, "m", prefix="µ") == "3.00 µm"
    assert quantity(40e3, "Pa") == "40.0 kPa"
    assert quantity(0.012, "Ω·m²") == "12.0 mΩ·m²"
    assert quantity(1.2e9, "Ω·m²") == "1.20 GΩ·m²"
    assert quantity(math.inf, "Ω·m²") == "∞ Ω·m²"
    assert quantity(0.5, "1") == "0.500"
    assert auto_prefix(8.854e-12) == "p" and auto_prefix(999.0) == "" and auto_prefix(0) == ""


def test_drive_settings():
    assert [frequency(f) for f in (10, 10000, 2500, 0.5)] == ["10 Hz", "10 kHz", "2.5 kHz",
                                                             "0.5 Hz"]
    assert [voltage(v) for v in (80.0, 142.5, math.nan)] == ["80 V", "142.5 V", "—"]
