"""summary.json's warnings as records (summary_version 2), an earlier evtribo's lines lifted,
a record damaged by hand refused naming the key."""

from __future__ import annotations

import json

import pytest
from hypothesis import given
from hypothesis import strategies as st

from evtribo.documents.summary import SUMMARY_VERSION, Summary, read_summary, write_summary
from evtribo.errors import ResultFolderError
from evtribo.warning.catalogue import kind
from evtribo.warning.record import Scope

RECORDS = st.builds(
    lambda s, t, pct, fn: kind("normal-zero").record(
        Scope(s, t), {"change_pct": pct, "normal_N": fn}, "evtribo.analysis.tared_windows"),
    st.sampled_from(["P01", "P02", "NA", "P 3"]), st.sampled_from(["run-01", "run-02"]),
    st.floats(0.1, 50), st.floats(0.05, 5))


@given(st.lists(RECORDS, max_size=5))
def test_records_written_are_the_records_read(tmp_path_factory, records):
    path = tmp_path_factory.mktemp("s") / "summary.json"
    write_summary(path, {"summary_version": SUMMARY_VERSION,
                         "warnings": [r.as_json() for r in records]})
    back = read_summary(path)
    assert back.version == 2 and back.warnings == records


def test_an_earlier_summary_s_lines_are_records_of_the_kinds_they_name():
    lines = ["P01/run-02: the normal cell's zero is unknown (no finger-lifted stretch and no "
             "[rig.calibration] normal_offset_N): an offset of 10 mN would change F_el by "
             "2.1 % (offset / F_n, at this trial's 0.48 N); record a tare stretch (evtribo "
             "acquire --tare-s) or give [rig.calibration] normal_offset_N",
             "P01/run-03: the logger's clock stepped ahead by 0.018 s at 3.000 s into the "
             "trial", "P02: something no version said"]
    summary = Summary({"subjects": ["P01", "P02"], "warnings": lines})
    assert summary.version == 1
    assert [(r.kind, r.scope.subject, r.scope.trial, r.text) for r in summary.warnings] == [
        ("normal-zero", "P01", "run-02", lines[0]), ("sequence", "P01", "run-03", lines[1]),
        ("earlier-unclassified", "P02", None, lines[2])]


@pytest.mark.parametrize("bad", [{"kind": "normal-zero", "text": "t"}, ["a", "b"],
                                 {"kind": "x", "effect": "maybe", "text": "t"}])
def test_a_warning_edited_out_of_shape_is_refused_naming_the_key(tmp_path, bad):
    path = tmp_path / "summary.json"
    path.write_text(json.dumps({"summary_version": 2, "warnings": [
        kind("no-window").record(Scope("P01", "run-01")).as_json(), bad]}))
    with pytest.raises(ResultFolderError, match="key 'warnings', item 2"):
        read_summary(path)
