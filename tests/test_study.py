"""The study folder: discovery, names, study.toml and sidecars."""

import functools
import json
import os
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

import _studies
from evtribo import study
from evtribo.errors import OutputExistsError, SidecarError, StudyError

RIG = {"dbc": "rig/loadcells.dbc", "normal_force": "FzCell.Fz", "tangential_force": "FxCell.Fx"}


make_study = functools.partial(_studies.make_study, rig=RIG)


@given(st.text(max_size=20))
def test_names_are_plain_or_refused(name):
    try:
        ok = study.validate_name(name, what="subject")
    except StudyError as err:
        assert "not allowed" in str(err)
        assert not study.NAME_PATTERN.fullmatch(name)
    else:
        assert ok == name
        assert "/" not in name and "\\" not in name and name not in ("", ".", "..")
        assert Path(name).name == name


@pytest.mark.parametrize("bad", ["../P01", "P01/x", "/etc", "..", "", "P 01", "P01\n", 7])
def test_sidecar_subject_path_refused(tmp_path, bad):
    p = tmp_path / "run-01.json"
    p.write_text(json.dumps({"subject": bad}))
    with pytest.raises(SidecarError) as exc:
        study.read_sidecar(p, default_subject="P01")
    assert str(p) in str(exc.value) and "key 'subject'" in str(exc.value)


@pytest.mark.parametrize(
    ("sidecar", "key"),
    [
        ({"waveform": "triangle-ish"}, "waveform"),
        ({"amplitude_V": "140"}, "amplitude_V"),
        ({"amplitude_V": True}, "amplitude_V"),
        ({"amplitude_V": -5}, "amplitude_V"),
        ({"frequency_Hz": [1]}, "frequency_Hz"),
        ({"condition": "sometimes"}, "condition"),
        ({"notes": 12}, "notes"),
    ],
)
def test_sidecar_bad_values_name_the_key(tmp_path, sidecar, key):
    p = tmp_path / "run-01.json"
    p.write_text(json.dumps(sidecar))
    with pytest.raises(SidecarError) as exc:
        study.read_sidecar(p, default_subject="P01")
    assert exc.value.key == key and exc.value.path == str(p)


def test_sidecar_invalid_json_names_the_line(tmp_path):
    p = tmp_path / "run-01.json"
    p.write_text('{\n "subject": "P01",\n "amplitude_V": 140,,\n}')
    with pytest.raises(SidecarError) as exc:
        study.read_sidecar(p, default_subject="P01")
    assert exc.value.line == 3


def test_sidecar_defaults_and_unknown_keys_kept(tmp_path):
    p = tmp_path / "run-01.json"
    p.write_text(json.dumps({"waveform": "Square", "amplitude_V": 140, "frequency_Hz": 10000,
                             "condition": "alternating", "bus": "vcan0", "frames": 12}))
    s = study.read_sidecar(p, default_subject="P07")
    assert (s.subject, s.waveform, s.amplitude_V, s.condition) == ("P07", "square", 140.0,
                                                                   "alternating")
    assert s.extra == {"bus": "vcan0", "frames": 12}
    assert s.to_dict()["bus"] == "vcan0"


def test_write_sidecar_refuses_overwrite(tmp_path):
    p = tmp_path / "run-01.json"
    study.write_sidecar(p, {"subject": "P01"})
    with pytest.raises(OutputExistsError):
        study.write_sidecar(p, {"subject": "P02"})
    assert json.loads(p.read_text())["subject"] == "P01"
    study.write_sidecar(p, {"subject": "P02"}, force=True)
    assert json.loads(p.read_text())["subject"] == "P02"


def test_write_sidecar_that_fails_leaves_no_temporary_file(tmp_path):
    p = tmp_path / "run-01.json"
    with pytest.raises(ValueError):
        study.write_sidecar(p, {"subject": "P01", "amplitude_V": float("inf")})
    assert list(tmp_path.iterdir()) == []
    study.write_sidecar(p, {"subject": "P01"})          # and a retry is not blocked
    assert [f.name for f in tmp_path.iterdir()] == ["run-01.json"]


