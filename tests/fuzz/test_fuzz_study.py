"""study.toml, the [rig] table and trial sidecars with fuzzed content: a loaded study, or
a :class:`~evtribo.errors.UserInputError` naming the file (and the key or line when there
is one); never another exception."""

from __future__ import annotations

import json
import shutil
import string

import pytest
from hypothesis import event, given
from hypothesis import strategies as st

from evtribo.canlog.rig import ROLES, default_rig_path
from evtribo.errors import RigConfigError, SidecarError, StudyError, UserInputError
from evtribo.study import load_study, parse_sidecar, read_sidecar, read_study_toml

DBC = default_rig_path().with_name("default.dbc")
SIGNALS = ("FzCell.Fz", "FxCell.Fx", "FzCell.FzCounter", "HvStatus.HvOn", "HvStatus.HvAmp",
           "HvStatus.HvWave", "FzCell", "Fz", "FzCell.Fz.x", "Nope.Fz", "FzCell.Nope", "",
           ".", "FzCell.")

json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=12),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner,
                                                                 max_size=4),
    max_leaves=10)
SIDECAR_KEYS = ("subject", "waveform", "frequency_Hz", "amplitude_V", "condition", "notes")
sidecars = st.dictionaries(st.sampled_from(SIDECAR_KEYS) | st.text(max_size=8),
                           json_values | st.sampled_from(
                               ("P01", "../P02", "/etc", "sine", "square", "SINE", "on",
                                "alternating", "140", 140, -1, float("nan"), 1e400)),
                           max_size=7)


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    return tmp_path_factory.mktemp("study-fuzz")


@given(data=sidecars | json_values)
def test_parse_sidecar(data):
    try:
        sc = parse_sidecar(data, path="P01/run-01.json", default_subject="P01")
    except SidecarError as err:
        assert str(err).startswith("P01/run-01.json")
        return
    assert sc.subject and "/" not in sc.subject and ".." not in sc.subject
    assert sc.waveform in (None, "sine", "square")
    assert sc.condition in (None, "on", "off", "alternating")
    for v in (sc.frequency_Hz, sc.amplitude_V):
        assert v is None or (isinstance(v, float) and v >= 0 and v != float("inf"))


@given(content=st.binary(max_size=300) | st.text(max_size=300).map(str.encode)
       | sidecars.map(lambda d: json.dumps(d).encode()))
def test_read_sidecar_of_any_bytes(work, content):
    path = work / "run-01.json"
    path.write_bytes(content)
    try:
        read_sidecar(path, default_subject="P01")
    except SidecarError as err:
        assert err.path == str(path)


toml_scalars = (st.integers(-(2**63), 2**63 - 1).map(str)
                | st.floats(allow_nan=True).map(lambda f: repr(f).replace("inf", "inf"))
                | st.text(string.printable, max_size=10).map(json.dumps)
                | st.sampled_from(SIGNALS).map(json.dumps)
                | st.sampled_from(("true", "[1, 2]", "{a = 1}", '"rig/default.dbc"',
                                   '"nope.dbc"', '"rig"', '"../rig/default.dbc"')))
rig_keys = st.sampled_from(("dbc", *ROLES, "name", "dbcc", "normal-force")) | st.text(
    string.ascii_letters + "_", min_size=1, max_size=8)


@st.composite
def study_tomls(draw):
    """A valid study.toml with 0 to 3 faults: keys added, values replaced, text inserted."""
    top = {"name": json.dumps(draw(st.text(string.printable, max_size=10)))}
    rig = {"dbc": '"rig/default.dbc"', "normal_force": '"FzCell.Fz"',
           "tangential_force": '"FxCell.Fx"'}
    damage_text = False
    for _ in range(draw(st.integers(0, 3))):
        fault = draw(st.sampled_from(("top", "rig", "rig", "drop", "text")))
        if fault == "top":
            top[draw(st.sampled_from(("name", "analysis", "extra", "rig")))] = \
                draw(toml_scalars)
        elif fault == "rig":
            rig[draw(rig_keys)] = draw(toml_scalars)
        elif fault == "drop" and rig:
            del rig[draw(st.sampled_from(sorted(rig)))]
        else:
            damage_text = True
    lines = [f"{k} = {v}" for k, v in top.items()]
    if "rig" not in top:
        lines += ["[rig]", *(f"{k} = {v}" for k, v in rig.items())]
    text = "\n".join(lines) + "\n"
    if damage_text:
        pos = draw(st.integers(0, len(text)))
        text = text[:pos] + draw(st.text(max_size=5)) + text[pos:]
    return text


@given(text=study_tomls())
def test_load_study_with_any_study_toml(work, text):
    root = work / "study"
    shutil.rmtree(root, ignore_errors=True)
    (root / "rig").mkdir(parents=True)
    shutil.copy(DBC, root / "rig" / "default.dbc")
    (root / "P01").mkdir()
    (root / "P01" / "run-01.log").write_text("(1.0) vcan0 0C1#00\n")
    (root / "study.toml").write_text(text, encoding="utf-8", errors="surrogateescape")
    try:
        study = load_study(root)
    except (StudyError, RigConfigError) as err:
        event(type(err).__name__)
        assert err.path is not None and "study.toml" in err.path
        assert err.key is not None or err.line is not None or "TOML" in err.message \
            or "UTF-8" in err.message, str(err)
        return
    event("loaded")
    assert study.rig is not None and len(study.trials) == 1


@given(content=st.binary(max_size=200))
def test_read_study_toml_of_any_bytes(work, content):
    path = work / "study.toml"
    path.write_bytes(content)
    try:
        read_study_toml(path)
    except UserInputError as err:
        assert err.path == str(path)
