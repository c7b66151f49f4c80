"""population.csv by key: a lookup gives the row of its quantity, drive, amplitude and
analysis whatever the rows' order, and refuses a table where two rows share a key."""

from __future__ import annotations

import io
import math

import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st

from evtribo.documents.population_table import (
    EXPONENT,
    FORCE,
    META,
    PRIMARY,
    Checks,
    Drive,
    PopulationTable,
    without,
)
from evtribo.errors import ResultFolderError

QUANTITIES = (FORCE, EXPONENT, "friction_increase_pct", "mu")
DRIVES = (Drive("square", 10000.0), Drive("square", 250.0), Drive("sine", 10.0), None)
AMPLITUDES = (None, 60.0, 80.0, 142.5)
ANALYSES = (PRIMARY, META, without("S03"))
KEYS = st.tuples(st.sampled_from(QUANTITIES), st.sampled_from(DRIVES),
                 st.sampled_from(AMPLITUDES), st.sampled_from(ANALYSES))


def _frame(keys, order) -> pd.DataFrame:
    rows = [{"quantity": q, "waveform": None if d is None else d.waveform,
             "frequency_Hz": math.nan if d is None else d.frequency_Hz * (1 + 1e-13),
             "amplitude_V": math.nan if a is None else a, "estimate": float(k),
             "analysis": an, "n_subjects": 3, "method": "m", "checks": ""}
            for k, (q, d, a, an) in enumerate(keys)]
    frame = pd.DataFrame([rows[i] for i in order], columns=[
        "quantity", "waveform", "frequency_Hz", "amplitude_V", "estimate", "analysis",
        "n_subjects", "method", "checks"])
    return pd.read_csv(io.StringIO(frame.to_csv(index=False)))  # as a file reads


@given(st.lists(KEYS, unique=True, max_size=30).flatmap(
    lambda keys: st.tuples(st.just(keys), st.permutations(range(len(keys))))))
def test_a_lookup_gives_the_row_of_its_keys_whatever_the_rows_order(drawn):
    keys, order = drawn
    table = PopulationTable(_frame(keys, order))
    for k, (q, d, a, an) in enumerate(keys):
        row = table.row(q, d, a, an)
        assert row is not None and row.estimate == k
        assert (row.quantity, row.drive, row.amplitude_V, row.analysis) == (q, d, a, an)
    assert table.drives() == sorted({d for _, d, _, _ in keys if d is not None})
    assert table.row("h_L_m") is None
    for q, d, _, an in keys:
        amps = [r.amplitude_V for r in table.rows(q, d, an)]
        assert amps == sorted(amps, key=lambda a: -math.inf if a is None else a)
        assert len(amps) == sum(1 for k in keys if (k[0], k[1], k[3]) == (q, d, an))


@given(st.lists(KEYS, unique=True, min_size=1, max_size=10), st.data())
def test_two_rows_of_one_key_are_refused(keys, data):
    twice = data.draw(st.sampled_from(keys))
    table = PopulationTable(_frame([*keys, twice], range(len(keys) + 1)),
                            path="population.csv")
    with pytest.raises(ResultFolderError, match=r"^population\.csv: 2 rows of "):
        table.row(*twice)


def test_the_demo_s_single_amplitude_drive_has_no_primary_force():
    text = ("quantity,waveform,frequency_Hz,amplitude_V,estimate,analysis,checks\n"
            "electrostatic_force_N,square,10000.0,140.0,0.3444,primary,the exponent is hardly "
            "determined by these data: read it as unknown\n"
            "exponent,square,10000.0,,2.06,primary,the exponent is hardly determined\n"
            "electrostatic_force_N,square,10000.0,140.0,0.3420,meta-analysis,\n"
            "electrostatic_force_N,sine,10.0,140.0,0.1736,meta-analysis,\n"
            "mu,,,,0.52,primary,\n")
    table = PopulationTable(pd.read_csv(io.StringIO(text)))
    square, sine = Drive.of("square", 1e4), Drive.of("sine", 10)
    assert table.drives() == [sine, square]
    assert table.row(FORCE, square, 140.0).estimate == 0.3444
    assert table.row(FORCE, square, 140, META).estimate == 0.3420
    assert table.row(FORCE, sine, 140.0) is None
    assert table.row("mu").estimate == 0.52
    checks = table.checks(square)
    assert not checks.ok and not checks.holds(FORCE) and checks.holds("mu")
    assert not table.checks(sine).holds(FORCE)
    given_checks = {square: Checks(True, True, True, False, "n undetermined")}
    table = PopulationTable(pd.read_csv(io.StringIO(text)), given_checks)
    assert table.checks(square).holds(FORCE) and not table.checks(square).holds(EXPONENT)


def test_a_drive_is_its_waveform_and_frequency_by_the_one_rule():
    assert Drive.of("square", 10000.0000001) == Drive("square", 1e4)
    assert Drive.of("square", float("nan")) == Drive("square") != Drive.of(None, None)
    assert Drive.of("square", 1e4).label() == "square 10 kHz"
    assert Drive.of(float("nan"), 250).label() == "unknown waveform 250 Hz"
    for d in (Drive("square", 1e4), Drive("sine", 12.5), Drive("square"), Drive(None, 5.0)):
        assert Drive.from_condition(d.condition) == d
    assert Drive("square", 1e4).condition == "square 10000 Hz"


@pytest.mark.parametrize(("said", "ok"), [("ok (4 optimisers agree)", True),
                                          ("the exponent is hardly determined", False),
                                          ("", False), (None, False)])
def test_checks_of_older_text_pass_only_when_they_say_ok(said, ok):
    checks = Checks.of_text(said)
    assert checks.ok is ok and checks.holds(FORCE) is ok and checks.holds(EXPONENT) is ok
    assert Checks.from_json(checks.as_json()) == checks
    assert Checks.from_json(said) == checks
