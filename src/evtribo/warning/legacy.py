"""Warnings of results written by earlier versions of evtribo, lifted into records.

Earlier versions kept each warning in summary.json as a line of text (``P01/run-03: the
normal cell's zero is unknown ...``) and told its kind afterwards by the patterns below, a
frozen copy of those versions' own: :func:`lift` reads a line's scope (a trial, a cell, a
drive, a subject, or the study) and its kind as they did, so that older result folders
still report and compare with the same kinds, and gives it as a :class:`WarningRecord`
with the line as its text and no values. A line none of the patterns knows is of kind
``earlier-unclassified`` (it may change a number: nobody has said it does not).

The kinds only earlier versions said (``sequence``, ``study-files``,
``earlier-unclassified``) are declared here (:data:`EARLIER_KINDS`); :func:`merged_texts`
says several lifted texts of one kind once, as those versions did (each number that differs
as its range).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence

from evtribo.warning.kind import Kind
from evtribo.warning.record import Scope, WarningRecord

__all__ = ["EARLIER_KINDS", "PATTERNS", "lift", "lift_all", "merged_texts"]

_AGAIN = "Analyse the study again with this evtribo to have each warning of its own kind."

#: The kinds only results of earlier versions have.
EARLIER_KINDS: tuple[Kind, ...] = (
    Kind("sequence", "information", "the logger's clock or a cell's frames put in order",
         "{text}", _AGAIN, "trial", prefixed=False, earlier=True,
         stands_for=("clock-step", "counter-restart", "counter-jump", "frames-twice",
                     "counter-stood")),
    Kind("study-files", "information", "study files", "{text}", _AGAIN, "trial",
         prefixed=False, earlier=True,
         stands_for=("log-part-superseded", "sidecar-unknown-key", "sidecar-missing",
                     "log-partial", "subject-outside", "input-gone", "inputs-outside")),
    Kind("earlier-unclassified", "number", "warnings of no known kind (earlier results)",
         "{text}", "Analyse the study again with this evtribo: each warning then has its "
         "kind, and says what it does to the results.", "study", prefixed=False,
         earlier=True,
         stands_for=("rerecording-unfinished", "rerecording-leftover", "sidecar-without-log",
                     "trials-unlisted", "input-changed-during", "candump-deltas",
                     "cache-unwritable", "dbc-lenient", "frames-short", "frames-undecoded",
                     "frames-decode-failed", "frames-id-kind", "frames-fd-kind",
                     "timestamps-nonfinite", "channels-several", "counter-elsewhere",
                     "waveform-codes", "samples-range-wrong", "samples-bad",
                     "periods-unsure", "periods-unsure-still", "more-warnings")),
)

#: The patterns earlier versions told a line's kind by, after its scope (the first found
#: in the text wins): ``(id, effect, pattern)``. Frozen: never edited.
PATTERNS: tuple[tuple[str, str, str], ...] = (
    ("not-analysed", "number", r"^not analysed: "),
    ("input-changed", "number",
     r"changed since the analysis|in the study folder but not in the analysis"),
    ("roles", "number", r"roles look swapped"),
    ("mu-implausible", "number", r"outside what fingers give"),
    ("negative-force", "number", r"electrostatic force is below zero"),
    ("normal-zero", "number", r"the normal cell's zero is unknown"),
    ("directions-confounded", "number", r"ON windows are left out: the OFF windows all"),
    ("tangential-zero", "number", r"the tangential cell's zero is unknown"),
    ("crosstalk-normal", "number", r"the normal cell reads .* of the tangential force"),
    ("drift-unseen", "number", r"are ON throughout and were compared with other trials"),
    ("amplitude-unknown", "number", r"amplitude of the ON windows is unknown"),
    ("no-force", "number", r"^no electrostatic force"),
    ("no-mu", "number", r"no OFF windows to estimate"),
    ("no-power-law", "number", r"^no power law"),
    ("power-law-near-zero", "number", r"^left out of the power law"),
    ("other-off", "number", r"alternates but has no OFF window"),
    ("law-untold", "number", r"span too little to tell"),
    ("long-phases", "interval", r"phases are too long"),
    ("few-windows", "interval", r"windows \(fewer than \d+\)"),
    ("mu-scatter", "interval", r"friction coefficient scatters by"),
    ("no-window", "interval", r"no steady-sliding window found"),
    ("piece-left", "interval", r"^the piece from .* is not analysed"),
    ("offset", "information", r"cell's zero offset was"),
    ("zero-drift", "information", r"cell's zero drifted by"),
    ("drift-followed", "information", r"friction coefficient changed within"),
    ("pace", "information", r"friction follows the strokes' pace"),
    ("crosstalk-tangential", "information", r"tangential reading follows the normal force"),
    ("no-lift", "information", r"no finger-lifted stretch was found"),
    ("sidecar-signals", "information", r"^the sidecar says .* but the excitation signals say"),
    ("frames-lost", "information",
     r"frames missing|dropped frame|frames on this channel \(DROPCOUNT\)|dropped \d+ "
     r"frames|frames lost where the stream's|to see single lost frames"),
    ("counter-law", "information",
     r"^the counter \S+ (?:counts from|does not count|never counted)"),
    ("damaged-lines", "information", r"damaged line"),
    ("pieces", "information",
     r"^analysed in \d+ continuous pieces|^the load cells fell silent|^a gap of|"
     r"^no frame of the load cells for"),
    ("sequence", "information",
     r"^the logger's clock stepped|^the counter \S+ (?:restarted|jumped from|stood still)"
     r"|received twice, the first at"),
    ("sign-flipped", "information", r"normal force is negative"),
    ("modulation", "information", r"friction modulation at|no oscillation of the friction"),
    ("same-log", "information", r"the same recording under\s+two names"),
    ("cut-short", "information", r"the recording was (?:interrupted|ended)"),
    ("whole-off", "information", r"no whole-OFF trial"),
    ("study-files", "information",
     r"no sidecar|partial trial|unknown key .* ignored|is the trial's complete|"
     r"outside the study folder|no longer in the study folder"),
)

_COMPILED = tuple((id, effect, re.compile(p)) for id, effect, p in PATTERNS)
#: A number in a message (not a digit of a name: run-03, 0C1).
_NUMBER = re.compile(r"(?<![\w.-])[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?(?![\w.]\d)(?!\w)")
_TRIAL = re.compile(r"^(?P<subject>[^\s/:]+)/(?P<trial>[^\s/:]+): (?P<rest>.*)$", re.S)
_LOG = re.compile(r"^(?:[^:]*/)?(?P<subject>[^\s/:]+)/(?P<trial>[^\s/:.]+)\.\w+: ", re.S)
_CELL = re.compile(r"^(?P<subject>[^\s:]+) \((?P<drive>[^()]*)\) at (?P<amp>[-+0-9.eE]+) V: "
                   r"(?P<rest>.*)$", re.S)
_DRIVE = re.compile(r"^(?P<subject>[^\s:]+) \((?P<drive>[^()]*)\): (?P<rest>.*)$", re.S)
_SUBJECT = re.compile(r"^(?P<subject>[^\s:/]+): (?P<rest>.*)$", re.S)


def _drive(text: str) -> tuple[str | None, float | None]:
    """``square, 10000 Hz`` -> ("square", 10000.0)."""
    parts = [p.strip() for p in text.split(",")]
    wave = parts[0] if parts and parts[0] != "unknown waveform" else None
    freq = None
    if len(parts) > 1:
        m = re.match(r"([-+0-9.eE]+)\s*Hz", parts[1])
        freq = float(m.group(1)) if m else None
    return wave, freq


def _scope(line: str, subjects: set[str] | None, trials: set[tuple[str, str]] | None
           ) -> tuple[Scope, str]:
    """A line's scope and the text after it (None: any subject or trial is one)."""
    def trial(m: re.Match[str]) -> bool:
        return trials is None or (m["subject"], m["trial"]) in trials

    def subject(m: re.Match[str]) -> bool:
        return subjects is None or m["subject"] in subjects

    if (m := _TRIAL.match(line)) and trial(m):
        return Scope(m["subject"], m["trial"]), m["rest"]
    if (m := _LOG.match(line)) and trial(m):  # a trial named by its file: the name stays
        return Scope(m["subject"], m["trial"]), line
    if (m := _CELL.match(line)) and subject(m):
        wave, freq = _drive(m["drive"])
        return Scope(m["subject"], None, wave, freq, float(m["amp"])), m["rest"]
    if (m := _DRIVE.match(line)) and subject(m):
        wave, freq = _drive(m["drive"])
        return Scope(m["subject"], None, wave, freq), m["rest"]
    if (m := _SUBJECT.match(line)) and subject(m):
        return Scope(m["subject"]), m["rest"]
    return Scope(), line


