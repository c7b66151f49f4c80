"""The analysis's settings: defaults, ``[analysis]`` of study.toml, and overrides.

:class:`AnalysisSettings` is the one place the defaults live; ``analysis/default.toml`` at the
top of the repository lists every key with its default and meaning (a test keeps the two
equal). A study overrides them in the ``[analysis]`` table of its study.toml, and the command
line overrides both (``evtribo analyze --tare none --set guard_s=0.3``). Every key is checked:
an unknown key (``guard_sec``) or a value of the wrong type or range stops with the file,
the line and the key, and the closest valid name.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import os
from collections.abc import Collection, Mapping
from dataclasses import dataclass, fields
from typing import Any

from evtribo.analysis.forces.align import DEFAULT_MAX_GAP_PERIODS
from evtribo.analysis.forces.conditions import DEFAULT_GUARD_S
from evtribo.analysis.friction.estimate import DEFAULT_CONFIDENCE, DEFAULT_N_BOOT
from evtribo.analysis.friction.laws import LAWS
from evtribo.analysis.friction.windows import (
    DEFAULT_MAX_WINDOW_S,
    DEFAULT_MIN_WINDOW_S,
    DEFAULT_SMOOTH_S,
)
from evtribo.analysis.modes import HUM_MODES, TARE_MODES
from evtribo.errors import ConfigError, toml_key_line
from evtribo.study import STUDY_FILE, StudyFolder

__all__ = ["HUM_MODES", "SETTING_HELP", "TARE_MODES", "AnalysisSettings", "parse_setting",
           "setting_bounds", "study_settings"]

#: The allowed values of each setting that is a word (the friction laws' names: the
#: builtins, then those of plug-ins, :mod:`evtribo.analysis.friction.laws`).
CHOICES: dict[str, Collection[str]] = {"tare": TARE_MODES, "hum": HUM_MODES,
                                       "friction_law": LAWS}

#: One line per key: its meaning (``analysis/default.toml`` carries the same words).
SETTING_HELP = {
    "tare": "how the load cells' zero offsets are removed: auto (calibration, then the "
            "finger-lifted stretches, then the friction loop), lifted, friction-loop, "
            "calibration ([rig.calibration] only) or none",
    "guard_s": "time excluded on each side of an ON/OFF switch, s",
    "smooth_s": "moving-average span for finding strokes, s (at least a period of a sine "
                "drive)",
    "min_window_s": "shortest steady-sliding window kept, s",
    "max_window_s": "longest window; longer steady runs are split, s",
    "confidence": "coverage of the confidence intervals",
    "n_boot": "bootstrap replicates of the electrostatic force",
    "seed": "seed of the bootstrap",
    "hum": "mains hum (50/60 Hz and harmonics) on the load cells: auto (notched out in sine "
           "trials, whose windows span whole periods of the friction's oscillation; "
           "elsewhere every window spans whole periods of 50 and 60 Hz, which cancels it), "
           "remove (notched out in every trial) or keep",
    "min_lift_s": "shortest finger-lifted stretch used to tare the load cells, s",
    "max_gap_periods": "a pause of a load cell longer than this many sample periods is a "
                       "gap, never interpolated through",
    "trace_off_s": "sine trace for the model comparison: seconds before a switch to ON",
    "trace_on_s": "sine trace: seconds after the switch",
    "trace_rate_Hz": "highest sample rate of the sine trace, Hz",
    "friction_law": "how the friction grows with the load W = F_n + F_el, F_t = c W^m: auto "
                    "(m measured from each subject's OFF windows where their normal forces "
                    "tell it, else Amontons' m = 1 with F_el at m = 0.75 beside it), power "
                    "(the measured m however uncertain), amontons (m = 1) or a plug-in's law",
}


@dataclass(frozen=True)
class AnalysisSettings:
    """Tunable constants of the analysis (all times in s).

    Attributes
    ----------
    tare : {"auto", "lifted", "friction-loop", "calibration", "none"}
        How the load cells' zero offsets are removed (:mod:`evtribo.analysis.forces.zero_offsets`).
    guard_s : float, s
        Excluded on both sides of an ON/OFF switch.
    smooth_s : float, s
        Moving-average span for finding strokes; for a sine drive at least one period of
        the drive (two of the friction's modulation) is used.
    min_window_s, max_window_s : float, s
        Shortest window kept, longest window (longer steady runs are split).
    confidence : float
        Coverage of the intervals.
    n_boot : int
        Bootstrap replicates of the electrostatic force.
    seed : int
        Seed of the bootstrap.
    hum : {"auto", "remove", "keep"}
        Mains hum on the load cells: notched out in sine trials (``auto``), in every trial
        (``remove``) or never (``keep``); windows of other trials span whole mains periods.
    min_lift_s : float, s
        Shortest finger-lifted stretch used for taring.
    max_gap_periods : float
        A pause of a load cell longer than this many sample periods is a gap.
    trace_off_s, trace_on_s : float, s
        Extent of the sine trace written for the model comparison (sine_trace.csv): this
        long before and after a switch from OFF to ON.
    trace_rate_Hz : float, Hz
        Highest sample rate of the sine trace (block means of the aligned forces).
    friction_law : str
        How the friction grows with the load: ``auto``, ``amontons``, ``power`` or a
        plug-in's law (:mod:`evtribo.analysis.friction.laws`).
    """

    tare: str = "auto"
    guard_s: float = DEFAULT_GUARD_S
    smooth_s: float = DEFAULT_SMOOTH_S
    min_window_s: float = DEFAULT_MIN_WINDOW_S
    max_window_s: float = DEFAULT_MAX_WINDOW_S
    confidence: float = DEFAULT_CONFIDENCE
    n_boot: int = DEFAULT_N_BOOT
    seed: int = 0
    hum: str = "auto"
    min_lift_s: float = 0.2
    max_gap_periods: float = DEFAULT_MAX_GAP_PERIODS
    trace_off_s: float = 0.5
    trace_on_s: float = 1.0
    trace_rate_Hz: float = 1000.0
    friction_law: str = "auto"

    def __post_init__(self) -> None:
        for f in fields(self):
            object.__setattr__(self, f.name, _checked(f.name, getattr(self, f.name)))
        if self.max_window_s < self.min_window_s:
            raise ConfigError(f"{self.max_window_s!r} is not allowed: must be >= min_window_s "
                              f"({self.min_window_s!r})", key="max_window_s")

    def to_dict(self) -> dict[str, Any]:
        """The settings as a JSON-ready mapping."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def updated(self, values: Mapping[str, Any], *, source: str | os.PathLike[str] | None = None,
                table: str = "analysis", text: str | None = None) -> AnalysisSettings:
        """These settings with *values* replacing some of them.

        Parameters
        ----------
        values : mapping
            ``{key: value}``, as in ``[analysis]`` of study.toml.
        source : path-like, optional
            The file the values come from, named in errors.
        table : str
            Their table, named in errors (``analysis.guard_s``).
        text : str, optional
            The file's text, to name the line of a key at fault.

        Raises
        ------
        ConfigError
            An unknown key (with the closest valid name) or a bad value.
        """
        names = [f.name for f in fields(self)]
        src = None if source is None else os.fspath(source)

        def where(key: str) -> dict[str, Any]:
            line = toml_key_line(text, table, key) if text is not None else None
            return {"path": src, "line": line, "key": f"{table}.{key}" if table else key}

        for key in values:
            if key not in names:
                close = difflib.get_close_matches(key, names, n=1, cutoff=0.5)
                hint = f"did you mean {close[0]!r}? " if close else ""
                raise ConfigError(f"unknown setting; {hint}known: {', '.join(names)}",
                                  **where(key))
        try:
            return dataclasses.replace(self, **dict(values))
        except ConfigError as err:
            key = err.key or ""
            raise ConfigError(err.message, **where(key)) from err


