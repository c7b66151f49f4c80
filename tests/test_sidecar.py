"""The trial sidecar's one module: one shape written by every writer, both shapes read."""

from __future__ import annotations

import json

from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, write_trial
from evtribo.canlog.rig import default_rig
from evtribo.documents.sidecar import (
    CONDITIONS,
    WAVEFORMS,
    Sidecar,
    read_sidecar,
    rig_entry,
    write_sidecar,
)


def test_simulated_sidecar_names_its_rig_as_acquire_does(tmp_path):
    write_trial(tmp_path, "run-01", SubjectParams(name="P01"),
                TrialConfig(duration_s=0.5))
    raw = json.loads((tmp_path / "P01" / "run-01.json").read_text())
    rig = default_rig()
    assert raw["rig"] == rig_entry("rig/default.dbc", name=rig.name,
                                   dbc_version=rig.database.version)
    assert (tmp_path / raw["rig"]["dbc"]).is_file()


def test_both_rig_shapes_on_disk_are_read(tmp_path):
    old, new = tmp_path / "old.json", tmp_path / "new.json"
    old.write_text(json.dumps({"rig": "rig/default.dbc"}))
    new.write_text(json.dumps({"rig": {"name": "r", "dbc": "rig/x.dbc", "dbc_version": "1"}}))
    assert read_sidecar(old, default_subject="P01").rig == {"dbc": "rig/default.dbc"}
    assert read_sidecar(new, default_subject="P01").rig == {
        "name": "r", "dbc": "rig/x.dbc", "dbc_version": "1"}
    assert read_sidecar(new, default_subject="P01").extra["rig"]["dbc"] == "rig/x.dbc"
    assert Sidecar(subject="P01").rig is None


def test_writer_writes_the_one_rig_shape(tmp_path):
    p = write_sidecar(tmp_path / "run-01.json", {"subject": "P01", "rig": "rig/a.dbc"})
    assert json.loads(p.read_text())["rig"] == {"dbc": "rig/a.dbc"}


names = st.text(st.sampled_from("abcXYZ019-_"), min_size=1, max_size=12)


sidecars = st.builds(
    Sidecar, subject=names, waveform=st.none() | st.sampled_from(WAVEFORMS),
    frequency_Hz=st.none() | st.floats(0, 1e6), amplitude_V=st.none() | st.floats(0, 1e4),
    condition=st.none() | st.sampled_from(CONDITIONS), notes=st.text(max_size=20),
    extra=st.fixed_dictionaries({"frames": st.integers(0, 10**9),
                                 "rig": st.just(rig_entry("rig/r.dbc", name="r"))}))


@settings(max_examples=40, deadline=None)
@given(sidecar=sidecars)
def test_what_is_written_is_read_back(tmp_path_factory, sidecar):
    path = tmp_path_factory.mktemp("s") / "run.json"
    write_sidecar(path, sidecar)
    assert read_sidecar(path, default_subject=sidecar.subject) == sidecar
