"""A subject's protocol (spec §7): the protocol file, and the trials it plans.

>>> protocol = read_protocol("acquisition/protocols/meyer2013.toml")   # doctest: +SKIP
>>> [p.label for p in plan_trials(protocol)][:2]                      # doctest: +SKIP
['square 10000 Hz 100 V alternating', 'square 10000 Hz 60 V alternating']

The file has a ``[session]`` table and one ``[[trial]]`` table per kind of trial. A list in a
trial (``amplitude_V = [60, 80, 100]``, ``frequency_Hz = [20, 100, 1000]``) expands to one
trial per value (every combination, when several keys are lists); ``repetitions`` repeats the
whole list; ``randomize`` shuffles it with ``seed`` (drawn and recorded when not given).
Every key is checked: an unknown one (``amplitude``) or a bad value stops with the file, the
line and the key, and the closest valid name.
"""

from __future__ import annotations

import difflib
import itertools
import math
import os
import re
import secrets
import tomllib
from dataclasses import asdict, dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from evtribo.errors import ConfigError, toml_key_line, toml_problem
from evtribo.store.files import read_limited

__all__ = ["CONDITIONS", "Protocol", "ProtocolTrial", "SessionSettings", "TrialSpec",
           "example_protocols", "plan_trials", "read_protocol", "session_seed"]

#: Values of a trial's ``condition`` (spec §1's sidecar).
CONDITIONS = ("alternating", "on", "off")
#: Waveforms a protocol may ask for.
WAVEFORMS = ("sine", "square")


@dataclass(frozen=True)
class SessionSettings:
    """The ``[session]`` table.

    Attributes
    ----------
    trial_s : float, s
        Duration of each trial.
    repetitions : int
        Each trial of the list, this many times.
    randomize : bool
        Shuffle the order.
    seed : int or None
        Seed of the shuffle (None: drawn when the session starts, and recorded).
    tare_s : float, s
        Finger lifted at the start of each trial.
    target_force_N, band_N : float, N
        Target normal force and the half-width of its band.
    pause_s : float, s
        Pause between trials (the operator can go on earlier with Enter).
    on_s, off_s : float, s
        ON and OFF phases of an alternating trial whose excitation evtribo commands.
    target_steps_N : tuple of float, N
        Targets the band steps through in each trial after the tare stretch, each held
        :attr:`step_s`, in turn (empty: :attr:`target_force_N` all through): presses that
        span a range within a trial tell how the friction grows with the load
        (docs/analysis.md, "The friction law").
    step_s : float, s
    """

    trial_s: float = 20.0
    repetitions: int = 1
    randomize: bool = False
    seed: int | None = None
    tare_s: float = 1.5
    target_force_N: float = 0.5
    band_N: float = 0.1
    pause_s: float = 0.0
    on_s: float = 2.0
    off_s: float = 2.0
    target_steps_N: tuple[float, ...] = ()
    step_s: float = 4.0


@dataclass(frozen=True)
class TrialSpec:
    """One ``[[trial]]`` table, its lists not yet expanded."""

    waveform: str = "square"
    frequency_Hz: tuple[float, ...] = (10000.0,)
    amplitude_V: tuple[float, ...] = (100.0,)
    condition: str = "alternating"
    notes: str = ""