def _checked(name: str, value: Any) -> Any:
    """*value* for setting *name*, of the right type and range, or ConfigError."""
    kind = {f.name: f.type for f in fields(AnalysisSettings)}[name]
    if kind == "str":
        if value not in CHOICES[name]:
            raise ConfigError(f"{value!r} is not allowed: choose one of "
                              f"{', '.join(CHOICES[name])}", key=name)
        return value
    if kind == "bool":
        if not isinstance(value, bool):
            raise ConfigError(f"expected true or false, got {value!r}", key=name)
        return value
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ConfigError(f"expected a number, got {value!r}", key=name)
    if isinstance(value, float) and not math.isfinite(value):
        raise ConfigError(f"expected a finite number, got {value!r}", key=name)
    given = value
    if kind == "int":
        if value != int(value):
            raise ConfigError(f"expected a whole number, got {value!r}", key=name)
        value = int(value)
    else:
        value = float(value)
    low, strict = _RANGES.get(name, (0.0, True))
    if value < low or (strict and value == low):
        raise ConfigError(f"{value!r} is not allowed: must be {'>' if strict else '>='} "
                          f"{low:g}", key=name)
    high, why = _HIGHEST.get(name, (math.inf, ""))
    if value > high:
        raise ConfigError(f"{given!r} is not allowed: at most {high:,} ({why})", key=name)
    return value


