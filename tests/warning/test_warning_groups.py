"""The analysis's warnings, each kind once with the trials or cells it concerns, in the order
of what they do to the reported numbers: the records the analysis says, grouped as the
report and analyze's console show them."""

from __future__ import annotations

import numpy as np
import pandas as pd
from hypothesis import given
from hypothesis import strategies as st

from evtribo.analysis.tared_windows import _like_with_like
from evtribo.documents.summary import Summary
from evtribo.report.drawing import trials_to_check
from evtribo.warning.catalogue import kind
from evtribo.warning.collect import collecting
from evtribo.warning.record import EFFECTS, Scope
from evtribo.warning.render import console_lines, group, scope_text

SUBJECTS = ("P01", "P02", "P03")
TRIALS = [(s, f"run-{k:02d}") for s in SUBJECTS for k in range(1, 5)]
CELLS = [Scope(s, None, "square", 10000.0, a) for s in SUBJECTS for a in (60.0, 100.0, 140.0)]


def _zero(subject: str, trial: str, pct: float, fn: float):
    return kind("normal-zero").record(Scope(subject, trial), {"change_pct": pct, "normal_N": fn})


def _few(cell: Scope, n_on: int):
    return kind("few-windows").record(cell, {"on": n_on, "off": 4, "min_windows": 5})


def _offset(subject: str, trial: str, mn: float):
    return kind("offset").record(Scope(subject, trial), {
        "cell": "tangential", "offset_mN": mn, "share_pct": 18.0, "force_N": 0.254})


def _drift(subject: str, trial: str, mn: float):
    return kind("zero-drift").record(Scope(subject, trial), {
        "cell": "normal", "drift_mN": mn, "first_s": 0.8, "last_s": 12.0, "noise_mN": 0.3})


RECORDS = st.one_of(
    st.builds(lambda t, p: _zero(*t, p, 10 / p), st.sampled_from(TRIALS),
              st.floats(1.0, 5.0)),
    st.builds(_few, st.sampled_from(CELLS), st.integers(1, 4)),
    st.builds(lambda t, x: _offset(*t, x), st.sampled_from(TRIALS), st.floats(-50, 50)),
    st.builds(lambda s: kind("no-mu").record(Scope(s)), st.sampled_from(SUBJECTS)),
)


@given(st.lists(RECORDS, max_size=40))
def test_every_record_is_in_one_group_and_the_groups_come_by_effect(records):
    groups = group(records)
    said = [r for g in groups for r in g.records]
    assert sorted(r.text for r in said) == sorted({r.text for r in records})  # none lost
    order = [list(EFFECTS).index(g.effect) for g in groups]
    assert order == sorted(order)
    assert len({g.kind for g in groups}) == len(groups)  # each kind once


def test_a_study_without_a_tare_says_the_unknown_zero_once_for_all_its_trials():
    records = [_zero(s, t, 1.5 + k / 10, 0.3 + k / 50) for k, (s, t) in enumerate(TRIALS)]
    records += [_few(c, 4) for c in CELLS[:5]] + [_offset("P01", "run-01", -44.9)]
    groups = group(records)
    assert [g.kind for g in groups] == ["normal-zero", "few-windows", "offset"]
    zero, few, _ = groups
    assert zero.count == len(TRIALS) and zero.effect == "number"
    assert "by 1.5\u20132.6 %" in zero.text and "0.30\u20130.52 N" in zero.text
    assert scope_text(zero, TRIALS, CELLS) == f"all {len(TRIALS)} trials"
    assert scope_text(few, TRIALS, CELLS) == "5 of 9 cells: P01 (all); P02 at 60, 100 V"
    assert few.effect == "interval"
    assert all(c.holds("P01", "square", 1e4, c.amplitude_V) for c in few.touches({})[:3])
    console = console_lines(groups, TRIALS, CELLS)
    assert console[0] == EFFECTS["number"] + ":"
    assert sum(line.startswith("  [W") for line in console) == 3


def test_a_trial_s_warning_touches_the_cell_it_measured():
    [g] = group([_zero("P02", "run-03", 2.0, 0.4)])
    cell = Scope("P02", None, "square", 10000.0, 100.0)
    assert g.touches({("P02", "run-03"): cell}) == [cell]
    assert not g.study


def test_on_windows_left_out_for_their_direction_are_one_kind_of_their_own():
    records = []
    for (s, t), n in zip(TRIALS[:3], (2, 3, 4), strict=True):
        w = pd.DataFrame({"condition": ["off"] * 3 + ["on"] * n,
                          "direction": [1] * 3 + [-1] * n})
        with collecting(Scope(s, t), quiet=True) as said:
            _like_with_like(w, np.zeros(len(w)))
        records += said
    groups = group(records)
    assert [g.kind for g in groups] == ["directions-confounded"]
    assert groups[0].effect == "number" and groups[0].count == 3
    assert groups[0].trials == TRIALS[:3]


@given(zeros=st.lists(st.sampled_from(TRIALS), max_size=6),
       informed=st.lists(st.tuples(st.sampled_from(TRIALS), st.floats(-9, 9),
                                   st.booleans()), max_size=12),
       others=st.lists(st.builds(lambda s: kind("no-mu").record(Scope(s)),
                                 st.sampled_from(SUBJECTS)), max_size=4))
def test_the_trials_to_check_are_those_a_warning_not_only_for_information_names(
        zeros, informed, others):
    """A trial whose only warnings are for information (an offset removed, a drift followed)
    is not among those compare looks at by default; one with an unknown zero is, whatever
    else is said of it."""
    info = [(_offset if off else _drift)(*t, x) for t, x, off in informed]
    records = [*(_zero(*t, 2.0, 5.0) for t in zeros), *info, *others]
    assert trials_to_check(records, TRIALS) == {f"{s}/{t}" for s, t in zeros}


@given(st.lists(st.text(alphabet="abcdefgh P0123/:.()-,", min_size=1, max_size=40),
                max_size=8))
def test_an_older_summary_s_lines_are_never_unclassified(lines):
    """summary.json of an earlier evtribo: its lines lifted, each of a kind of the
    catalogue, with an effect the page has a heading for."""
    records = Summary({"warnings": lines, "subjects": list(SUBJECTS)}).warnings
    assert [r.text for r in records] == list(dict.fromkeys(lines))
    for g in group(records):
        assert g.effect in EFFECTS and g.kind in {r.kind for r in records}


def test_a_warning_about_a_drive_of_the_population_names_the_drive():
    """A record scoped to a drive and no subject (the population's) is said of that drive,
    not of "the study"."""
    sine = kind("population-one-amplitude").record(Scope(None, None, "sine", 10.0, None),
                                                   {"drive": "sine 10 Hz"})
    square = kind("population-checks-failed").record(
        Scope(None, None, "square", 10000.0, None),
        {"drive": "square 10000 Hz", "checks": "the exponent is hardly determined"})
    groups = group([sine, square])
    assert [scope_text(g, TRIALS, CELLS) for g in groups] == [
        "the population at sine 10 Hz", "the population at square 10 kHz"]
    assert not any(g.study for g in groups)
