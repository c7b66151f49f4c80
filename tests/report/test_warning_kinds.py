"""The analysis's warnings, each kind once with the trials or cells it concerns, in the order
of what they do to the reported numbers."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from evtribo.report.drawing import trials_to_check
from evtribo.report.lead.warning_kinds import (
    EFFECTS,
    Cell,
    console_lines,
    group_warnings,
    scope_text,
)

SUBJECTS = ("P01", "P02", "P03")
TRIALS = [(s, f"run-{k:02d}") for s in SUBJECTS for k in range(1, 5)]
CELLS = [Cell(s, "square", 10000.0, a) for s in SUBJECTS for a in (60.0, 100.0, 140.0)]


def _zero(subject: str, trial: str, pct: float, fn: float) -> str:
    return (f"{subject}/{trial}: the normal cell's zero is unknown (no finger-lifted stretch "
            f"and no [rig.calibration] normal_offset_N): an offset of 10 mN would change F_el "
            f"by {pct:.1f} % (offset / F_n, at this trial's {fn:.2f} N); record a tare stretch "
            "(evtribo acquire --tare-s) or give [rig.calibration] normal_offset_N")


def _few(cell: Cell, n_on: int) -> str:
    return (f"{cell.subject} (square, 10000 Hz) at {cell.amplitude_V:g} V: only {n_on} ON and "
            "4 OFF windows (fewer than 5); the interval is calibrated for small counts but "
            "rests on few windows")


def _offset(subject: str, trial: str, mn: float) -> str:
    return (f"{subject}/{trial}: the tangential cell's zero offset was {mn:+.1f} mN, 18 % of "
            "the tangential force measured (0.254 N); removed, but tare the load cells "
            "before recording")


LINES = st.one_of(
    st.builds(lambda t, p: _zero(*t, p, 10 / p), st.sampled_from(TRIALS),
              st.floats(1.0, 5.0)),
    st.builds(_few, st.sampled_from(CELLS), st.integers(1, 4)),
    st.builds(lambda t, x: _offset(*t, x), st.sampled_from(TRIALS), st.floats(-50, 50)),
    st.builds(lambda s: f"{s}: no OFF windows to estimate mu from; no electrostatic force",
              st.sampled_from(SUBJECTS)),
    st.text(alphabet="abcdefgh 0123456789", min_size=1, max_size=30),
)


@given(st.lists(LINES, max_size=40))
def test_every_line_is_in_one_group_and_the_groups_come_by_effect(lines):
    groups = group_warnings(lines, SUBJECTS, TRIALS)
    said = [line for g in groups for line in g.lines]
    assert sorted(said) == sorted(set(lines))  # each line once, none lost
    order = [list(EFFECTS).index(g.effect) for g in groups]
    assert order == sorted(order)
    assert len({g.key for g in groups}) == len(groups)  # each kind once


def test_a_study_without_a_tare_says_the_unknown_zero_once_for_all_its_trials():
    lines = [_zero(s, t, 1.5 + k / 10, 0.3 + k / 50) for k, (s, t) in enumerate(TRIALS)]
    lines += [_few(c, 4) for c in CELLS[:5]] + [_offset("P01", "run-01", -44.9)]
    groups = group_warnings(lines, SUBJECTS, TRIALS)
    assert [g.key for g in groups] == ["normal-zero", "few-windows", "offset"]
    zero, few, _ = groups
    assert zero.count == len(TRIALS) and zero.effect == "number"
    assert "by 1.5\u20132.6 %" in zero.text and "0.30\u20130.52 N" in zero.text
    assert scope_text(zero, TRIALS, CELLS) == f"all {len(TRIALS)} trials"
    assert scope_text(few, TRIALS, CELLS) == "5 of 9 cells: P01 (all); P02 at 60, 100 V"
    assert few.effect == "interval"
    cells = few.touches({})
    assert all(c.holds("P01", "square", 1e4, a) for c in cells[:3] for a in [c.amplitude_V])
    console = console_lines(groups, TRIALS, CELLS)
    assert console[0] == EFFECTS["number"] + ":"
    assert sum(line.startswith("  [W") for line in console) == 3


def test_a_line_of_an_unknown_kind_is_said_as_it_is_and_not_merged_with_others():
    lines = ["P01/run-01: something new happened at 3 s", "P02/run-01: something new "
             "happened at 5 s", "P01: another thing"]
    groups = group_warnings(lines, SUBJECTS, TRIALS)
    assert {g.effect for g in groups} == {"unclassified"}
    new = next(g for g in groups if g.count == 2)
    assert new.text == "something new happened at 3\u20135 s"
    assert new.trials == [("P01", "run-01"), ("P02", "run-01")]


def test_a_trial_s_warning_touches_the_cell_it_measured():
    line = "P02/run-03: the normal cell's zero is unknown (no finger-lifted stretch)"
    [g] = group_warnings([line], SUBJECTS, TRIALS)
    cell = Cell("P02", "square", 10000.0, 100.0)
    assert g.touches({("P02", "run-03"): cell}) == [cell]
    assert not g.study


def test_on_windows_left_out_for_their_direction_are_one_kind_of_their_own():
    import numpy as np
    import pandas as pd

    from evtribo.analysis.tared_windows import _like_with_like

    lines = []
    for (s, t), n in zip(TRIALS[:3], (2, 3, 4), strict=True):
        said = []
        w = pd.DataFrame({"condition": ["off"] * 3 + ["on"] * n,
                          "direction": [1] * 3 + [-1] * n})
        _like_with_like(w, np.zeros(len(w)), said.append)
        lines += [f"{s}/{t}: {x}" for x in said]
    groups = group_warnings(lines, SUBJECTS, TRIALS)
    assert [g.key for g in groups] == ["directions-confounded"]
    assert groups[0].effect == "number" and groups[0].count == 3


def _drift(subject: str, trial: str, mn: float) -> str:
    return (f"{subject}/{trial}: the normal cell's zero drifted by {mn:+.1f} mN between the "
            "finger-lifted stretches at 0.8 s and 12.0 s (noise 0.3 mN); interpolated between "
            "them")


@given(zeros=st.lists(st.sampled_from(TRIALS), max_size=6),
       informed=st.lists(st.tuples(st.sampled_from(TRIALS), st.floats(-9, 9),
                                   st.booleans()), max_size=12),
       others=st.lists(LINES, max_size=10))
def test_the_trials_to_check_are_those_a_warning_not_only_for_information_names(
        zeros, informed, others):
    """A trial whose only warnings are for information (an offset removed, a drift followed)
    is not among those compare looks at by default; one with an unknown zero is, whatever
    else is said of it."""
    info = [(_offset if off else _drift)(*t, x) for t, x, off in informed]
    lines = [*(_zero(*t, 2.0, 5.0) for t in zeros), *info,
             *(x for x in others if not x.startswith(tuple(f"{s}/" for s in SUBJECTS)))]
    assert trials_to_check(lines, TRIALS) == {f"{s}/{t}" for s, t in zeros}