#: Lowest value of each numeric setting, and whether it is excluded (default: > 0).
_RANGES = {"guard_s": (0.0, False), "seed": (0.0, False), "n_boot": (10.0, False),
           "confidence": (0.5, False), "max_gap_periods": (1.0, False),
           "trace_rate_Hz": (1.0, False)}
_HOUR = (3600, "an hour: longer than any phase, stroke or pause of a trial")
#: Highest value of each numeric setting, and why (the bounds no rig or protocol reaches).
_HIGHEST: dict[str, tuple[float, str]] = {
    "n_boot": (100_000, "the bootstrap's own error on a 95 % interval's ends is then below "
                        "1 % of its width; more replicates cost memory and time for nothing"),
    "seed": (2**64 - 1, "a seed is a 64-bit number"),
    "confidence": (0.9999, "an interval's ends beyond it rest on a handful of replicates"),
    "max_gap_periods": (1_000_000, "a pause of a million samples is a gap in any stream"),
    "trace_rate_Hz": (1_000_000, "no load cell's stream is faster than a megahertz"),
    **dict.fromkeys(("guard_s", "smooth_s", "min_window_s", "max_window_s", "min_lift_s",
                     "trace_off_s", "trace_on_s"), _HOUR),
}


def setting_bounds(name: str) -> str:
    """What numeric setting *name* may be, in words (``from 0 to 3,600``), for the docs.

    Parameters
    ----------
    name : str
        A numeric setting of :class:`AnalysisSettings`.

    Returns
    -------
    str
    """
    low, strict = _RANGES.get(name, (0.0, True))
    high, _ = _HIGHEST[name]
    return f"{'>' if strict else '>='} {low:g} and <= {high:,}"


def parse_setting(text: str) -> tuple[str, Any]:
    """``"guard_s=0.3"`` to ``("guard_s", 0.3)`` (numbers, true/false, or a word).

    Parameters
    ----------
    text : str
        ``key=value``.

    Returns
    -------
    (str, object)
        The key and its value.

    Raises
    ------
    ConfigError
        No ``=``.
    """
    key, sep, raw = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ConfigError(f"expected KEY=VALUE, got {text!r}", key=key or text)
    raw = raw.strip()
    value: Any
    if raw.lower() in ("true", "false"):
        value = raw.lower() == "true"
    else:
        try:
            value = int(raw)
        except ValueError:
            try:
                value = float(raw)
            except ValueError:
                value = raw
    return key, value


def study_settings(study: StudyFolder, overrides: Mapping[str, Any] | None = None,
                   base: AnalysisSettings | None = None) -> AnalysisSettings:
    """The analysis settings of a study: *base* (default: the package's defaults), then the
    ``[analysis]`` table of its study.toml, then *overrides* (the command line's).

    Parameters
    ----------
    study : StudyFolder
        The study, as loaded (its ``[analysis]`` table).
    overrides : mapping, optional
        Settings that take precedence (``{"tare": "none"}``).
    base : AnalysisSettings, optional
        The settings to start from.

    Returns
    -------
    AnalysisSettings

    Raises
    ------
    ConfigError
        An unknown key or a bad value, naming study.toml's line and key (or the option).
    """
    settings = base or AnalysisSettings()
    table = study.config.get("analysis") or {}
    if table:
        path = study.root / STUDY_FILE
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError):
            text = None
        settings = settings.updated(table, source=path, text=text)
    if overrides:
        settings = settings.updated(overrides, table="")
    return settings
