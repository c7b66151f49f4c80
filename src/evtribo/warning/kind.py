"""A kind of warning: its id, what it does to the results, its title, its wording with
named fields, what the researcher can do about it, and what it is said of.

A kind's wording is a :meth:`str.format` string: ``{offset_mN:+.1f}`` is the value
``offset_mN`` to one decimal with its sign, ``{key!r}`` a value quoted. Two formats of
evtribo's own: ``{lost:plural}`` is ``s`` unless the value is 1 (``{lost} frame{lost:plural}``
says ``1 frame``, ``3 frames``), ``{gap_s:duration}`` a time in seconds said in hours,
minutes or seconds (``1.2 h``, ``3.5 min``, ``12.0 s``). A :class:`Span` stands for the
values of several warnings said once: each end formatted alike, joined by an en dash
(``1.6-3.2``).
"""

from __future__ import annotations

import re
import string
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from evtribo.warning.record import EFFECTS, LEVELS, Effect, Level, Scope, WarningRecord

__all__ = ["Kind", "Span", "wording_fields"]

_ID = re.compile(r"^[a-z0-9]+(?:[-.][a-z0-9]+)*$")


@dataclass(frozen=True)
class Span:
    """The values of one field over several warnings said once: from *low* to *high*.

    Attributes
    ----------
    low, high : Any
    """

    low: Any
    high: Any


def _duration(value: Any) -> str:
    """``1.2 h``, ``3.5 min``, ``12.0 s`` (seconds)."""
    size = float(value)
    if size >= 3600:
        return f"{size / 3600:.1f} h"
    return f"{size / 60:.1f} min" if size >= 60 else f"{size:.1f} s"


class _Wording(string.Formatter):
    """:meth:`str.format` with evtribo's ``plural`` and ``duration`` and with spans."""

    def convert_field(self, value: Any, conversion: str | None) -> Any:
        if isinstance(value, Span):
            return Span(super().convert_field(value.low, conversion),
                        super().convert_field(value.high, conversion))
        return super().convert_field(value, conversion)

    def format_field(self, value: Any, format_spec: str) -> str:
        if isinstance(value, Span):
            if format_spec == "plural":
                return "s"
            low, high = (self.format_field(v, format_spec) for v in (value.low, value.high))
            return low if low == high else f"{low}\u2013{high}"
        if format_spec == "plural":
            return "" if value == 1 else "s"
        if format_spec == "duration":
            return _duration(value)
        return str(super().format_field(value, format_spec))


_FORMAT = _Wording()


def wording_fields(wording: str) -> tuple[str, ...]:
    """The fields a wording names, each once, in order.

    Parameters
    ----------
    wording : str

    Returns
    -------
    tuple of str

    Raises
    ------
    ValueError
        The wording does not parse, or names a field that is no plain name (``{a.b}``,
        ``{0}``, ``{}``).
    """
    names = []
    for _, name, spec, _ in _FORMAT.parse(wording):
        if name is None:
            continue
        if not name.isidentifier():
            raise ValueError(f"wording field {{{name}}} is not a plain name")
        if spec and "{" in spec:
            raise ValueError(f"wording field {{{name}}}: no nested fields in a format")
        names.append(name)
    return tuple(dict.fromkeys(names))


@dataclass(frozen=True)
class Kind:
    """A kind of warning.

    Attributes
    ----------
    id : str
        Its key (``normal-zero``): lower-case letters and digits, words joined by ``-`` (a
        plug-in's may begin with its name and ``.``: ``mylab.humidity``).
    effect : {"number", "interval", "information"}
        What it does to the reported numbers.
    title : str
        The kind in a few words, as the report and the console head it.
    wording : str
        What it says, a :meth:`str.format` string with named fields (the module's text);
        the scope's prefix is not part of it.
    todo : str
        What the researcher can do about it, one sentence.
    scope : {"study", "subject", "drive", "cell", "trial"}
        What it is said of.
    prefixed : bool
        Whether its text starts with the scope's prefix (:meth:`Scope.prefix`); False where
        the wording names its place itself (a file's path).
    earlier : bool
        Said only by earlier versions of evtribo: a kind results written before it existed
        are read with, its wording ``{text}``.
    stands_for : tuple of str
        In summary.json written by earlier versions, this id also stands for what these
        kinds now say.
    """

    id: str
    effect: Effect
    title: str
    wording: str
    todo: str
    scope: Level
    prefixed: bool = True
    earlier: bool = False
    stands_for: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not isinstance(self.id, str) or not _ID.match(self.id):
            raise ValueError(f"warning kind id {self.id!r}: lower-case letters and digits, "
                             "words joined by '-' or '.'")
        if self.effect not in EFFECTS:
            raise ValueError(f"warning kind {self.id}: effect {self.effect!r} is not one of "
                             f"{', '.join(EFFECTS)}")
        if self.scope not in LEVELS:
            raise ValueError(f"warning kind {self.id}: scope {self.scope!r} is not one of "
                             f"{', '.join(LEVELS)}")
        for name in ("title", "wording", "todo"):
            if not isinstance(getattr(self, name), str) or not getattr(self, name).strip():
                raise ValueError(f"warning kind {self.id}: no {name}")
        try:
            wording_fields(self.wording)
        except ValueError as err:
            raise ValueError(f"warning kind {self.id}: {err}") from None

    @property
    def fields(self) -> tuple[str, ...]:
        """The fields its wording names, in order."""
        return wording_fields(self.wording)

    def text(self, values: Mapping[str, Any]) -> str:
        """The wording filled with *values* (no prefix).

        Parameters
        ----------
        values : mapping
            A value for each of :attr:`fields` (more are ignored); a :class:`Span` stands
            for several.

        Returns
        -------
        str

        Raises
        ------
        KeyError
            A field without a value.
        """
        return _FORMAT.vformat(self.wording, (), values)

    def record(self, scope: Scope | None = None, values: Mapping[str, Any] | None = None,
               source: str = "") -> WarningRecord:
        """A warning of this kind: its text rendered now, its scope's prefix first.

        Parameters
        ----------
        scope : Scope, optional
            Where it is said (default: the study).
        values : mapping, optional
            The wording's values (strings, numbers, booleans or None).
        source : str
            The module that says it.

        Returns
        -------
        WarningRecord

        Raises
        ------
        KeyError
            A field of the wording without a value.
        TypeError
            A value that is not plain data.
        """
        scope = scope or Scope()
        values = dict(values or {})
        prefix = scope.prefix(self.scope) if self.prefixed else ""
        return WarningRecord(self.id, self.effect, scope, tuple(values.items()),
                             prefix + self.text(values), source)
