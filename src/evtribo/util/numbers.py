"""Numbers for people: significant figures without scientific notation, unit prefixes.

The report and its exported tables print every quantity in a unit that keeps it readable
(forces in mN, air gaps in µm, moduli in kPa) and to three significant figures, never in
scientific notation nor finer than a millionth of its unit; an interval is printed with the
decimals of the value it belongs to, no finer than its half-width to two significant
figures, so ``148 [99, 198]``, ``72 [-398, 541]`` and ``26.5 [25.7, 27.4]`` read at a
glance. Settings are printed as given (:func:`plain`: ``0.15``, not ``0.1500``).

>>> significant(0.0264716, 3)
'0.0265'
>>> with_interval(26.47, 25.71, 27.41)
'26.5 [25.7, 27.4]'
>>> r_squared(0.99999942)
'> 0.9999'
>>> quantity(3.0e-6, "m", prefix="µ")
'3.00 µm'
"""

from __future__ import annotations

import math
from decimal import Decimal
from typing import Any

__all__ = ["KEY_DECIMALS", "PREFIXES", "TINY", "UNBOUNDED", "amplitude_key", "auto_prefix",
           "decimals_for", "frequency", "frequency_key", "plain", "quantity", "r_squared",
           "significant", "to_float", "voltage", "with_interval"]

#: SI prefixes and their powers of ten.
PREFIXES: dict[str, int] = {"p": -12, "n": -9, "µ": -6, "m": -3, "": 0, "k": 3, "M": 6,
                            "G": 9, "T": 12}

#: What the page prints for a value that is missing or not finite.
MISSING = "—"
#: The smallest magnitude printed as a number (in the unit printed): below it, ``< 0.000001``
#: (an exact fit's RMSE, 5.55e-14, is no number to print to its last digit).
TINY = 1e-6
_TINY_DECIMALS = 6


def to_float(value: Any) -> float:
    """*value* as a float (NaN when it is missing or not a number).

    Parameters
    ----------
    value : Any
        A number, a string holding one, None.

    Returns
    -------
    float
        The number, or NaN.
    """
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def decimals_for(value: float, sig: int = 3) -> int:
    """Decimals that show *value* to *sig* significant figures (0 for large values).

    Parameters
    ----------
    value : float
        The number.
    sig : int
        Significant figures.

    Returns
    -------
    int
        Digits after the decimal point, >= 0.
    """
    if not math.isfinite(value) or value == 0:
        return max(sig - 1, 0)
    magnitude = math.floor(math.log10(abs(value)))
    # rounding may carry into the next decade (9.996 -> 10.0)
    if round(abs(value), max(sig - 1 - magnitude, 0)) >= 10 ** (magnitude + 1):
        magnitude += 1
    return max(sig - 1 - magnitude, 0)


def _fixed(value: float, decimals: int) -> str:
    text = f"{value:.{decimals}f}"
    if text.startswith("-") and float(text) == 0:
        text = text[1:]  # no "-0.00"
    return text


def _trim(text: str) -> str:
    """``10.0`` -> ``10``, ``2.50`` -> ``2.5``."""
    return text.rstrip("0").rstrip(".") if "." in text else text


def significant(value: Any, sig: int = 3, *, decimals: int | None = None) -> str:
    """*value* to *sig* significant figures, in positional notation (never ``1e-06``).

    Parameters
    ----------
    value : Any
        The number (None, NaN and text that is no number print as ``—``).
    sig : int
        Significant figures.
    decimals : int, optional
        Print with this many decimals instead.

    Returns
    -------
    str
        The number.
    """
    v = to_float(value)
    if not math.isfinite(v):
        return "∞" if v == math.inf else "-∞" if v == -math.inf else MISSING
    if decimals is None and 0 < abs(v) < TINY:
        return f"< {plain(TINY)}" if v > 0 else f"> -{plain(TINY)}"
    places = decimals_for(v, sig) if decimals is None else decimals
    if decimals is None and abs(v) >= 10 ** sig:  # 12345 -> 12300
        magnitude = math.floor(math.log10(abs(v)))
        v = round(v, sig - 1 - magnitude)
    return _fixed(v, places)


#: An interval reaching beyond this many times its value bounds nothing: it is not printed.
UNBOUNDED = 1e6


def with_interval(value: Any, low: Any, high: Any, *, sig: int = 3) -> str:
    """``value [low, high]``, the three with the same decimals: the value's to *sig*
    significant figures, fewer when the interval's half-width needs fewer, shown to two
    significant figures when it begins with 1 or 2 and to one otherwise (a value is not
    printed finer than its uncertainty; ``70 [55, 85]`` and ``98 [88, 108]`` alike).

    Parameters
    ----------
    value, low, high : Any
        The estimate and its interval, in the unit printed.
    sig : int
        Significant figures of the value.

    Returns
    -------
    str
        ``26.5 [25.7, 27.4]``, ``72 [-398, 541]``; the value alone followed by ``(no
        interval)`` when a bound is missing or beyond :data:`UNBOUNDED` times the value (a
        fit whose data do not determine the value), ``—`` when the value is missing.
    """
    v, lo, hi = to_float(value), to_float(low), to_float(high)
    if not math.isfinite(v):
        return MISSING
    if not (math.isfinite(lo) and math.isfinite(hi)) or (
            v != 0 and max(abs(lo), abs(hi)) > UNBOUNDED * abs(v)):
        return f"{significant(v, sig)} (no interval)"
    places = min(decimals_for(v, sig), _TINY_DECIMALS)
    if hi > lo:  # the half-width to two figures when it begins with 1 or 2, else to one
        half = (hi - lo) / 2
        lead = int(f"{half:e}"[0])
        places = min(places, decimals_for(half, 2 if lead <= 2 else 1))
    return (f"{significant(v, decimals=places)} [{significant(lo, decimals=places)}, "
            f"{significant(hi, decimals=places)}]")


