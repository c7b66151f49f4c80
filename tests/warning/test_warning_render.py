"""Warnings said once per kind, each field that differs as its range, with the trials or
cells each kind concerns, in the order of what they do to the reported numbers."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from evtribo.warning.catalogue import kind
from evtribo.warning.legacy import lift_all
from evtribo.warning.record import EFFECTS, Scope
from evtribo.warning.render import console_lines, group, scope_text

SUBJECTS = ("P01", "P02", "P03")
TRIALS = [(s, f"run-{k:02d}") for s in SUBJECTS for k in range(1, 5)]
CELLS = [Scope(s, None, "square", 10000.0, a) for s in SUBJECTS for a in (60.0, 100.0, 140.0)]


def _zero(trial, pct, fn):
    return kind("normal-zero").record(Scope(*trial), {"change_pct": pct, "normal_N": fn})


def _few(cell, n_on):
    return kind("few-windows").record(cell, {"on": n_on, "off": 4, "min_windows": 5})


def _offset(trial, cell, mn):
    return kind("offset").record(Scope(*trial), {"cell": cell, "offset_mN": mn,
                                                 "share_pct": 18, "force_N": 0.254})


RECORDS = st.one_of(
    st.builds(_zero, st.sampled_from(TRIALS), st.floats(1.0, 5.0), st.floats(0.2, 5.0)),
    st.builds(_few, st.sampled_from(CELLS), st.integers(1, 4)),
    st.builds(_offset, st.sampled_from(TRIALS), st.sampled_from(["normal", "tangential"]),
              st.floats(-50, 50)),
    st.builds(lambda s: kind("no-mu").record(Scope(s)), st.sampled_from(SUBJECTS)))


@given(st.lists(RECORDS, max_size=40))
def test_every_record_is_in_one_group_and_the_groups_come_by_effect(records):
    groups = group(records)
    said = [r for g in groups for r in g.records]
    assert sorted(r.text for r in said) == sorted({r.text for r in records})
    order = [list(EFFECTS).index(g.effect) for g in groups]
    assert order == sorted(order)
    assert len({g.kind for g in groups}) == len(groups)
    for g in groups:
        assert "{" not in g.text and g.text  # the wording filled, each field once


def test_a_study_without_a_tare_says_the_unknown_zero_once_for_all_its_trials():
    records = [_zero(t, 1.5 + k / 10, 0.3 + k / 50) for k, t in enumerate(TRIALS)]
    records += [_few(c, 4) for c in CELLS[:5]] + [_offset(("P01", "run-01"), "normal", -44.9)]
    groups = group(records)
    assert [g.kind for g in groups] == ["normal-zero", "few-windows", "offset"]
    zero, few, _ = groups
    assert zero.count == len(TRIALS) and zero.effect == "number"
    assert "by 1.5\u20132.6 %" in zero.text and "0.30\u20130.52 N" in zero.text
    assert scope_text(zero, TRIALS, CELLS) == f"all {len(TRIALS)} trials"
    assert scope_text(few, TRIALS, CELLS) == "5 of 9 cells: P01 (all); P02 at 60, 100 V"
    assert few.text == ("only 4 ON and 4 OFF windows (fewer than 5); the interval is "
                        "calibrated for small counts but rests on few windows")
    assert all(c.holds("P01", "square", 1e4, c.amplitude_V) for c in few.touches({})[:3])
    console = console_lines(groups, TRIALS, CELLS)
    assert console[0] == EFFECTS["number"] + ":"
    assert console[1] == f"  [W1] the normal cell's zero is unknown: all {len(TRIALS)} trials"
    assert sum(line.startswith("  [W") for line in console) == 3


def test_records_that_differ_in_a_text_are_wordings_of_their_own():
    records = [_offset(("P01", "run-01"), "normal", -4.0),
               _offset(("P01", "run-02"), "normal", -6.0),
               _offset(("P02", "run-01"), "tangential", 9.0)]
    [g] = group(records)
    assert g.text == ("the normal cell's zero offset was -6.0\u2013-4.0 mN, 18 % of the normal "
                      "force measured (0.254 N); removed, but tare the load cells before "
                      "recording | the tangential cell's zero offset was +9.0 mN, 18 % of the "
                      "tangential force measured (0.254 N); removed, but tare the load cells "
                      "before recording")
    assert g.trials == [("P01", "run-01"), ("P01", "run-02"), ("P02", "run-01")]


def test_a_drive_s_warning_names_its_drive_and_a_trial_s_touches_the_cell_it_measured():
    [g] = group([kind("other-off").record(Scope("P02", None, None), {"trial": "run-03"})])
    assert g.text == ("trial run-03 alternates but has no OFF window; using the subject's OFF "
                      "windows")
    assert scope_text(g, TRIALS, CELLS) == "P02 (unknown waveform)"
    [g] = group([_zero(("P02", "run-03"), 2.0, 0.5)])
    cell = Scope("P02", None, "square", 10000.0, 100.0)
    assert g.touches({("P02", "run-03"): cell}) == [cell] and not g.study


def test_a_kind_this_catalogue_lacks_is_said_with_its_id_and_its_texts():
    from evtribo.warning.record import WarningRecord

    records = [WarningRecord("mylab-humidity", "interval", Scope("P01", "run-01"),
                             (("rh_pct", 71),), "P01/run-01: humidity 71 %")]
    [g] = group(records)
    assert (g.title, g.effect, g.text, g.trials) == ("mylab-humidity", "interval",
                                                     "humidity 71 %", [("P01", "run-01")])


def test_earlier_results_lines_are_grouped_as_earlier_versions_grouped_them():
    lines = [f"P01/run-0{k}: the normal cell's zero is unknown (no finger-lifted stretch and "
             f"no [rig.calibration] normal_offset_N): an offset of 10 mN would change F_el by "
             f"{k}.5 % (offset / F_n, at this trial's 0.4{k} N); record a tare stretch"
             for k in (1, 2, 3)] + ["P01/run-01: something new happened at 3 s",
                                   "P02/run-01: something new happened at 5 s"]
    groups = group(lift_all(lines, SUBJECTS, TRIALS))
    assert [(g.kind, g.effect) for g in groups] == [("normal-zero", "number"),
                                                  ("earlier-unclassified", "number")]
    assert "by 1.5\u20133.5 % (offset / F_n, at this trial's 0.41\u20130.43 N)" in groups[0].text
    assert groups[1].text == "something new happened at 3\u20135 s"
    assert groups[1].trials == [("P01", "run-01"), ("P02", "run-01")]
