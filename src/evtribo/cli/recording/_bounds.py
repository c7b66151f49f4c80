"""The bounds of ``simulate``'s and ``acquire``'s numbers: values no finger, rig, bus or
protocol reaches. A number beyond them is refused before anything is recorded or written
(exit 2 naming the option), rather than a simulation that runs out of memory or overflows,
or a trial whose sidecar ``analyze`` would refuse; each option's help says its bounds
(:func:`say_bounds`)."""

from __future__ import annotations

import argparse
import math
from collections.abc import Iterable
from typing import NamedTuple

from evtribo.documents.sidecar import SIDECAR_BOUNDS
from evtribo.errors import ConfigError

__all__ = ["BOUNDS", "MAX_OFFLINE_FRAMES", "Bound", "check_bounds", "say_bounds"]


class Bound(NamedTuple):
    """An option's lowest and highest value (whether the lowest is allowed), its unit and
    why its highest is the highest."""

    low: float
    low_allowed: bool
    high: float
    unit: str
    why: str


_HOUR = "an hour: longer than any trial, phase or stroke"
_FORCE = "far beyond any force a finger presses with or a load cell reads"
_RATE = "no CAN bus carries more frames a second"

#: Each bounded option's bounds (both numbers of a two-number option alike).
BOUNDS: dict[str, Bound] = {
    "--duration": Bound(0.0, False, 86_400.0, "s", "a day: leave --duration out to go on "
                                                     "until Ctrl-C"),
    "--amplitude": Bound(0.0, True, SIDECAR_BOUNDS["amplitude_V"][0], "V",
                         SIDECAR_BOUNDS["amplitude_V"][2]),
    "--frequency": Bound(0.0, True, SIDECAR_BOUNDS["frequency_Hz"][0], "Hz",
                         SIDECAR_BOUNDS["frequency_Hz"][2]),
    "--tare-s": Bound(0.0, True, SIDECAR_BOUNDS["tare_s"][0], "s",
                      SIDECAR_BOUNDS["tare_s"][2]),
    "--on-time": Bound(0.0, False, 3600.0, "s", _HOUR),
    "--off-time": Bound(0.0, False, 3600.0, "s", _HOUR),
    "--target-force": Bound(0.0, False, 1000.0, "N", _FORCE),
    "--band": Bound(0.0, True, 1000.0, "N", _FORCE),
    "--force-drift": Bound(0.0, True, 1.0, "", "a wander of the whole force"),
    "--drift-time": Bound(0.0, False, 3600.0, "s", _HOUR),
    "--speed": Bound(0.0, False, 10.0, "m/s", "no finger slides faster"),
    "--stroke-length": Bound(0.0, False, 1.0, "m", "longer than any screen"),
    "--reversal-time": Bound(0.0, True, 3600.0, "s", _HOUR),
    "--dwell": Bound(0.0, True, 3600.0, "s", _HOUR),
    "--lifts-per-min": Bound(0.0, True, 600.0, "/min", "ten a second"),
    "--lift-time": Bound(0.0, True, 3600.0, "s", _HOUR),
    "--fz-rate": Bound(0.0, False, 1e5, "Hz", _RATE),
    "--fx-rate": Bound(0.0, False, 1e5, "Hz", _RATE),
    "--hv-rate": Bound(0.0, False, 1e5, "Hz", _RATE),
    "--foreign-rate": Bound(0.0, True, 1e5, "Hz", _RATE),
    "--noise": Bound(0.0, True, 1000.0, "N", _FORCE),
    "--hum": Bound(0.0, True, 1000.0, "N", _FORCE),
    "--jitter": Bound(0.0, True, 0.1, "s", "a frame a tenth of a second late is a stall, not "
                                        "jitter"),
    "--offsets": Bound(-1000.0, True, 1000.0, "N", _FORCE),
    "--drift": Bound(-1000.0, True, 1000.0, "N", _FORCE),
    "--crosstalk": Bound(-1.0, True, 1.0, "", "a cell reads at most the whole of the "
                                             "other force"),
    "--seed": Bound(0, True, 2**64 - 1, "", "a seed is a 64-bit number"),
}
#: Most frames a trial simulated offline (``simulate --study``) may hold: it is made in
#: memory (an hour of the default rig is 11 million).
MAX_OFFLINE_FRAMES = 20_000_000


def _number(x: float) -> str:
    return f"{x:,}" if isinstance(x, int) else f"{x:g}"


def _text(bound: Bound) -> str:
    unit = f" {bound.unit}" if bound.unit else ""
    low = f"{'>=' if bound.low_allowed else '>'} {_number(bound.low)}"
    return f"{low} and <= {_number(bound.high)}{unit}"


def check_bounds(args: argparse.Namespace, flags: Iterable[str], *,
                 bound: Bound | None = None) -> None:
    """Refuse a number of *flags* beyond its bounds (:data:`BOUNDS`), naming the option.

    Parameters
    ----------
    args : argparse.Namespace
        The command's options (an option not given is None and not checked).
    flags : iterable of str
        The options to check (``"--duration"``).
    bound : Bound, optional
        The bounds of every one of *flags* (default: each one's of :data:`BOUNDS`).

    Returns
    -------
    None

    Raises
    ------
    ConfigError
        ``key '--duration': 1e+300 s is not allowed: > 0 and <= 86400 s (a day: ...)``.
    """
    for flag in flags:
        value = getattr(args, flag[2:].replace("-", "_"), None)
        if value is None:
            continue
        limits = BOUNDS[flag] if bound is None else bound
        for v in value if isinstance(value, list | tuple) else (value,):
            ok = math.isfinite(v) and v <= limits.high and (
                v >= limits.low if limits.low_allowed else v > limits.low)
            if not ok:
                unit = f" {limits.unit}" if limits.unit else ""
                raise ConfigError(f"{v!r}{unit} is not allowed: {_text(limits)} "
                                  f"({limits.why})", key=flag)


def say_bounds(parser: argparse.ArgumentParser, flags: Iterable[str] = tuple(BOUNDS)) -> None:
    """Append the bounds of *flags* to their help (``--help`` says them).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    flags : iterable of str
        The options of :data:`BOUNDS` the command checks (default: all it has).

    Returns
    -------
    None
    """
    chosen = set(flags)
    for action in parser._actions:
        flag = next((f for f in action.option_strings if f in chosen), None)
        if flag is not None and action.help is not None:
            action.help += f"; {_text(BOUNDS[flag]).replace('%', '%%')}"