def test_discovery(tmp_path):
    root = make_study(tmp_path / "s", {
        "P01/run-01": {"condition": "on", "amplitude_V": 60},
        "P01/run-02": {"condition": "off"},
        "P02/run-01": None,
    })
    (root / "rig").mkdir()
    (root / "rig" / "stray.log").write_text("")
    (root / "P02" / "run-02.log.part").write_text("")
    (root / "P02" / "notes.txt").write_text("")
    s = study.load_study(root, with_rig=False)
    assert s.name == "sweep"
    assert [t.key for t in s.trials] == ["P01/run-01", "P01/run-02", "P02/run-01", "P02/run-02"]
    assert s.trials[3].partial and not s.trials[0].partial
    assert s.trials[2].sidecar_path is None
    assert len(s.warnings) == 3  # two without a sidecar, one partial
    assert sorted(w.kind for w in s.warnings) == ["log-partial", "sidecar-missing",
                                                   "sidecar-missing"]
    assert s.subjects == ["P01", "P02"]


def test_partial_log_superseded_by_complete_one(tmp_path):
    root = make_study(tmp_path / "s", {"P01/run-01": {}})
    (root / "P01" / "run-01.log.part").write_text("")
    s = study.load_study(root, with_rig=False)
    assert len(s.trials) == 1 and not s.trials[0].partial
    assert s.trials[0].log_path.name == "run-01.log"
    assert any("run-01.log.part: not analysed" in w.text for w in s.warnings)


def test_a_sidecar_subject_other_than_its_folder_is_refused(tmp_path):
    """A sidecar saying "S1" in folder S01 silently made a second subject: now exit 2,
    naming the sidecar; the folder's own name in the sidecar is fine."""
    root = make_study(tmp_path / "s", {"S01/run-01": {"subject": "S1"},
                                       "S01/run-02": {"subject": "S01"}})
    with pytest.raises(SidecarError) as err:
        study.load_study(root, with_rig=False)
    assert err.value.key == "subject" and err.value.path.endswith("S01/run-01.json")
    assert err.value.exit_code == 2


def test_a_misspelt_sidecar_key_is_a_warning_with_the_closest_key(tmp_path):
    root = make_study(tmp_path / "s", {"P01/run-01": {"amplitde_V": 140, "frames": 3,
                                                      "operator": "JD"}})
    loaded = study.load_study(root, with_rig=False)
    warned = [w.text for w in loaded.warnings if "run-01.json" in w.text]
    assert any("unknown key 'amplitde_V' ignored (did you mean 'amplitude_V'?)" in w
               for w in warned)
    assert any("unknown key 'operator' ignored" in w for w in warned)
    assert not any("'frames'" in w for w in warned)  # a key evtribo writes
    assert loaded.trials[0].sidecar.amplitude_V is None


@pytest.mark.parametrize("kind", ["fifo", "device", "huge", "deep"])
def test_a_sidecar_that_is_no_small_regular_file_is_refused_not_read(tmp_path, kind):
    """A FIFO hung the analysis, a link to /dev/zero was read without end, JSON nested
    100,000 deep gave a RecursionError: each is a bad input now, naming the sidecar."""
    root = make_study(tmp_path / "s", {"P01/run-01": {}})
    sidecar = root / "P01" / "run-01.json"
    sidecar.unlink()
    if kind == "fifo":
        os.mkfifo(sidecar)
    elif kind == "device":
        sidecar.symlink_to("/dev/zero")
    elif kind == "huge":
        sidecar.write_text('{"notes": "' + "x" * (2 << 20) + '"}')
    else:
        sidecar.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(SidecarError) as err:
        study.load_study(root, with_rig=False)
    assert err.value.path.endswith("run-01.json") and err.value.exit_code == 2


def test_names_too_long_for_a_file_system_are_refused(tmp_path):
    with pytest.raises(StudyError, match="at most 100"):
        study.validate_name("r" * 300, what="trial")
    assert study.validate_name("r" * 100, what="trial") == "r" * 100


@pytest.mark.parametrize(
    ("text", "key", "line"),
    [
        ('name = "x"\n[rig]\ndbc = \n', None, 3),
        ('name = 3\n[rig]\n', "name", None),
        ('nmae = "x"\n[rig]\n', "nmae", None),
        ('name = "x"\n', "rig", None),
        ('name = "x"\nrig = "loadcells.dbc"\n', "rig", None),
    ],
)
def test_bad_study_toml(tmp_path, text, key, line):
    (tmp_path / "study.toml").write_text(text)
    with pytest.raises(StudyError) as exc:
        study.load_study(tmp_path, with_rig=False)
    assert exc.value.path.endswith("study.toml")
    assert exc.value.key == key and exc.value.line == line


