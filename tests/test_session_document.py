"""session.json (spec §7): what is written is read back; bad files are named with the key."""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import _studies
from evtribo.documents.names import NAME_PATTERN
from evtribo.documents.session import (
    SESSION_FILE,
    VERSION,
    Session,
    SessionTrial,
    read_session,
    write_session,
)
from evtribo.documents.sidecar import CONDITIONS, WAVEFORMS
from evtribo.errors import StudyError
from evtribo.study import discover_trials

names = st.from_regex(NAME_PATTERN, fullmatch=True).filter(lambda s: len(s) <= 20)
numbers = st.none() | st.floats(0, 1e5, allow_nan=False)
planned = st.builds(SessionTrial, trial=names, waveform=st.none() | st.sampled_from(WAVEFORMS),
                    frequency_Hz=numbers, amplitude_V=numbers,
                    condition=st.none() | st.sampled_from(CONDITIONS))
orders = st.lists(planned, max_size=6, unique_by=lambda t: t.trial).map(tuple)
protocols = st.fixed_dictionaries({"session": st.fixed_dictionaries(
    {"trial_s": st.floats(1, 60), "randomize": st.booleans()})})


@st.composite
def sessions(draw):
    order = draw(orders)
    done = draw(st.lists(st.sampled_from([t.trial for t in order]), unique=True)
                if order else st.just([]))
    return Session(subject=draw(names), seed=draw(st.integers(0, 2**32)),
                   protocol=draw(protocols), order=order, done=tuple(done))


@settings(max_examples=50, deadline=None)
@given(session=sessions())
def test_what_is_written_is_read_back(tmp_path_factory, session):
    path = tmp_path_factory.mktemp("s") / SESSION_FILE
    write_session(path, session)
    assert read_session(path) == session
    assert json.loads(path.read_text())["version"] == VERSION


def test_the_next_trial_is_the_first_not_done():
    session = Session(subject="P01", seed=1, order=(SessionTrial("run-01"),
                                                    SessionTrial("run-02")))
    assert session.next_trial() == SessionTrial("run-01")
    session = session.with_done("run-01")
    assert session.next_trial() == SessionTrial("run-02")
    assert session.with_done("run-02").next_trial() is None
    with pytest.raises(ValueError, match="run-03"):
        session.with_done("run-03")


GOOD = {"version": 1, "subject": "P01", "seed": 1, "protocol": {},
        "order": [{"trial": "run-01", "amplitude_V": 60}], "done": []}


@pytest.mark.parametrize("change,key", [
    ({"version": 2}, "version"),
    ({"seed": "1"}, "seed"),
    ({"seed": True}, "seed"),
    ({"subject": "../P01"}, "subject"),
    ({"order": [{"trial": "run 01"}]}, "order[0].trial"),
    ({"order": [{"trial": "run-01", "waveform": "saw"}]}, "order[0].waveform"),
    ({"order": [{"trial": "run-01", "amplitude_V": -1}]}, "order[0].amplitude_V"),
    ({"order": [{"trial": "a"}, {"trial": "a"}]}, "order"),
    ({"done": ["run-02"]}, "done"),
])
def test_a_bad_session_file_is_named_with_its_key(tmp_path, change, key):
    path = tmp_path / SESSION_FILE
    path.write_text(json.dumps({**GOOD, **change}))
    with pytest.raises(StudyError) as err:
        read_session(path)
    assert err.value.key == key and str(path) in str(err.value)


def test_invalid_json_names_the_line(tmp_path):
    path = tmp_path / SESSION_FILE
    path.write_text('{"version": 1,\n "subject": }')
    with pytest.raises(StudyError) as err:
        read_session(path)
    assert err.value.line == 2


def test_a_session_file_is_not_taken_for_a_sidecar_without_a_log(tmp_path):
    root = _studies.make_study(tmp_path / "s", {"P01/run-01": {}}, rig={"dbc": "rig/x.dbc"})
    write_session(root / "P01" / SESSION_FILE, Session(
        subject="P01", seed=1, order=(SessionTrial("run-01"),), done=("run-01",)))
    trials, warnings = discover_trials(root)
    assert [t.key for t in trials] == ["P01/run-01"]
    assert not any(SESSION_FILE in w.text for w in warnings)
