"""The notes of comparisons written by earlier versions of evtribo, lifted into records.

Earlier versions kept what ``evtribo compare`` said in fit.json as lines of text (its
``notes``, and its ``population``'s ``notes`` and ``exclusion_rule``), with no kind. Their
texts are those this version's kinds say (:mod:`evtribo.warning.kinds_compare`), so the
patterns below, frozen, tell each line's kind: :func:`lift_notes` gives each as a
:class:`WarningRecord` of that kind (its effect the kind's), its text the line's, no values;
a line of a subject (``P01: ...``) is said of it. A line none of the patterns knows is of
kind ``compare-note`` (for information: earlier versions called these notes, not warnings).
"""

from __future__ import annotations

import re
from collections.abc import Iterable

from evtribo.warning.kind import Kind
from evtribo.warning.record import Scope, WarningRecord

__all__ = ["EARLIER_COMPARE_KINDS", "NOTE_PATTERNS", "lift_notes"]

#: The kinds only comparisons of earlier versions have.
EARLIER_COMPARE_KINDS: tuple[Kind, ...] = (
    Kind("compare-note", "information", "a note of an earlier comparison", "{text}",
         "Compare again with this evtribo (evtribo compare OUT --force) to have each note "
         "as a warning of its kind.", "study", prefixed=False, earlier=True),
)

#: The patterns telling an earlier fit.json's line's kind: ``(id, effect, level,
#: pattern)``, the first found wins. Frozen: never edited.
NOTE_PATTERNS: tuple[tuple[str, str, str, str], ...] = (
    ("intervals-bootstrap", "information", "study",
     r"^Intervals of .*: 2\.5-97\.5 % percentiles"),
    ("bootstrap-missing", "number", "study",
     r"^No electrostatic_bootstrap\.csv in the result folder"),
    ("intervals-jacobian", "number", "subject", r"^Intervals of \S+ from the Jacobian"),
    ("fit-none", "information", "study", r"^No electrostatic force in these results"),
    ("models-ranked", "information", "study", r"^Models over the study"),
    ("model-not-fitted", "information", "study", r"^Model \S+ of .* could not be fitted"),
    ("model-at-bound", "number", "study", r"^Model \S+: .* at its bound for "),
    ("models-one-frequency", "information", "study",
     r"subject\(s\) with each drive at a single frequency"),
    ("sine-trace-none", "information", "study", r"^No measured sine trace"),
    ("checks-chosen", "information", "study", r"^Each trial's check: drawn for"),
    ("checks-study-gone", "information", "study",
     r"^The study folder .* is not there: no check figures"),
    ("checks-study-unreadable", "information", "study", r"^No check figures of the trials: "),
    ("check-not-analysed", "information", "study",
     r"^Trial \S+: not analysed, so nothing to check"),
    ("population-rule-unread", "number", "study",
     r"^the study folder .* was not there: its study\.toml's \[population\] rule"),
    ("population-excluded", "information", "subject",
     r"^[^\s:]+: excluded from the population's estimates by the study's rule"),
    ("population-too-few", "number", "study",
     r"^\d+ subject\(s\) with electrostatic forces: a population estimate needs"),
    ("population-cell-no-interval", "number", "study",
     r" V: F_el without an interval: left out of the population"),
    ("population-cell-not-positive", "number", "study",
     r" V: F_el not positive \(no logarithm\)"),
    ("population-pool-few", "number", "study",
     r"subject\(s\) to pool; a population estimate needs"),
    ("population-drive-few", "number", "study",
     r": \d+ subject\(s\) with electrostatic forces; a population estimate needs"),
    ("population-one-amplitude", "number", "study", r": one amplitude only, no power law"),
    ("population-amplitudes-few", "number", "study",
     r" amplitudes, fewer than the .* model needs"),
    ("population-model-failed", "number", "study",
     r": the mixed model with random \w+ could not be fitted"),
    ("population-checks-failed", "number", "study", r": the mixed model's checks failed: "),
    ("population-singular", "information", "study", r"\(a singular fit"),
    ("population-meta-few", "number", "study",
     r" V: no meta-analysis of log F_el \(\d+ subject\(s\) measured there"),
    ("population-meta-invalid", "number", "study", r" V: no meta-analysis of log F_el \("),
    ("population-air-gap-undetermined", "number", "subject",
     r"^[^\s:]+: its fitted air gap h_L is not determined"),
)

_COMPILED = tuple((id, effect, level, re.compile(p)) for id, effect, level, p in NOTE_PATTERNS)


def _lift(line: str) -> WarningRecord:
    for id, effect, level, pattern in _COMPILED:
        if pattern.search(line):
            scope = Scope(line.split(": ", 1)[0]) if level == "subject" else Scope()
            return WarningRecord(id, effect, scope, (), line)  # type: ignore[arg-type]
    return WarningRecord("compare-note", "information", Scope(), (), line)


def lift_notes(lines: Iterable[object]) -> list[WarningRecord]:
    """An earlier fit.json's notes as records, in order, each line once.

    Parameters
    ----------
    lines : iterable
        The lines (anything else than a string: its ``str``).

    Returns
    -------
    list of WarningRecord
        Of kind ``compare-note`` (for information) when no pattern knows the line.
    """
    return [_lift(line) for line in dict.fromkeys(str(x) for x in lines)]
