"""summary.json's warnings as earlier versions wrote them (lines of text) are lifted into
records of the kind, and with the scope, those versions told them by; a line of no known
kind is of kind earlier-unclassified, which may change a number."""

from __future__ import annotations

from _warning_examples import example
from hypothesis import given
from hypothesis import strategies as st

from evtribo.report.lead import warning_kinds
from evtribo.report.lead.warning_kinds import Cell, group_warnings
from evtribo.warning.catalogue import AREAS, kind
from evtribo.warning.legacy import PATTERNS, lift, lift_all
from evtribo.warning.record import Scope
from evtribo.warning.render import group

SUBJECTS = ("P01", "P02", "P03")
TRIALS = [(s, f"run-{k:02d}") for s in SUBJECTS for k in range(1, 5)]
#: What the analysis says, as the tests of the report's grouping write it, and each kind's
#: sentence said where it is said.
SAID = [
    "P01/run-01: the normal cell's zero is unknown (no finger-lifted stretch and no "
    "[rig.calibration] normal_offset_N): an offset of 10 mN would change F_el by 1.5 % "
    "(offset / F_n, at this trial's 0.30 N); record a tare stretch (evtribo acquire --tare-s) "
    "or give [rig.calibration] normal_offset_N",
    "P02 (square, 10000 Hz) at 60 V: only 3 ON and 4 OFF windows (fewer than 5); the interval "
    "is calibrated for small counts but rests on few windows",
    "P01/run-03: the tangential cell's zero offset was -44.9 mN, 18 % of the tangential force "
    "measured (0.254 N); removed, but tare the load cells before recording",
    "P03: no OFF windows to estimate mu from; no electrostatic force",
    "P01/run-01: something new happened at 3 s", "P01: another thing",
    "P02/run-03: the normal cell's zero is unknown (no finger-lifted stretch)",
    "P01 (unknown waveform): trial run-02 alternates but has no OFF window; using the "
    "subject's OFF windows",
    "/data/study/P01/run-02.log: the recording was interrupted (Ctrl-C or SIGTERM); analysing "
    "what was recorded",
    "P01/run-02: the load cells fell silent for 3 s", "P01/run-02: a gap of 4 s in the frames",
    *(example(k).text for area in AREAS.values() for k in area if not k.earlier),
]
LINES = st.one_of(st.sampled_from(SAID),
                  st.builds(lambda scope, rest: scope + rest,
                            st.sampled_from(["", "P01/run-02: ", "P09/run-01: ", "P02: ",
                                             "P03 (sine, 10 Hz) at 140 V: ", "x/P01/run-01.asc: "]),
                            st.text(alphabet="abc defgh:0123456789.(),", max_size=40)))


def _cell(scope: Scope) -> Cell:
    return Cell(str(scope.subject), scope.waveform, scope.frequency_Hz, scope.amplitude_V)


@given(st.lists(LINES, max_size=6))
def test_every_line_is_lifted_to_the_kind_and_scope_earlier_versions_gave_it(lines):
    known = {k.key for k in warning_kinds.KINDS}
    for line in lines:
        [g] = group_warnings([line], SUBJECTS, TRIALS)
        record = lift(line, SUBJECTS, TRIALS)
        if record.kind not in known | {"earlier-unclassified"}:
            continue  # a kind newer than this tree's grouping
        assert record.kind == (g.key if not g.key.startswith("other:") else
                               "earlier-unclassified")
        assert record.effect == (g.effect if g.effect != "unclassified" else "number")
        assert record.text == line and kind(record.kind).effect == record.effect
        [said] = group([record])  # where the record's group says it was said
        assert (said.trials, [_cell(c) for c in said.cells], said.subjects, said.study) == (
            g.trials, g.cells, g.subjects, g.study)


def test_the_patterns_are_a_frozen_copy_of_the_report_s():
    """Each of the report's patterns, in its order (the copy may hold those of versions
    since)."""
    report = [(k.key, k.effect, k.pattern) for k in warning_kinds.KINDS]
    assert [p for p in PATTERNS if p in report] == report


def test_lifting_keeps_each_line_once_in_its_order():
    lines = ["P02: x", "P01: y", "P02: x"]
    assert [r.text for r in lift_all(lines, SUBJECTS)] == ["P02: x", "P01: y"]
    assert lift("P09: x", SUBJECTS).scope == Scope()  # not a subject of the study
    assert lift("P09: x").scope == Scope("P09")  # none given: any name is one
