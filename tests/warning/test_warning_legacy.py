"""summary.json's warnings as earlier versions wrote them (lines of text) are lifted into
records of the kind, and with the scope, those versions told them by; a line of no known
kind is of kind earlier-unclassified, which may change a number."""

from __future__ import annotations

from _warning_examples import example
from hypothesis import given
from hypothesis import strategies as st

from evtribo.warning.catalogue import AREAS, KINDS, kind
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


@given(st.lists(LINES, max_size=6))
def test_every_line_is_lifted_to_a_kind_of_the_catalogue_with_its_text(lines):
    for line in lines:
        record = lift(line, SUBJECTS, TRIALS)
        assert record.text == line and record.kind in KINDS
        assert kind(record.kind).effect == record.effect
        [said] = group([record])  # where the record's group says it was said
        s = record.scope
        assert said.trials == ([(s.subject, s.trial)] if s.trial is not None else [])
        if s.subject is None:
            assert said.study and not (said.trials or said.cells or said.subjects)


def test_the_patterns_say_each_kind_earlier_versions_knew_by_the_catalogue_s_effect():
    for id, effect, _ in PATTERNS:
        assert kind(id).effect == effect, id


def test_lifting_keeps_each_line_once_in_its_order():
    lines = ["P02: x", "P01: y", "P02: x"]
    assert [r.text for r in lift_all(lines, SUBJECTS)] == ["P02: x", "P01: y"]
    assert lift("P09: x", SUBJECTS).scope == Scope()  # not a subject of the study
    assert lift("P09: x").scope == Scope("P09")  # none given: any name is one
