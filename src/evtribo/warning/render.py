"""Warnings said once per kind, with the trials or cells each concerns, in the order of what
they do to the reported numbers.

A study without a tare stretch says "the normal cell's zero is unknown" once for each of its
trials; :func:`group` gives one :class:`WarningGroup` per kind: its records, where they
were said (trials, cells, subjects, the study) and what they say once, the kind's wording
filled with each field's value, or its range where the records differ (``by 1.6-3.2 %``;
records that differ in a text, a cell's name, are said as wordings of their own, up to
three). The groups come by effect (:data:`~evtribo.warning.record.EFFECTS`: a number may
change, an interval widens, for information), then by how many records each stands for.
:func:`scope_text` says where in a few words, :func:`console_lines` says it all as
``evtribo analyze``'s console does.

Records lifted from earlier results have no values: their texts are said once as earlier
versions did (:func:`~evtribo.warning.legacy.merged_texts`). A record of a kind the
catalogue lacks (a plug-in not installed here) is said with its id as its title.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from evtribo.util.numbers import frequency
from evtribo.warning.catalogue import KINDS
from evtribo.warning.kind import Kind, Span
from evtribo.warning.legacy import merged_texts
from evtribo.warning.record import EFFECTS, Scope, WarningRecord

__all__ = ["MAX_WORDINGS", "WarningGroup", "console_lines", "group", "scope_text"]

#: Most wordings of one kind said in full (the others counted).
MAX_WORDINGS = 3


@dataclass
class WarningGroup:
    """One kind of warning: what it says once, where it was said, what it does.

    Attributes
    ----------
    kind : str
        The kind's id.
    effect : str
        A key of :data:`~evtribo.warning.record.EFFECTS`.
    title : str
        The kind in a few words.
    text : str
        What the records say, once.
    records : list of WarningRecord
        The records, each once, in the order said.
    trials : list of (str, str)
        The trials it was said of, ``(subject, trial)``.
    cells : list of Scope
        The cells (a subject's drive at an amplitude) and drives it was said of.
    subjects : list of str
        The subjects it was said of as a whole.
    drives : list of str
        The drives of the population it was said of (no subject's): ``square 10 kHz``.
    study : bool
        Whether it was said of the study as a whole.
    """

    kind: str
    effect: str
    title: str
    text: str = ""
    records: list[WarningRecord] = field(default_factory=list)
    trials: list[tuple[str, str]] = field(default_factory=list)
    cells: list[Scope] = field(default_factory=list)
    subjects: list[str] = field(default_factory=list)
    drives: list[str] = field(default_factory=list)
    study: bool = False

    @property
    def count(self) -> int:
        """How many records it stands for."""
        return len(self.records)

    def touches(self, trial_cells: Mapping[tuple[str, str], Scope]) -> list[Scope]:
        """The cells this kind concerns: its own, its subjects' (any drive), its trials'.

        Parameters
        ----------
        trial_cells : mapping
            ``(subject, trial)`` -> the cell the trial measured.

        Returns
        -------
        list of Scope
            Empty when it was said of the study as a whole (it concerns every cell).
        """
        out = list(self.cells) + [Scope(s) for s in self.subjects]
        out += [trial_cells[t] for t in self.trials if t in trial_cells]
        return out


def _level(record: WarningRecord, kind: Kind | None) -> str:
    """What a record was said of (its kind's level, where its scope names it; for a kind
    the catalogue lacks or a kind of earlier results, the finest level its scope names):
    trial, cell, subject, study."""
    s = record.scope
    if s.subject is None:
        return "study"
    level = kind.scope if kind is not None and not kind.earlier else (
        "trial" if s.trial is not None else "subject" if (
            s.waveform, s.frequency_Hz, s.amplitude_V) == (None, None, None) else "cell")
    if level == "trial":
        return "trial" if s.trial is not None else "study"
    return "cell" if level in ("drive", "cell") else level


def _body(record: WarningRecord, kind: Kind | None) -> str:
    """A record's text after its scope's prefix (a kind whose wording names its file has
    none; a kind the catalogue lacks or of earlier results, the prefix of its scope)."""
    if kind is not None and not kind.earlier and not kind.prefixed:
        return record.text
    level = kind.scope if kind is not None and not kind.earlier else _level(record, None)
    prefix = record.scope.prefix(level)
    return record.text[len(prefix):] if prefix and record.text.startswith(prefix) \
        else record.text


def _numeric(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _said(records: Sequence[WarningRecord], kind: Kind | None) -> list[str]:
    """What records of one kind say, one text per wording, the most frequent first (the
    records lifted from earlier results, without values, after)."""
    by_words: dict[tuple[Any, ...], list[WarningRecord]] = {}
    bare = []
    for r in records:
        if kind is None or not r.values or not kind.fields:
            bare.append(_body(r, kind))
            continue
        values = dict(r.values)
        words = tuple((k, values.get(k)) for k in kind.fields if not _numeric(values.get(k)))
        by_words.setdefault(words, []).append(r)
    ranked = sorted(by_words.values(), key=len, reverse=True)
    filled = [_filled(kind, rs) for rs in ranked] if kind is not None else []
    return filled + (merged_texts(bare) if bare else [])


def _filled(kind: Kind, records: Sequence[WarningRecord]) -> str:
    """The kind's wording filled once for records that differ only in numbers: each number
    that differs as its range."""
    values: dict[str, Any] = {}
    for name in kind.fields:
        seen: list[Any] = [dict(r.values).get(name) for r in records]
        if all(_numeric(v) for v in seen) and len(set(seen)) > 1:
            values[name] = Span(min(seen), max(seen))
        else:
            values[name] = seen[0]
    try:
        return kind.text(values)
    except (KeyError, ValueError, TypeError):  # values a wording cannot take: as said
        return _body(records[0], kind)


def group(records: Iterable[WarningRecord]) -> list[WarningGroup]:
    """The warnings grouped by kind, each kind once, in the order of their effects.

    Parameters
    ----------
    records : iterable of WarningRecord
        The warnings (a record said twice, the same kind and text, counts once).

    Returns
    -------
    list of WarningGroup
        By effect, then by how many records each stands for (most first), then by title.
    """
    unique: dict[tuple[str, str], WarningRecord] = {}
    for record in records:
        unique.setdefault((record.kind, record.text), record)
    groups: dict[str, WarningGroup] = {}
    for record in unique.values():
        kind = KINDS.get(record.kind)
        g = groups.setdefault(record.kind, WarningGroup(
            record.kind, record.effect, kind.title if kind is not None else record.kind))
        g.records.append(record)
        level, s = _level(record, kind), record.scope
        if level == "trial":
            g.trials.append((str(s.subject), str(s.trial)))
        elif level == "cell":
            g.cells.append(Scope(s.subject, None, s.waveform, s.frequency_Hz, s.amplitude_V))
        elif level == "subject":
            g.subjects.append(str(s.subject))
        elif s.subject is None and s.waveform is not None:  # a drive of the population
            g.drives.append(_drive(s))
        else:
            g.study = True
    for g in groups.values():
        said = _said(g.records, KINDS.get(g.kind))
        rest = len(said) - MAX_WORDINGS
        g.text = " | ".join(said[:MAX_WORDINGS]) + (
            f" | and {rest} other wording(s)" if rest > 0 else "")
        g.subjects = list(dict.fromkeys(g.subjects))
        g.drives = list(dict.fromkeys(g.drives))
    order = list(EFFECTS)
    return sorted(groups.values(), key=lambda g: (
        order.index(g.effect) if g.effect in order else 0, -g.count, g.title))


def _drive(scope: Scope) -> str:
    """A drive for people: ``square 10 kHz``, ``sine 10 Hz``, ``square``."""
    wave = str(scope.waveform)
    return wave if scope.frequency_Hz is None else f"{wave} {frequency(scope.frequency_Hz)}"


def _amps(cells: Sequence[Scope]) -> str:
    amps = sorted({c.amplitude_V for c in cells if c.amplitude_V is not None})
    return ", ".join(f"{a:g}" for a in amps) + " V" if amps else "all drives"


def _trials_text(mine: Sequence[tuple[str, str]], all_trials: Sequence[tuple[str, str]]
                 ) -> str:
    mine = list(dict.fromkeys(mine))
    if all_trials and set(mine) >= set(all_trials):
        return f"all {len(set(all_trials))} trials"
    by_subject: dict[str, list[str]] = {}
    for s, t in mine:
        by_subject.setdefault(s, []).append(t)
    every = {s: {t for s2, t in all_trials if s2 == s} for s in by_subject}
    return "; ".join(f"{s} (all {len(ts)} trials)" if every[s] and set(ts) >= every[s]
                     else f"{s}: {', '.join(ts)}" for s, ts in by_subject.items())


def _cells_text(mine: Sequence[Scope], all_cells: Sequence[Scope]) -> str:
    mine = list(dict.fromkeys(mine))
    n = len(set(all_cells))
    if n and len(mine) >= n and set(mine) >= set(all_cells):
        return f"all {n} cells"
    by_subject: dict[str, list[Scope]] = {}
    for c in mine:
        by_subject.setdefault(str(c.subject), []).append(c)
    parts = []
    for s, cs in by_subject.items():
        every = {c for c in all_cells if c.subject == s}
        at = [c for c in cs if c.amplitude_V is not None]
        drives = [c.waveform or "unknown waveform" for c in cs if c.amplitude_V is None]
        if every and set(cs) >= every:
            parts.append(f"{s} (all)")
            continue
        said = [f"{s} ({', '.join(dict.fromkeys(drives))})"] if drives else []
        said += [f"{s} at {_amps(at)}"] if at else []
        parts.append("; ".join(said))
    full = all(c.amplitude_V is not None for c in mine)
    lead = (f"{len(mine)} of {n} cells: " if n else f"{len(mine)} cell(s): ") if full else ""
    return lead + "; ".join(parts)


def scope_text(group: WarningGroup, all_trials: Sequence[tuple[str, str]] = (),
               all_cells: Sequence[Scope] = ()) -> str:
    """Where a kind of warning was said, in a few words: ``all 40 trials``, ``P01: run-01,
    run-03; P02 (all 5 trials)``, ``32 of 40 cells: P01 (all); P02 at 60, 80 V``.

    Parameters
    ----------
    group : WarningGroup
    all_trials : sequence of (str, str)
        The study's trials (to say "all").
    all_cells : sequence of Scope
        The study's cells, each a subject's drive at one amplitude (to say "all").

    Returns
    -------
    str
    """
    parts = []
    if group.trials:
        parts.append(_trials_text(group.trials, all_trials))
    if group.cells:
        parts.append(_cells_text(group.cells, all_cells))
    if group.subjects:
        parts.append(", ".join(group.subjects))
    if group.drives:
        parts.append("the population at " + ", ".join(group.drives))
    if group.study and not parts:
        parts.append("the study")
    return "; ".join(parts)


def console_lines(groups: Sequence[WarningGroup], all_trials: Sequence[tuple[str, str]] = (),
                  all_cells: Sequence[Scope] = ()) -> list[str]:
    """The grouped warnings as a console says them: a heading per effect, then two lines per
    kind: ``[W1] the normal cell's zero is unknown: all 40 trials``, and what it says.

    Parameters
    ----------
    groups : sequence of WarningGroup
        From :func:`group`.
    all_trials : sequence of (str, str)
        The study's trials.
    all_cells : sequence of Scope
        The study's cells.

    Returns
    -------
    list of str
    """
    out: list[str] = []
    effect = None
    for k, g in enumerate(groups, start=1):
        if g.effect != effect:
            effect = g.effect
            out.append(f"{EFFECTS.get(effect, effect)}:")
        out.append(f"  [W{k}] {g.title}: {scope_text(g, all_trials, all_cells)}")
        out.append(f"       {g.text}")
    return out
