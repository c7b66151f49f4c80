"""The kinds of the analysis's warnings: what each does to the reported numbers, its title,
and the pattern its text matches after its scope (:mod:`evtribo.report.lead.warning_kinds`
groups the warnings by them)."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["EFFECTS", "KINDS", "Kind"]


#: What a kind of warning does to the headline numbers, in the order they are said.
EFFECTS: dict[str, str] = {
    "number": "may change a reported number",
    "interval": "widens an interval (the interval holds it)",
    "unclassified": "not classified",
    "information": "for information",
}


@dataclass(frozen=True)
class Kind:
    """A kind of warning: its key, its effect (a key of :data:`EFFECTS`), its title and the
    pattern its text matches after the scope."""

    key: str
    effect: str
    title: str
    pattern: str


#: The analysis's warnings by kind (the first whose pattern is found in the text wins).
KINDS: tuple[Kind, ...] = (
    Kind("not-analysed", "number", "trials not analysed", r"^not analysed: "),
    Kind("input-changed", "number", "inputs changed since the analysis",
         r"changed since the analysis|in the study folder but not in the analysis"),
    Kind("roles", "number", "the normal and tangential roles look swapped", r"roles look swapped"),
    Kind("mu-implausible", "number", "friction coefficient outside what fingers give",
         r"outside what fingers give"),
    Kind("negative-force", "number", "electrostatic force below zero beyond its interval",
         r"electrostatic force is below zero"),
    Kind("normal-zero", "number", "the normal cell's zero is unknown",
         r"the normal cell's zero is unknown"),
    Kind("directions-confounded", "number", "ON windows left out: slid the other way from "
         "the OFF windows, the zero unknown", r"ON windows are left out: the OFF windows all"),
    Kind("tangential-zero", "number", "the tangential cell's zero is unknown",
         r"the tangential cell's zero is unknown"),
    Kind("crosstalk-normal", "number", "the normal cell reads part of the tangential force",
         r"the normal cell reads .* of the tangential force"),
    Kind("drift-unseen", "number", "friction changed within ON-only trials",
         r"are ON throughout and were compared with other trials"),
    Kind("amplitude-unknown", "number", "amplitude of the ON windows unknown",
         r"amplitude of the ON windows is unknown"),
    Kind("no-force", "number", "no electrostatic force", r"^no electrostatic force"),
    Kind("no-mu", "number", "no OFF windows to estimate μ from", r"no OFF windows to estimate"),
    Kind("no-power-law", "number", "no power law", r"^no power law"),
    Kind("power-law-near-zero", "number", "cells left out of the power law (F_el within its "
         "error of zero)", r"^left out of the power law"),
    Kind("other-off", "number", "ON windows compared with other trials' OFF windows",
         r"alternates but has no OFF window"),
    Kind("law-untold", "number", "friction law not measured (m = 1)", r"span too little to tell"),
    Kind("long-phases", "interval", "phases too long to tell a drift", r"phases are too long"),
    Kind("few-windows", "interval", "fewer than 5 ON or OFF windows",
         r"windows \(fewer than \d+\)"),
    Kind("mu-scatter", "interval", "friction scatters between strokes",
         r"friction coefficient scatters by"),
    Kind("no-window", "interval", "trials without a steady-sliding window",
         r"no steady-sliding window found"),
    Kind("piece-left", "interval", "pieces of a trial not analysed",
         r"^the piece from .* is not analysed"),
    Kind("offset", "information", "zero offsets removed", r"cell's zero offset was"),
    Kind("zero-drift", "information", "zeros that drifted, followed", r"cell's zero drifted by"),
    Kind("drift-followed", "information", "friction changed within trials, followed",
         r"friction coefficient changed within"),
    Kind("pace", "information", "friction follows the strokes' pace",
         r"friction follows the strokes' pace"),
    Kind("crosstalk-tangential", "information",
         "the tangential reading follows the normal force",
         r"tangential reading follows the normal force"),
    Kind("no-lift", "information", "no finger-lifted stretch where the sidecar says one",
         r"no finger-lifted stretch was found"),
    Kind("sidecar-signals", "information", "sidecar and excitation signals disagree",
         r"^the sidecar says .* but the excitation signals say"),
    Kind("frames-lost", "information", "load-cell frames lost",
         r"frames missing|dropped frame|frames on this channel \(DROPCOUNT\)|dropped \d+ "
         r"frames|frames lost where the stream's|to see single lost frames"),
    Kind("counter-law", "information", "a load cell's counter as its firmware counts",
         r"^the counter \S+ (?:counts from|does not count|never counted)"),
    Kind("damaged-lines", "information", "damaged log lines skipped", r"damaged line"),
    Kind("pieces", "information", "trials analysed in pieces",
         r"^analysed in \d+ continuous pieces|^the load cells fell silent|^a gap of|"
         r"^no frame of the load cells for"),
    Kind("sequence", "information", "the logger's clock or a cell's frames put in order",
         r"^the logger's clock stepped|^the counter \S+ (?:restarted|jumped from|stood still)"
         r"|received twice, the first at"),
    Kind("sign-flipped", "information", "negative normal force, sign flipped",
         r"normal force is negative"),
    Kind("modulation", "information", "friction modulation not measured",
         r"friction modulation at|no oscillation of the friction"),
    Kind("same-log", "information", "the same recording under two names",
         r"the same recording under\s+two names"),
    Kind("cut-short", "information", "recordings cut short (what was recorded analysed)",
         r"the recording was (?:interrupted|ended)"),
    Kind("whole-off", "information", "no whole-OFF trial", r"no whole-OFF trial"),
    Kind("study-files", "information", "study files",
         r"no sidecar|partial trial|unknown key .* ignored|is the trial's complete|"
         r"outside the study folder|no longer in the study folder"),
)