def test_not_a_study(tmp_path):
    with pytest.raises(StudyError, match="not a study"):
        study.load_study(tmp_path, with_rig=False)
    with pytest.raises(StudyError, match="no such study folder"):
        study.load_study(tmp_path / "missing", with_rig=False)


def test_study_toml_round_trip_and_no_overwrite(tmp_path):
    study.write_study_toml(tmp_path, name='a "quoted" name', rig=RIG)
    config = study.read_study_toml(tmp_path / "study.toml")
    assert config == {"name": 'a "quoted" name', "rig": RIG}
    with pytest.raises(OutputExistsError):
        study.write_study_toml(tmp_path, name="other", rig=RIG)


def test_discovery_knows_every_format_the_readers_read(tmp_path):
    """Discovery's log suffixes are the reader registry's, each also gzipped and .part."""
    from evtribo.canlog.io.registry import supported_suffixes

    suffixes = supported_suffixes()
    assert {".log", ".asc", ".blf", ".trc", ".csv"} <= set(suffixes)
    root = make_study(tmp_path / "s", {})
    (root / "P01").mkdir()
    expected = []
    for k, suffix in enumerate(suffixes):
        for extra in ("", ".gz", ".part", ".gz.part"):
            trial = f"run-{k:02d}-{len(extra)}"
            (root / "P01" / f"{trial}{suffix}{extra}").write_bytes(b"")
            expected.append(f"P01/{trial}")
    trials, _ = study.discover_trials(root)
    assert sorted(t.key for t in trials) == sorted(expected)


def test_sidecar_without_a_log_is_reported(tmp_path):
    root = make_study(tmp_path / "s", {"P01/run-01": {"condition": "on"}})
    (root / "P01" / "run-02.json").write_text(json.dumps({"condition": "off"}))
    (root / "P01" / "run-03.json").write_text(json.dumps({"condition": "off"}))
    (root / "P01" / "run-03.lgo").write_text("")
    (root / "P02").mkdir()
    (root / "P02" / "run-01.json").write_text(json.dumps({"condition": "off"}))
    s = study.load_study(root, with_rig=False)
    assert [t.key for t in s.trials] == ["P01/run-01"]
    assert sorted(w.text.split(": ", 1)[1] for w in s.warnings) == [
        "sidecar without a log (run-03.lgo: not a log format); not analysed",
        "sidecar without a log; not analysed",
        "sidecar without a log; not analysed"]
    assert sorted(w.text.split(": ", 1)[0] for w in s.warnings) == sorted(
        str(root / p) for p in ("P01/run-02.json", "P01/run-03.json", "P02/run-01.json"))


def test_importing_the_study_module_does_not_import_python_can():
    import subprocess
    import sys

    code = "import sys, evtribo.study; print('can' in sys.modules, 'numpy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.split() == ["False", "False"]


def test_operating_system_clutter_is_no_trial(tmp_path):
    root = make_study(tmp_path / "s", {"P01/run-01": {}})
    for name in ("Thumbs.db", "desktop.ini", ".DS_Store", "._run-01.log", "~$notes.log"):
        (root / "P01" / name).write_bytes(b"\x00\x01")
    s = study.load_study(root, with_rig=False)
    assert [t.key for t in s.trials] == ["P01/run-01"]


def test_a_subject_folder_linked_from_elsewhere_is_said_so(tmp_path):
    """A subject folder that is a link to a folder outside the study is analysed (it may be
    meant), with a warning naming both; a link inside the study is nothing to say."""
    root = make_study(tmp_path / "s", {"P01/run-01": {"condition": "on"}})
    elsewhere = make_study(tmp_path / "other", {"P07/run-01": {"subject": "P03"}})
    (root / "P03").symlink_to(elsewhere / "P07", target_is_directory=True)
    s = study.load_study(root, with_rig=False)
    assert [t.key for t in s.trials] == ["P01/run-01", "P03/run-01"]
    said = [w.text for w in s.warnings if w.kind == "subject-outside"]
    assert said == [f"{root / 'P03'}: a link to {(elsewhere / 'P07').resolve()}, outside the "
                    "study folder: its trials are analysed as subject P03's; copy them into "
                    "the study if they belong to it (or remove the link)"]
    (root / "P03").unlink()
    (root / "P03").symlink_to(root / "P01", target_is_directory=True)  # inside: no warning
    s = study.load_study(root, with_rig=False)
    assert [t.key for t in s.trials] == ["P01/run-01", "P03/run-01"]
    assert not [w for w in s.warnings if w.kind == "subject-outside"]