def lift(line: str, subjects: Iterable[str] | None = None,
         trials: Iterable[tuple[str, str]] | None = None) -> WarningRecord:
    """A warning line of an earlier version's summary.json as a record: its kind and scope
    as that version told them, the line as its text.

    Parameters
    ----------
    line : str
        The warning, as summary.json kept it.
    subjects : iterable of str, optional
        The study's subjects: a line's scope is a subject's only if it is one of them (none
        given: any name before ``": "``).
    trials : iterable of (str, str), optional
        The study's trials ``(subject, trial)``, likewise.

    Returns
    -------
    WarningRecord
        Of kind ``earlier-unclassified`` (effect ``number``) when no pattern knows it.
    """
    trial_set = None if trials is None else {(str(s), str(t)) for s, t in trials}
    subject_set = None if subjects is None and trials is None else (
        {str(s) for s in subjects or ()} | {s for s, _ in trial_set or ()})
    scope, rest = _scope(line, subject_set, trial_set)
    for id, effect, pattern in _COMPILED:
        if pattern.search(rest) or pattern.search(line):
            return WarningRecord(id, effect, scope, (), line)  # type: ignore[arg-type]
    return WarningRecord("earlier-unclassified", "number", scope, (), line)


def lift_all(lines: Iterable[str], subjects: Iterable[str] | None = None,
             trials: Iterable[tuple[str, str]] | None = None) -> list[WarningRecord]:
    """Every line lifted (:func:`lift`), in order, each line once.

    Parameters
    ----------
    lines : iterable of str
    subjects : iterable of str, optional
    trials : iterable of (str, str), optional

    Returns
    -------
    list of WarningRecord
    """
    subjects = None if subjects is None else list(subjects)
    trials = None if trials is None else list(trials)
    return [lift(line, subjects, trials) for line in dict.fromkeys(str(x) for x in lines)]


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


def merged_texts(texts: Sequence[str]) -> list[str]:
    """Texts of one kind said once as earlier versions did: those that differ only in their
    numbers merged, each number that differs as its range, the most frequent wording first.

    Parameters
    ----------
    texts : sequence of str
        The texts after their scope.

    Returns
    -------
    list of str
        One per wording.
    """
    by_skeleton: dict[str, list[str]] = {}
    for t in texts:
        by_skeleton.setdefault(_NUMBER.sub("#", t), []).append(t)
    return [_merged_one(group) for group in sorted(by_skeleton.values(), key=len,
                                                          reverse=True)]
