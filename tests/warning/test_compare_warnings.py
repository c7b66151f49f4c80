"""Compare's warnings: each a record of a kind of the catalogue, kept in fit.json (version 2)
beside the notes' texts; an earlier fit.json's notes lifted into records of the same kinds;
the report and compare's console say them with the analysis's, each kind once."""

from __future__ import annotations

import json
import re
import string

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from markupsafe import escape

from evtribo.cli import main
from evtribo.documents.fit import FIT_VERSION, read_fit
from evtribo.population.convergence import singular
from evtribo.report.study_report import build_report
from evtribo.warning.catalogue import KINDS
from evtribo.warning.kinds_compare import COMPARE_IDS, COMPARE_KINDS, POPULATION_KINDS
from evtribo.warning.legacy_compare import NOTE_PATTERNS, lift_notes
from evtribo.warning.record import Scope

#: The comparison's kinds that were fit.json's notes before they were warnings.
_NOTES = [k for k in COMPARE_KINDS
          if k.id in {id for id, *_ in NOTE_PATTERNS}]
_WORD = st.from_regex(r"[A-Za-z][A-Za-z0-9_-]{0,8}", fullmatch=True)
_NUMBER = st.one_of(st.integers(0, 500), st.floats(0.01, 1e4))


#: Fields that take one of a few texts: those texts, as compare says them.
_TEXTS = {"singular": st.sampled_from([singular(np.zeros((2, 2)), 2),
                                       singular(np.ones((2, 2)), 2)]),
          "effects": st.sampled_from(["exponents", "levels"])}


def _values(kind):
    """A value for each field: a number where the wording formats one, else a word (a
    subject, a drive, a model's name, a reason)."""
    specs = {name: spec for _, name, spec, _ in string.Formatter().parse(kind.wording)
             if name}
    counts = {"needed", "amplitudes", "chosen", "trials", "auto_all", "replicates"}
    if "{subjects} subject" in kind.wording:
        counts.add("subjects")
    return st.fixed_dictionaries({f: _TEXTS[f] if f in _TEXTS else _NUMBER if specs.get(f)
                                  else st.integers(0, 500) if f in counts else _WORD
                                  for f in kind.fields})


@given(data=st.data())
def test_an_earlier_fit_json_s_note_is_lifted_into_its_kind(data):
    """A note as an earlier compare wrote it (its kind's wording, any values) is read back
    as a record of that kind, with its effect, its text as it was."""
    kind = data.draw(st.sampled_from(_NOTES))
    values = data.draw(_values(kind))
    scope = Scope(data.draw(_WORD)) if kind.prefixed else None  # said of a subject: P01:
    text = kind.record(scope, values).text
    [lifted] = lift_notes([text])
    assert (lifted.kind, lifted.effect, lifted.text) == (kind.id, kind.effect, text)


def test_every_note_fit_json_had_is_a_kind_and_an_unknown_one_is_information():
    assert {id for id, *_ in NOTE_PATTERNS} <= COMPARE_IDS
    assert {k.id for k in POPULATION_KINDS} <= COMPARE_IDS <= set(KINDS)
    [other] = lift_notes(["a note no pattern knows"])
    assert (other.kind, other.effect) == ("compare-note", "information")


def test_fit_json_keeps_the_comparison_s_warnings_as_records(compared_out, capsys):
    """compare's warnings in fit.json: records (kind, effect, text), the population's among
    them; its console says each kind once, as analyze's does; the report lists them with the
    analysis's under one numbering, and no note apart."""
    doc = json.loads((compared_out / "fit.json").read_text(encoding="utf-8"))
    assert doc["fit_version"] == FIT_VERSION == 2
    kinds = [w["kind"] for w in doc["warnings"]]
    assert kinds and all(KINDS[k].effect == w["effect"] for k, w in zip(
        kinds, doc["warnings"], strict=True))
    assert "population-too-few" in kinds  # two subjects: the population's warning too
    assert doc["notes"] == [w["text"] for w in doc["warnings"]]
    assert [w.kind for w in read_fit(compared_out / "fit.json").warnings] == kinds
    html = build_report(compared_out, compared_out.parent / "w.html").read_text("utf-8")
    assert "Notes on the fit" not in html and "Not estimated" not in html
    numbers = [int(n) for n in re.findall(r'<li id="w\d+" value="(\d+)">', html)]
    assert numbers == list(range(1, len(numbers) + 1))
    assert html.count("in fit.json)") == len(set(kinds))
    for w in doc["warnings"]:
        assert str(escape(KINDS[w["kind"]].title)) in html


def test_compare_s_console_says_each_kind_once(compared_out, capsys):
    assert main(["compare", str(compared_out), "--force", "--dpi", "30",
                 "--figure-format", "png"]) == 0
    err = capsys.readouterr().err
    doc = json.loads((compared_out / "fit.json").read_text(encoding="utf-8"))
    assert "note: " not in err
    for kind in {w["kind"] for w in doc["warnings"]}:
        assert err.count(f"] {KINDS[kind].title}: ") == 1, (kind, err)
    assert f"each as the comparison said it in {compared_out / 'fit.json'}" in err


def test_an_earlier_fit_json_s_notes_are_read_as_records(compared_out, tmp_path):
    """fit.json of version 1 (no warnings, no version): its notes and its population's
    lifted, each of its kind."""
    doc = json.loads((compared_out / "fit.json").read_text(encoding="utf-8"))
    del doc["warnings"], doc["fit_version"]
    (tmp_path / "fit.json").write_text(json.dumps(doc), encoding="utf-8")
    old = read_fit(tmp_path / "fit.json")
    assert old.version == 1
    lifted = [w.kind for w in old.warnings]
    assert "compare-note" not in lifted
    assert set(lifted) <= {w["kind"] for w in json.loads(
        (compared_out / "fit.json").read_text(encoding="utf-8"))["warnings"]}
