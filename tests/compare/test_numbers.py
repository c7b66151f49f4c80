"""Numbers for people (evtribo.compare.numbers), against values worked by hand."""

from __future__ import annotations

import math

import pytest

from evtribo.compare.numbers import (
    auto_prefix,
    decimals_for,
    frequency,
    quantity,
    r_squared,
    significant,
    voltage,
    with_interval,
)


@pytest.mark.parametrize(("value", "text"), [
    (0.0264716, "0.0265"), (148.3, "148"), (9.996, "10.0"), (0.0009996, "0.00100"),
    (12345.0, "12300"), (-0.0001234, "-0.000123"), (3e-6, "0.00000300"), (0.0, "0.00"),
    (-0.0001, "-0.000100"), (math.nan, "—"), (None, "—"), (math.inf, "∞")])
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
