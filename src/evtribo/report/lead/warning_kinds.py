"""The analysis's warnings said once per kind, with the trials or cells each concerns, in the
order of what they do to the reported numbers.

``summary.json`` keeps every warning as the analysis said it, one line per trial or cell:
a study recorded without a finger-lifted stretch says "the normal cell's zero is unknown"
once for each of its trials, and one of short trials says "fewer than 5 windows" for most
of its cells. :func:`group_warnings` reads each line's scope (``P01/run-03: ...`` a trial,
``P01 (square, 10000 Hz) at 80 V: ...`` a cell, ``P01: ...`` a subject, anything else the
study) and its kind (:data:`KINDS`, matched on the text after the scope; a line of no known
kind is a kind of its own, its numbers aside), and gives one :class:`WarningGroup` per kind:

1. ``number``: may change a reported number beyond its interval (an unknown zero, a trial
   left out, roles swapped, cross-talk in the normal forces reported);
2. ``interval``: widens an interval, which already holds it (few windows, scattered
   friction, a trial or a piece without windows);
3. ``unclassified``: a warning of a kind not listed here, as said;
4. ``information``: corrected or harmless (offsets removed, drifts followed, frames lost).

Lines of a kind differing only in their numbers are said once with each number's range
(``by 1.6-3.2 %``). It imports nothing heavy: ``evtribo analyze`` uses it for its console.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

from evtribo.report.lead.kinds import EFFECTS, KINDS, Kind
from evtribo.report.lead.scope import Cell, read_scope, study_cells

__all__ = ["EFFECTS", "KINDS", "Cell", "Kind", "WarningGroup", "console_lines",
           "group_warnings", "read_scope", "scope_text", "study_cells"]

_COMPILED = tuple((k, re.compile(k.pattern)) for k in KINDS)
#: A number in a message (not a digit of a name: run-03, 0C1).
_NUMBER = re.compile(r"(?<![\w.-])[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?(?![\w.]\d)(?!\w)")
_TRIAL = re.compile(r"^(?P<subject>[^\s/:]+)/(?P<trial>[^\s/:]+): (?P<rest>.*)$", re.S)
_LOG = re.compile(r"^(?:[^:]*/)?(?P<subject>[^\s/:]+)/(?P<trial>[^\s/:.]+)\.\w+: ", re.S)
_CELL = re.compile(r"^(?P<subject>[^\s:]+) \((?P<drive>[^()]*)\) at (?P<amp>[-+0-9.eE]+) V: "
                   r"(?P<rest>.*)$", re.S)
_DRIVE = re.compile(r"^(?P<subject>[^\s:]+) \((?P<drive>[^()]*)\): (?P<rest>.*)$", re.S)
_SUBJECT = re.compile(r"^(?P<subject>[^\s:/]+): (?P<rest>.*)$", re.S)


@dataclass
class WarningGroup:
    """One kind of warning: what it says once, where it was said, what it does.

    Attributes
    ----------
    key : str
        The kind's key (``normal-zero``; ``other:<text>`` for a kind not listed).
    effect : str
        A key of :data:`EFFECTS`.
    title : str
        The kind in a few words.
    text : str
        What the lines say, once (each number that differs between them as its range).
    trials : list of (str, str)
        The trials it was said of, ``(subject, trial)``.
    cells : list of Cell
        The cells it was said of (subject, drive and amplitude).
    subjects : list of str
        The subjects it was said of as a whole.
    study : bool
        Whether it was said of the study as a whole.
    lines : list of str
        The lines as summary.json holds them.
    """

    key: str
    effect: str
    title: str
    text: str = ""
    trials: list[tuple[str, str]] = field(default_factory=list)
    cells: list[Cell] = field(default_factory=list)
    subjects: list[str] = field(default_factory=list)
    study: bool = False
    lines: list[str] = field(default_factory=list)

    @property
    def count(self) -> int:
        """How many lines of summary.json it stands for."""
        return len(self.lines)

    def touches(self, trial_cells: Mapping[tuple[str, str], Cell]) -> list[Cell]:
        """The cells this kind concerns: its own, its subjects' (any drive), its trials'.

        Parameters
        ----------
        trial_cells : mapping
            ``(subject, trial)`` -> the cell the trial measured.

        Returns
        -------
        list of Cell
            Empty when it was said of the study as a whole (it concerns every cell).
        """
        out = list(self.cells) + [Cell(s) for s in self.subjects]
        out += [trial_cells[t] for t in self.trials if t in trial_cells]
        return out


def _kind(rest: str, full: str) -> Kind:
    for kind, pattern in _COMPILED:
        if pattern.search(rest) or pattern.search(full):
            return kind
    skeleton = _NUMBER.sub("#", rest)
    title = re.split(r"[;:]", rest, maxsplit=1)[0][:80]
    return Kind(f"other:{skeleton}", "unclassified", title, "")


def _drive(text: str) -> tuple[str | None, float | None]:
    """``square, 10000 Hz`` -> ("square", 10000.0)."""
    parts = [p.strip() for p in text.split(",")]
    wave = parts[0] if parts and parts[0] != "unknown waveform" else None
    freq = None
    if len(parts) > 1:
        m = re.match(r"([-+0-9.eE]+)\s*Hz", parts[1])
        freq = float(m.group(1)) if m else None
    return wave, freq


def _scope(line: str, subjects: set[str], trials: set[tuple[str, str]]
           ) -> tuple[str, object, str]:
    """``(kind of scope, where, the rest of the text)`` of one line."""
    m = _TRIAL.match(line)
    if m and (m["subject"], m["trial"]) in trials:
        return "trial", (m["subject"], m["trial"]), m["rest"]
    m = _LOG.match(line)  # a trial named by its file's path: the name stays in the text
    if m and (m["subject"], m["trial"]) in trials:
        return "trial", (m["subject"], m["trial"]), line
    m = _CELL.match(line)
    if m and m["subject"] in subjects:
        wave, freq = _drive(m["drive"])
        return "cell", Cell(m["subject"], wave, freq, float(m["amp"])), m["rest"]
    m = _DRIVE.match(line)
    if m and m["subject"] in subjects:
        wave, freq = _drive(m["drive"])
        return "cell", Cell(m["subject"], wave, freq, None), m["rest"]
    m = _SUBJECT.match(line)
    if m and m["subject"] in subjects:
        return "subject", m["subject"], m["rest"]
    return "study", None, line


def _merged_one(texts: Sequence[str]) -> str:
    """Texts that differ only in their numbers, said once: each number that differs as its
    range (``1.6-3.2``)."""
    numbers = [[m.group(0) for m in _NUMBER.finditer(t)] for t in texts]
    columns = list(zip(*numbers, strict=True))
    out = []
    for k, part in enumerate(_NUMBER.split(texts[0])):
        out.append(part)
        if k < len(columns):
            values = sorted(set(columns[k]), key=float)
            out.append(values[0] if len(values) == 1 else f"{values[0]}\u2013{values[-1]}")
    return "".join(out)


#: Most wordings of one kind said in full (the others counted).
_MAX_WORDINGS = 3


def _merged(texts: Sequence[str]) -> str:
    """The texts said once: those that differ only in their numbers merged
    (:func:`_merged_one`), up to :data:`_MAX_WORDINGS` wordings, the most frequent first."""
    by_skeleton: dict[str, list[str]] = {}
    for t in texts:
        by_skeleton.setdefault(_NUMBER.sub("#", t), []).append(t)
    ranked = sorted(by_skeleton.values(), key=len, reverse=True)
    said = [_merged_one(group) for group in ranked[:_MAX_WORDINGS]]
    rest = len(ranked) - len(said)
    return " | ".join(said) + (f" | and {rest} other wording(s)" if rest > 0 else "")


def group_warnings(lines: Iterable[str], subjects: Iterable[str] = (),
                   trials: Iterable[tuple[str, str]] = ()) -> list[WarningGroup]:
    """The warnings grouped by kind, each kind once, in the order of :data:`EFFECTS`.

    Parameters
    ----------
    lines : iterable of str
        The warnings, as summary.json keeps them (repeats said once).
    subjects : iterable of str
        The study's subjects (a line's scope is a subject's only if it is one of them).
    trials : iterable of (str, str)
        The study's trials, ``(subject, trial)``.

    Returns
    -------
    list of WarningGroup
        By effect, then by how many lines each stands for (most first), then by title.
    """
    subject_set = {str(s) for s in subjects}
    trial_set = {(str(s), str(t)) for s, t in trials}
    subject_set |= {s for s, _ in trial_set}
    groups: dict[str, WarningGroup] = {}
    rests: dict[str, list[str]] = {}
    for line in dict.fromkeys(str(x) for x in lines):
        scope, where, rest = _scope(line, subject_set, trial_set)
        kind = _kind(rest, line)
        group = groups.setdefault(kind.key, WarningGroup(kind.key, kind.effect, kind.title))
        group.lines.append(line)
        rests.setdefault(kind.key, []).append(rest)
        if scope == "trial":
            assert isinstance(where, tuple)
            group.trials.append((str(where[0]), str(where[1])))
        elif scope == "cell":
            assert isinstance(where, Cell)
            group.cells.append(where)
        elif scope == "subject":
            group.subjects.append(str(where))
        else:
            group.study = True
    for key, group in groups.items():
        group.text = _merged(rests[key])
        group.subjects = list(dict.fromkeys(group.subjects))
    order = list(EFFECTS)
    return sorted(groups.values(), key=lambda g: (order.index(g.effect), -g.count, g.title))


def _amps(cells: Sequence[Cell]) -> str:
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


def _cells_text(mine: Sequence[Cell], all_cells: Sequence[Cell]) -> str:
    mine = list(dict.fromkeys(mine))
    n = len(set(all_cells))
    if n and len(mine) >= n and set(mine) >= set(all_cells):
        return f"all {n} cells"
    by_subject: dict[str, list[Cell]] = {}
    for c in mine:
        by_subject.setdefault(c.subject, []).append(c)
    parts = []
    for s, cs in by_subject.items():
        every = {c for c in all_cells if c.subject == s}
        at = [c for c in cs if c.amplitude_V is not None]
        drives = [c.waveform or "unknown waveform" for c in cs if c.amplitude_V is None]
        if every and set(cs) >= every:
            parts.append(f"{s} (all)")
            continue
        said = ([f"{s} ({', '.join(dict.fromkeys(drives))})"] if drives else [])
        said += [f"{s} at {_amps(at)}"] if at else []
        parts.append("; ".join(said))
    full = all(c.amplitude_V is not None for c in mine)
    lead = (f"{len(mine)} of {n} cells: " if n else f"{len(mine)} cell(s): ") if full else ""
    return lead + "; ".join(parts)


def scope_text(group: WarningGroup, all_trials: Sequence[tuple[str, str]] = (),
               all_cells: Sequence[Cell] = ()) -> str:
    """Where a kind of warning was said, in a few words: ``all 40 trials``, ``P01: run-01,
    run-03; P02 (all 5 trials)``, ``32 of 40 cells: P01 (all); P02 at 60, 80 V``.

    Parameters
    ----------
    group : WarningGroup
    all_trials : sequence of (str, str)
        The study's trials (to say "all").
    all_cells : sequence of Cell
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
    if group.study and not parts:
        parts.append("the study")
    return "; ".join(parts)


def console_lines(groups: Sequence[WarningGroup], all_trials: Sequence[tuple[str, str]] = (),
                  all_cells: Sequence[Cell] = ()) -> list[str]:
    """The grouped warnings as a console says them: a heading per effect, then two lines per
    kind: ``[W1] the normal cell's zero is unknown: all 40 trials``, and what it says.

    Parameters
    ----------
    groups : sequence of WarningGroup
        From :func:`group_warnings`.
    all_trials : sequence of (str, str)
        The study's trials.
    all_cells : sequence of Cell
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
            out.append(f"{EFFECTS[effect]}:")
        out.append(f"  [W{k}] {g.title}: {scope_text(g, all_trials, all_cells)}")
        out.append(f"       {g.text}")
    return out