@dataclass(frozen=True)
class Protocol:
    """A protocol file, read and checked.

    Attributes
    ----------
    session : SessionSettings
    trials : tuple of TrialSpec
    source : str or None
        The file it was read from.
    """

    session: SessionSettings
    trials: tuple[TrialSpec, ...]
    source: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready, as recorded in ``session.json``."""
        return {"session": {**asdict(self.session),
                            "target_steps_N": list(self.session.target_steps_N)},
                "trial": [{**asdict(t), "frequency_Hz": list(t.frequency_Hz),
                           "amplitude_V": list(t.amplitude_V)} for t in self.trials]}

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str | None = None) -> Protocol:
        """The inverse of :meth:`to_dict`."""
        trials = tuple(TrialSpec(**{**t, "frequency_Hz": tuple(t["frequency_Hz"]),
                                    "amplitude_V": tuple(t["amplitude_V"])})
                       for t in data["trial"])
        session = {**data["session"],
                   "target_steps_N": tuple(data["session"].get("target_steps_N", ()))}
        return cls(SessionSettings(**session), trials, source)


@dataclass(frozen=True)
class ProtocolTrial:
    """One trial of the plan: what the excitation is.

    Attributes
    ----------
    waveform : str
    frequency_Hz : float, Hz
    amplitude_V : float, V
    condition : {"alternating", "on", "off"}
    notes : str
    """

    waveform: str
    frequency_Hz: float
    amplitude_V: float
    condition: str
    notes: str = ""

    @property
    def label(self) -> str:
        """``"square 10000 Hz 100 V alternating"``."""
        return (f"{self.waveform} {self.frequency_Hz:g} Hz {self.amplitude_V:g} V "
                f"{self.condition}")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return asdict(self)


_SESSION_KEYS = {f: SessionSettings.__dataclass_fields__[f] for f in
                 SessionSettings.__dataclass_fields__}
_TRIAL_KEYS = ("waveform", "frequency_Hz", "amplitude_V", "condition", "notes")


@dataclass
class _Reader:
    """Checks values, naming the file, the line and the key of a bad one."""

    path: str
    text: str

    def fail(self, message: str, key: str, line: int | None) -> ConfigError:
        return ConfigError(message, path=self.path, line=line, key=key)

    def trial_line(self, index: int, key: str) -> int | None:
        """The line of *key* in the *index*-th ``[[trial]]`` table (0-based)."""
        seen = -1
        inside = False
        for number, line in enumerate(self.text.splitlines(), 1):
            if re.match(r"^\s*\[\[\s*trial\s*\]\]", line):
                seen += 1
                inside = seen == index
                continue
            if re.match(r"^\s*\[", line):
                inside = False
                continue
            if inside and re.match(rf"^\s*{re.escape(key)}\s*=", line):
                return number
        return None

    def unknown(self, keys: list[str], allowed: tuple[str, ...], where: str,
                line_of: Any) -> None:
        for k in keys:
            if k not in allowed:
                close = difflib.get_close_matches(k, allowed, n=1, cutoff=0.5)
                raise self.fail("unknown key" + (f" (did you mean {close[0]!r}?)" if close
                                                 else "") + f"; allowed: {', '.join(allowed)}",
                                f"{where}.{k}", line_of(k))


def _number(r: _Reader, value: object, key: str, line: int | None, *, positive: bool = True,
            integer: bool = False) -> float:
    ok = isinstance(value, int | float) and not isinstance(value, bool) \
        and math.isfinite(float(value))
    if integer:
        ok = ok and isinstance(value, int)
    if not ok or (positive and float(value) <= 0) or float(value) < 0:  # type: ignore[arg-type]
        what = "a whole number" if integer else "a number"
        raise r.fail(f"expected {what} {'> 0' if positive else '>= 0'}, got {value!r}",
                     key, line)
    return float(value)  # type: ignore[arg-type]


def _session(r: _Reader, table: object) -> SessionSettings:
    if table is None:
        return SessionSettings()
    if not isinstance(table, dict):
        raise r.fail("must be a table", "session", None)

    def line(k: str) -> int | None:
        return toml_key_line(r.text, "session", k)

    r.unknown(list(table), tuple(_SESSION_KEYS), "session", line)
    values: dict[str, Any] = {}
    for k, v in table.items():
        key = f"session.{k}"
        if k == "randomize":
            if not isinstance(v, bool):
                raise r.fail(f"expected true or false, got {v!r}", key, line(k))
            values[k] = v
        elif k == "target_steps_N":
            if not isinstance(v, list) or not v:
                raise r.fail(f"expected a list of numbers > 0, N, got {v!r}", key, line(k))
            values[k] = tuple(_number(r, x, key, line(k)) for x in v)
        elif k in ("repetitions", "seed"):
            values[k] = int(_number(r, v, key, line(k), integer=True,
                                    positive=k == "repetitions"))
        else:
            values[k] = _number(r, v, key, line(k), positive=k not in ("tare_s", "pause_s"))
    return SessionSettings(**values)


def _trial(r: _Reader, index: int, table: object) -> TrialSpec:
    where = f"trial[{index + 1}]"
    if not isinstance(table, dict):
        raise r.fail("must be a table", where, None)

    def line(k: str) -> int | None:
        return r.trial_line(index, k)

    r.unknown(list(table), _TRIAL_KEYS, where, line)
    values: dict[str, Any] = {}
    for k, v in table.items():
        key = f"{where}.{k}"
        if k in ("frequency_Hz", "amplitude_V"):
            items = v if isinstance(v, list) else [v]
            if not items:
                raise r.fail("an empty list plans no trial", key, line(k))
            values[k] = tuple(_number(r, x, key, line(k), positive=k == "frequency_Hz")
                              for x in items)
        elif k == "waveform" and v not in WAVEFORMS:
            raise r.fail(f"expected one of {', '.join(WAVEFORMS)}, got {v!r}", key, line(k))
        elif k == "condition" and v not in CONDITIONS:
            raise r.fail(f"expected one of {', '.join(CONDITIONS)}, got {v!r}", key, line(k))
        elif k == "notes" and not isinstance(v, str):
            raise r.fail(f"expected a string, got {v!r}", key, line(k))
        else:
            values.setdefault(k, v)
    return TrialSpec(**values)


def example_protocols() -> list[Path]:
    """The example protocols installed with evtribo (package data
    ``evtribo/data/protocols/``: ``meyer2013.toml``, ``frequency-sweep.toml``,
    ``friction-law.toml``).

    Returns
    -------
    list of Path
        Their files, by name.
    """
    folder = Path(str(resources.files("evtribo") / "data" / "protocols"))
    return sorted(folder.glob("*.toml"))


def read_protocol(path: str | os.PathLike[str]) -> Protocol:
    """Read and check a protocol file.

    Parameters
    ----------
    path : path-like
        The protocol's TOML file.

    Returns
    -------
    Protocol

    Raises
    ------
    ConfigError
        Unreadable, not TOML, an unknown key, a bad value, or no ``[[trial]]``; naming the
        file, the line and the key.
    """
    src = os.fspath(path)
    if not os.path.exists(src):
        raise ConfigError("protocol file not found", path=src)
    text = read_limited(path, ConfigError, what="protocol file").decode("utf-8", "replace")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        reason, line, key = toml_problem(err, text)
        raise ConfigError(f"not valid TOML: {reason}", path=src, line=line, key=key) \
            from err
    r = _Reader(src, text)
    r.unknown(list(data), ("session", "trial"), "protocol",
              lambda k: toml_key_line(text, "", k))
    trials = data.get("trial")
    if not isinstance(trials, list) or not trials:
        raise ConfigError("no [[trial]] table: the protocol plans no trial", path=src,
                          key="trial")
    return Protocol(_session(r, data.get("session")),
                    tuple(_trial(r, i, t) for i, t in enumerate(trials)), src)


def session_seed(protocol: Protocol) -> int:
    """The shuffle's seed: the protocol's, or a fresh one (to be recorded).

    Parameters
    ----------
    protocol : Protocol

    Returns
    -------
    int
    """
    if protocol.session.seed is not None:
        return protocol.session.seed
    return secrets.randbelow(2**31)


def plan_trials(protocol: Protocol, seed: int | None = None) -> list[ProtocolTrial]:
    """The trials in the order they will be recorded.

    Parameters
    ----------
    protocol : Protocol
    seed : int, optional
        The shuffle's seed (default: the protocol's; required when it randomizes without
        one).

    Returns
    -------
    list of ProtocolTrial
        Each ``[[trial]]`` expanded (every combination of its lists, in the file's order),
        the whole list repeated, then shuffled when ``randomize``.
    """
    one: list[ProtocolTrial] = []
    for spec in protocol.trials:
        for freq, amp in itertools.product(spec.frequency_Hz, spec.amplitude_V):
            one.append(ProtocolTrial(spec.waveform, freq, amp, spec.condition, spec.notes))
    planned = one * protocol.session.repetitions
    if protocol.session.randomize:
        s = protocol.session.seed if seed is None else seed
        if s is None:
            raise ValueError("a randomized protocol without a seed needs one")
        order = np.random.default_rng(s).permutation(len(planned))
        planned = [planned[i] for i in order]
    return planned

