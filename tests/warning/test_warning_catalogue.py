"""The catalogue: every kind's wording renders with its fields, an id is registered once, an
unknown id is refused, and a lab's plug-in adds kinds through an entry point."""

from __future__ import annotations

import logging

import pytest
from _warning_examples import SUBJECTS, TRIALS, example, example_values

from _plugins import install
from evtribo.util import plugins
from evtribo.warning import catalogue
from evtribo.warning.catalogue import AREAS, KINDS, Kind, kind, register
from evtribo.warning.collect import collecting, emitter
from evtribo.warning.kinds_compare import COMPARE_KINDS
from evtribo.warning.legacy import lift
from evtribo.warning.record import Scope

BUILTIN = [k for area in AREAS.values() for k in area]


@pytest.fixture
def fresh(monkeypatch):
    """The catalogue as it is, put back after the test (with the plug-ins not yet read)."""
    monkeypatch.setattr(catalogue, "_KINDS", dict(catalogue._KINDS))
    monkeypatch.setattr(catalogue, "_read", {"plugins": False})
    plugins.forget()
    yield
    plugins.forget()


@pytest.mark.parametrize("k", BUILTIN, ids=lambda k: k.id)
def test_every_kind_says_its_wording_with_its_fields(k):
    values = example_values(k)
    record = example(k)
    assert record.text.endswith(k.text(values))
    assert not any("{" + name in record.text for name in k.fields)
    assert record.kind == k.id and record.effect == k.effect
    assert dict(record.values) == values
    for name in k.fields:  # each field is needed
        with pytest.raises(KeyError, match=name):
            k.text({f: v for f, v in values.items() if f != name})
    assert k.todo.endswith(".") and k.todo[0].isupper() and k.title == k.title.strip()


def test_the_ids_are_unique_and_each_earlier_id_stands_for_kinds_there_are():
    ids = [k.id for k in BUILTIN]
    assert len(ids) == len(set(ids)) == len(KINDS)
    for k in BUILTIN:
        assert set(k.stands_for) <= set(ids), k.id
    grouped = [s for k in BUILTIN for s in k.stands_for if k.id != "earlier-unclassified"]
    assert len(grouped) == len(set(grouped))  # each stood for by one id at most


def test_a_kind_split_from_an_earlier_one_does_to_the_numbers_what_it_did():
    for k in BUILTIN:
        if k.id != "earlier-unclassified":
            assert {kind(s).effect for s in k.stands_for} <= {k.effect}, k.id


@pytest.mark.parametrize("k", [k for k in BUILTIN if not k.earlier and k not in COMPARE_KINDS],
                         ids=lambda k: k.id)
def test_what_an_earlier_version_said_is_read_back_as_the_kind_or_the_one_it_was(k):
    """The analysis's sentences, kept as text in summary.json by earlier versions, are lifted
    to this kind, or to the earlier kind that stands for it."""
    lifted = lift(example(k).text, SUBJECTS, TRIALS)
    assert lifted.kind == k.id or k.id in kind(lifted.kind).stands_for, lifted.kind


def test_an_id_is_registered_once_and_an_unknown_id_is_refused(fresh):
    again = Kind("offset", "information", "t", "w", "Do it.", "trial")
    with pytest.raises(ValueError, match="'offset' is registered already"):
        register(again)
    twice = Kind("mylab-twice", "information", "t", "w", "Do it.", "trial")
    with pytest.raises(ValueError, match="mylab-twice"):
        register(twice, twice)
    assert "mylab-twice" not in KINDS
    with pytest.raises(KeyError, match="no warning kind 'mylab-nothing'"):
        kind("mylab-nothing")
    with pytest.raises(TypeError):
        register("offset")  # type: ignore[arg-type]


@pytest.mark.parametrize(("change", "match"), [
    ({"id": "Bad Id"}, "lower-case"), ({"effect": "maybe"}, "effect"),
    ({"scope": "room"}, "scope"), ({"todo": " "}, "todo"), ({"wording": "{a.b}"}, "plain name"),
    ({"wording": "{0} left"}, "plain name"), ({"wording": "{a"}, "mylab-x")])
def test_a_kind_that_is_not_one_is_refused(change, match):
    fields = {"id": "mylab-x", "effect": "information", "title": "t", "wording": "w {a}",
              "todo": "Do it.", "scope": "trial", **change}
    with pytest.raises(ValueError, match=match):
        Kind(**fields)


PLUGIN = '''
from evtribo.warning.catalogue import Kind

KINDS = [Kind("mylab-humidity", "interval", "the room's humidity out of range",
              "the room's humidity was {rh_pct:.0f} %", "Record at 40-60 % humidity.",
              "trial")]
CLASH = Kind("offset", "information", "t", "w", "Do it.", "trial")
'''


def test_a_plug_in_s_kind_is_found_through_its_entry_point(fresh, tmp_path, monkeypatch,
                                                           caplog):
    install(tmp_path, monkeypatch, "mylab_kinds", PLUGIN, entry_points={
        catalogue.ENTRY_POINTS: {"mylab": "mylab_kinds:KINDS", "clash": "mylab_kinds:CLASH",
                                 "none": "json:dumps"}})
    assert kind("offset").title == "zero offsets removed"  # a builtin: no plug-in read
    assert not catalogue._read["plugins"]
    emit = emitter("mylab.analysis")
    with caplog.at_level(logging.WARNING), collecting(Scope("P01", "run-02")) as got:
        emit("mylab-humidity", rh_pct=71.6)
    assert [r.text for r in got] == ["P01/run-02: the room's humidity was 72 %"]
    assert got[0].effect == "interval" and list(KINDS)[-1] == "mylab-humidity"
    said = [r.getMessage() for r in caplog.records]
    assert "P01/run-02: the room's humidity was 72 %" in said
    assert any("clash" in m and "'offset' is registered already" in m for m in said)
    assert any("none" in m and "not warning kinds" in m for m in said)
    assert kind("offset").title == "zero offsets removed"  # the builtin stays
