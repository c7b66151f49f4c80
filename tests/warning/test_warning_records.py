"""A warning record is plain data: it goes through JSON and pickle unchanged, and its text
starts with its scope as evtribo has always written it."""

from __future__ import annotations

import json
import math
import pickle

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from evtribo.warning.record import EFFECTS, Scope, WarningRecord, plain_value

NAMES = st.text(st.characters(min_codepoint=33, max_codepoint=0x2FFF), min_size=1, max_size=8)
VALUES = st.one_of(st.none(), st.booleans(), st.integers(-2**60, 2**60),
                   st.floats(allow_nan=False), st.text(max_size=20))
SCOPES = st.builds(Scope, st.none() | NAMES, st.none() | NAMES, st.none() | NAMES,
                   st.none() | st.floats(0, 1e6), st.none() | st.floats(-500, 500))
RECORDS = st.builds(WarningRecord, st.text(min_size=1, max_size=20),
                    st.sampled_from(list(EFFECTS)), SCOPES,
                    st.lists(st.tuples(st.text(min_size=1, max_size=10), VALUES),
                             max_size=5, unique_by=lambda kv: kv[0]).map(tuple),
                    st.text(max_size=60), st.text(max_size=30))


@given(RECORDS)
def test_a_record_goes_through_json_and_pickle_unchanged(record):
    text = json.dumps(record.as_json(), ensure_ascii=False)
    assert WarningRecord.from_json(json.loads(text)) == record
    assert pickle.loads(pickle.dumps(record)) == record
    assert {"kind", "effect", "text", "subject", "trial"} <= set(record.as_json())


def test_a_value_that_is_not_a_number_keeps_its_place_in_json():
    record = WarningRecord("mu-implausible", "number", Scope("P01"), (("mu", math.nan),), "t")
    back = WarningRecord.from_json(json.loads(json.dumps(record.as_json())))
    assert math.isnan(back.value("mu")) and back.scope == record.scope


def test_numpy_scalars_are_held_as_python_values_and_objects_refused():
    record = WarningRecord("few-windows", "interval", Scope(), (
        ("on", np.int64(3)), ("share", np.float32(0.5)), ("ok", np.bool_(True))), "t")
    assert [type(v) for _, v in record.values] == [int, float, bool]
    with pytest.raises(TypeError, match="list"):
        plain_value([1, 2])


@pytest.mark.parametrize(("obj", "match"), [
    ({"kind": "x", "effect": "unclassified", "text": "t"}, "effect"),
    ({"kind": "x", "effect": "number"}, "'text'"),
    ({"kind": "x", "effect": "number", "text": "t", "values": [1]}, "values"),
    ("a line of text", "an object")])
def test_a_record_that_is_not_one_is_refused(obj, match):
    with pytest.raises(ValueError, match=match):
        WarningRecord.from_json(obj)


@pytest.mark.parametrize(("scope", "level", "prefix"), [
    (Scope("P01", "run-02"), "trial", "P01/run-02: "),
    (Scope("P03", None, "square", 10000.0, 60.0), "cell", "P03 (square, 10000 Hz) at 60 V: "),
    (Scope("P03", None, "square", 10000.0), "drive", "P03 (square, 10000 Hz): "),
    (Scope("P03", None, "square"), "drive", "P03 (square): "),
    (Scope("P03"), "drive", "P03 (unknown waveform): "),
    (Scope("P03", None, None, 12.5, 142.5), "cell", "P03 (unknown waveform, 12.5 Hz) at 142.5 V: "),
    (Scope("P01"), "subject", "P01: "), (Scope("P01", "run-02"), "study", ""),
    (Scope(), "trial", ""), (Scope("P01"), "trial", "")])
def test_a_text_starts_with_its_scope_as_the_analysis_writes_it(scope, level, prefix):
    assert scope.prefix(level) == prefix


def test_a_scope_holds_the_cells_it_names_by_the_one_frequency_rule():
    scope = Scope("P01", None, "square", 10000.0000001)
    assert scope.holds("P01", "square", 1e4, 60.0)
    assert not scope.holds("P01", "square", 10.0, 60.0)
    assert not scope.holds("P02", "square", 1e4, 60.0)
    assert Scope("P01").holds("P01", "sine", 10.0, 140.0)
    assert Scope(amplitude_V=math.nan) == Scope()