def plain(value: Any) -> str:
    """A number as it was given, in positional notation: ``0.15``, ``2000``, ``0.000001``
    (a setting, not a measurement: no rounding, no padding).

    Parameters
    ----------
    value : Any
        The number.

    Returns
    -------
    str
        Its shortest decimal form without an exponent; ``—`` when not finite.
    """
    v = to_float(value)
    if not math.isfinite(v):
        return significant(v)
    if v.is_integer() and abs(v) < 1e15:
        return str(int(v))
    text = format(Decimal(repr(v)), "f")
    return _trim(text)


def r_squared(value: Any) -> str:
    """The coefficient of determination for people: ``0.9996``, ``> 0.9999``, never ``1``.

    Parameters
    ----------
    value : Any
        R².

    Returns
    -------
    str
        Four decimals; ``> 0.9999`` when it rounds to 1 and is below it; ``1`` only when it
        is exactly 1 (a fit through every point).
    """
    v = to_float(value)
    if not math.isfinite(v):
        return MISSING
    if v == 1.0:
        return "1"
    if v >= 0.99995:
        return "> 0.9999"
    return _fixed(v, 4)


def auto_prefix(value: float, allowed: str = "pnµmkMGT") -> str:
    """The SI prefix that prints *value* with 1 to 3 digits before the point.

    Parameters
    ----------
    value : float
        The number in the base unit.
    allowed : str
        Prefixes to choose from (the base unit always is one).

    Returns
    -------
    str
        A key of :data:`PREFIXES` (``""`` for none).
    """
    if not math.isfinite(value) or value == 0:
        return ""
    exp = math.floor(math.log10(abs(value)) / 3) * 3
    choices = sorted((PREFIXES[p], p) for p in ("", *allowed))
    best = ""
    for power, p in choices:
        if power <= exp:
            best = p
    return best if PREFIXES[best] <= exp else choices[0][1]


def quantity(value: Any, unit: str, *, prefix: str | None = None, sig: int = 3) -> str:
    """*value* (in the base *unit*) with a prefix: ``3.00 µm``, ``40.0 kPa``.

    Parameters
    ----------
    value : Any
        The number in the base unit (``m``, ``Pa``...).
    unit : str
        The base unit; ``""`` or ``"1"`` for a dimensionless number.
    prefix : str, optional
        The prefix to use (default: :func:`auto_prefix`).
    sig : int
        Significant figures.

    Returns
    -------
    str
        The number and its unit; ``∞`` for an infinite value.
    """
    v = to_float(value)
    if unit in ("", "1"):
        return significant(v, sig)
    if not math.isfinite(v):
        return f"{significant(v, sig)} {unit}" if math.isinf(v) else MISSING
    p = auto_prefix(v) if prefix is None else prefix
    return f"{significant(v / 10.0 ** PREFIXES[p], sig)} {p}{unit}"


def frequency(value: Any) -> str:
    """A drive frequency: ``10 Hz``, ``10 kHz``, ``2.5 kHz``.

    Parameters
    ----------
    value : Any
        Hz.

    Returns
    -------
    str
        Up to 3 significant figures, trailing zeros dropped.
    """
    v = to_float(value)
    if not math.isfinite(v):
        return MISSING
    p = auto_prefix(v, allowed="kM") if v >= 1000 else ""
    return f"{_trim(significant(v / 10.0 ** PREFIXES[p], 3))} {p}Hz"


def voltage(value: Any) -> str:
    """A voltage amplitude: ``80 V``, ``142.5 V``.

    Parameters
    ----------
    value : Any
        V.

    Returns
    -------
    str
        The amplitude with up to 4 significant figures, trailing zeros dropped.
    """
    v = to_float(value)
    return MISSING if not math.isfinite(v) else f"{_trim(significant(v, 4))} V"


#: Decimals of a drive frequency or an amplitude that tell two apart: frequencies, Hz, and
#: amplitudes, V, that agree to a millionth are the same.
KEY_DECIMALS = 6


def frequency_key(value: Any) -> float | None:
    """The one rule for "the same frequency": two drive frequencies are the same when their
    keys are equal (rounded to a millionth of a hertz; None when missing or not finite).

    Parameters
    ----------
    value : Any
        Hz (None, NaN and text that is no number are missing).

    Returns
    -------
    float or None
        Hz.
    """
    v = to_float(value)
    return round(v, KEY_DECIMALS) + 0.0 if math.isfinite(v) else None


def amplitude_key(value: Any) -> float | None:
    """The same rule for amplitudes: two are the same when their keys are equal (rounded to
    a millionth of a volt; None when missing or not finite).

    Parameters
    ----------
    value : Any
        V.

    Returns
    -------
    float or None
        V.
    """
    return frequency_key(value)
