"""A warning as a record: what kind it is, what it does to the results, where it was said
(the study, a subject, a drive, a cell or a trial), the values it was said with and its
text.

A record is self-contained: its text is rendered when it is made and kept, so that a reader
(summary.json, the report, a script) needs no catalogue to show it, and it is plain data
(strings, numbers, None): it pickles and crosses processes and Dask as it is, and
:meth:`WarningRecord.as_json` / :meth:`WarningRecord.from_json` carry it through JSON.

The text starts with its scope's prefix, as evtribo has always written it:
``"P01/run-02: "`` (a trial), ``"P03 (square, 10000 Hz) at 60 V: "`` (a cell),
``"P03 (square, 10000 Hz): "`` (a drive), ``"P01: "`` (a subject), nothing for the study
(:meth:`Scope.prefix`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal, get_args

from evtribo.util.numbers import amplitude_key, frequency_key

__all__ = ["EFFECTS", "LEVELS", "Effect", "Level", "Note", "Scope", "WarningRecord",
           "plain_value"]

#: What a warning does to the reported numbers.
Effect = Literal["number", "interval", "information"]
#: Each effect in words, in the order the warnings are said (most serious first).
EFFECTS: dict[str, str] = {
    "number": "may change a reported number",
    "interval": "widens an interval (the interval holds it)",
    "information": "for information",
}
#: What a kind of warning is said of.
Level = Literal["study", "subject", "drive", "cell", "trial"]
LEVELS: tuple[str, ...] = get_args(Level)

_SCOPE_KEYS = ("subject", "trial", "waveform", "frequency_Hz", "amplitude_V")


@dataclass(frozen=True)
class Scope:
    """Where a warning was said: every field None is the study.

    Attributes
    ----------
    subject : str or None
    trial : str or None
        The trial's name within its subject (``run-03``).
    waveform : str or None
        The drive's waveform (None: unknown, or not a drive's warning).
    frequency_Hz : float or None, Hz
    amplitude_V : float or None, V
    """

    subject: str | None = None
    trial: str | None = None
    waveform: str | None = None
    frequency_Hz: float | None = None
    amplitude_V: float | None = None

    def __post_init__(self) -> None:
        for name in ("subject", "trial", "waveform"):
            value = getattr(self, name)
            if value is not None and not isinstance(value, str):
                object.__setattr__(self, name, str(value))
        for name in ("frequency_Hz", "amplitude_V"):
            value = getattr(self, name)
            if value is not None:
                value = float(value)
                object.__setattr__(self, name, value if math.isfinite(value) else None)

    def prefix(self, level: str) -> str:
        """The text's prefix for a warning of *level* said here (empty where this scope
        lacks what the level names: a trial's warning said outside a trial).

        Parameters
        ----------
        level : {"study", "subject", "drive", "cell", "trial"}

        Returns
        -------
        str
            ``P01/run-02: ``, ``P03 (square, 10000 Hz) at 60 V: ``, ``P03 (square): ``,
            ``P01: `` or ``""``.
        """
        if self.subject is None or level == "study":
            return ""
        if level == "trial":
            return f"{self.subject}/{self.trial}: " if self.trial is not None else ""
        if level == "subject":
            return f"{self.subject}: "
        drive = f"{self.subject} ({self.drive_text()})"
        if level == "cell" and self.amplitude_V is not None:
            return f"{drive} at {self.amplitude_V:g} V: "
        return f"{drive}: "

    def drive_text(self) -> str:
        """The drive as the analysis's warnings name it: ``square, 10000 Hz``, ``square``
        (no frequency), ``unknown waveform``.

        Returns
        -------
        str
        """
        text = self.waveform or "unknown waveform"
        return text if self.frequency_Hz is None else f"{text}, {self.frequency_Hz:g} Hz"

    def holds(self, subject: Any, waveform: Any = None, frequency_Hz: Any = None,
              amplitude_V: Any = None) -> bool:
        """Whether this scope (None: any) takes in a subject's drive at an amplitude.

        Parameters
        ----------
        subject : str
        waveform : str, optional
        frequency_Hz : float, optional, Hz
            The same frequency by :func:`~evtribo.util.numbers.frequency_key`.
        amplitude_V : float, optional, V

        Returns
        -------
        bool
        """
        return (self.subject in (None, str(subject))
                and self.waveform in (None, waveform)
                and (self.frequency_Hz is None
                     or frequency_key(self.frequency_Hz) == frequency_key(frequency_Hz))
                and (self.amplitude_V is None
                     or amplitude_key(self.amplitude_V) == amplitude_key(amplitude_V)))

    def as_json(self) -> dict[str, Any]:
        """The scope's keys, None where it names nothing.

        Returns
        -------
        dict
        """
        return {k: getattr(self, k) for k in _SCOPE_KEYS}


def plain_value(value: Any) -> str | int | float | bool | None:
    """A value a record can hold: a string, a number, a boolean or None (a numpy scalar as
    its Python value).

    Parameters
    ----------
    value : Any

    Returns
    -------
    str, int, float, bool or None

    Raises
    ------
    TypeError
        Anything else (a list, an array, an object): a record holds plain data.
    """
    if value is None or isinstance(value, str | bool | int | float):
        return value
    item = getattr(value, "item", None)
    if type(value).__module__ == "numpy" and callable(item):
        got = item()
        if got is None or isinstance(got, str | bool | int | float):
            return got
    raise TypeError(f"a warning's value is a string, a number, a boolean or None, not "
                    f"{type(value).__name__} ({value!r})")


@dataclass(frozen=True)
class WarningRecord:
    """One warning, as said.

    Attributes
    ----------
    kind : str
        The kind's id in the catalogue (``normal-zero``).
    effect : {"number", "interval", "information"}
        What it does to the reported numbers (:data:`EFFECTS`).
    scope : Scope
        Where it was said.
    values : tuple of (str, value)
        The values its wording was filled with, in order (strings, numbers, None).
    text : str
        What it says, its scope's prefix first.
    source : str
        The module that said it (its logger's name; said again under it).
    """

    kind: str
    effect: Effect
    scope: Scope = field(default_factory=Scope)
    values: tuple[tuple[str, Any], ...] = ()
    text: str = ""
    source: str = ""

    def __post_init__(self) -> None:
        if self.effect not in EFFECTS:
            raise ValueError(f"warning {self.kind!r}: effect {self.effect!r} is not one of "
                             f"{', '.join(EFFECTS)}")
        items = self.values.items() if isinstance(self.values, Mapping) else self.values
        object.__setattr__(self, "values", tuple((str(k), plain_value(v)) for k, v in items))

    def value(self, name: str, default: Any = None) -> Any:
        """One of the values the wording was filled with.

        Parameters
        ----------
        name : str
        default : Any
            When it has none of that name.

        Returns
        -------
        Any
        """
        return dict(self.values).get(name, default)

    def as_json(self) -> dict[str, Any]:
        """The record as summary.json holds it: ``kind``, ``effect``, ``text``, the scope's
        keys (``subject``, ``trial``, ``waveform``, ``frequency_Hz``, ``amplitude_V``; null
        where it names none), ``values`` and ``source``.

        Returns
        -------
        dict
        """
        return {"kind": self.kind, "effect": self.effect, "text": self.text,
                **self.scope.as_json(), "values": dict(self.values), "source": self.source}

    @classmethod
    def from_json(cls, obj: Mapping[str, Any]) -> WarningRecord:
        """A record from :meth:`as_json`'s object.

        Parameters
        ----------
        obj : mapping
            At least ``kind``, ``effect`` and ``text``.

        Returns
        -------
        WarningRecord

        Raises
        ------
        ValueError
            A key missing or of the wrong type, an unknown effect.
        """
        if not isinstance(obj, Mapping):
            raise ValueError(f"a warning is an object, not {type(obj).__name__}")
        for key in ("kind", "effect", "text"):
            if not isinstance(obj.get(key), str):
                raise ValueError(f"a warning's {key!r} is missing or not a string")
        values = obj.get("values") or {}
        if not isinstance(values, Mapping):
            raise ValueError("a warning's 'values' is not an object")
        try:
            scope = Scope(**{k: obj.get(k) for k in _SCOPE_KEYS})
            return cls(obj["kind"], obj["effect"], scope, tuple(values.items()), obj["text"],
                       str(obj.get("source") or ""))
        except (TypeError, ValueError) as err:
            raise ValueError(f"warning {obj['kind']!r}: {err}") from None


@dataclass(frozen=True)
class Note:
    """A warning found but not said yet: its kind and the values known where it was found;
    the caller that knows the rest (a load cell's name, the trial) says it
    (``emit(note.kind, **note.mapping, cell="normal")``).

    Attributes
    ----------
    kind : str
        The kind's id in the catalogue.
    values : tuple of (str, value)
        The values found (plain data; a mapping is taken too).
    """

    kind: str
    values: tuple[tuple[str, Any], ...] | Mapping[str, Any] = ()

    def __post_init__(self) -> None:
        items = self.values.items() if isinstance(self.values, Mapping) else self.values
        object.__setattr__(self, "values", tuple((str(k), plain_value(v)) for k, v in items))

    @property
    def mapping(self) -> dict[str, Any]:
        """The values by name."""
        return dict(self.values)
