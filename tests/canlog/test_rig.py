"""Rig descriptions: resolution against the DBC, and errors that name key, name and closest."""

import shutil
from pathlib import Path

import pytest

from evtribo.canlog.rig import Rig, default_rig, load_rig
from evtribo.errors import RigConfigError

DEFAULT_DBC = Path(default_rig().dbc)


def _study(tmp_path, **over):
    shutil.copy(DEFAULT_DBC, tmp_path / "loadcells.dbc")
    table = {"dbc": "loadcells.dbc", "normal_force": "FzCell.Fz",
             "tangential_force": "FxCell.Fx"}
    table.update(over)
    return {k: v for k, v in table.items() if v is not None}


def test_default_rig_resolves_every_role():
    rig = default_rig()
    assert rig.normal_force.qualified_name == "FzCell.Fz"
    assert rig.normal_force.message.frame_id == 0xC1
    assert rig.tangential_force_counter.signal.name == "FxCounter"
    assert rig.excitation_waveform.signal.choices[1] == "square"
    assert set(rig.roles) == {"normal_force", "tangential_force", "normal_force_counter",
                              "tangential_force_counter", "excitation_enabled",
                              "excitation_amplitude", "excitation_frequency",
                              "excitation_waveform", "excitation_command_enabled",
                              "excitation_command_amplitude", "excitation_command_frequency",
                              "excitation_command_waveform"}
    assert rig.excitation_command_amplitude.qualified_name == "HvCmd.HvAmp"
    assert set(rig.measured_roles) == set(rig.roles) - {
        r for r in rig.roles if "_command_" in r}


def test_from_mapping_resolves_dbc_relative_to_base_dir(tmp_path):
    rig = Rig.from_mapping(_study(tmp_path), tmp_path, source=tmp_path / "study.toml")
    assert rig.dbc == (tmp_path / "loadcells.dbc").resolve()
    assert not rig.has_excitation


def test_unknown_message_names_key_name_and_closest(tmp_path):
    with pytest.raises(RigConfigError) as exc:
        Rig.from_mapping(_study(tmp_path, normal_force="FzCel.Fz"), tmp_path,
                         source=tmp_path / "study.toml")
    msg = str(exc.value)
    assert exc.value.key == "rig.normal_force"
    assert "study.toml" in msg and "'FzCel'" in msg and "FzCell" in msg


def test_unknown_signal_names_closest_signals(tmp_path):
    with pytest.raises(RigConfigError) as exc:
        Rig.from_mapping(_study(tmp_path, tangential_force="FxCell.Fz"), tmp_path)
    msg = str(exc.value)
    assert exc.value.key == "rig.tangential_force"
    assert "'Fz'" in msg and "Fx" in msg and "FzCell.Fz" in msg


def test_malformed_name(tmp_path):
    with pytest.raises(RigConfigError, match=r"Message\.Signal") as exc:
        Rig.from_mapping(_study(tmp_path, excitation_enabled="HvOn"), tmp_path)
    assert exc.value.key == "rig.excitation_enabled"


def test_missing_dbc_and_unparsable_dbc(tmp_path):
    with pytest.raises(RigConfigError, match="not found") as exc:
        Rig.from_mapping(_study(tmp_path, dbc="nope.dbc"), tmp_path)
    assert exc.value.key == "rig.dbc"
    (tmp_path / "bad.dbc").write_text("BO_ this is not a dbc\n")
    with pytest.raises(RigConfigError, match="cannot parse DBC") as exc:
        Rig.from_mapping(_study(tmp_path, dbc="bad.dbc"), tmp_path)
    assert "bad.dbc" in str(exc.value)


def test_unknown_and_missing_keys(tmp_path):
    with pytest.raises(RigConfigError, match="did you mean 'normal_force_counter'") as exc:
        Rig.from_mapping(_study(tmp_path, normal_force_countr="FzCell.FzCounter"), tmp_path)
    assert exc.value.key == "rig.normal_force_countr"
    with pytest.raises(RigConfigError, match="missing") as exc:
        Rig.from_mapping(_study(tmp_path, tangential_force=None), tmp_path)
    assert exc.value.key == "rig.tangential_force"


def test_rig_toml_keys_are_top_level(tmp_path):
    (tmp_path / "r.toml").write_text(
        f'dbc = "{DEFAULT_DBC}"\nnormal_force = "FzCell.Fz"\ntangential_force = "FxCel.Fx"\n')
    with pytest.raises(RigConfigError) as exc:
        load_rig(tmp_path / "r.toml")
    assert exc.value.key == "tangential_force"
    assert str(exc.value).startswith(f"{tmp_path / 'r.toml'}: key 'tangential_force'")


def test_fingerprint_follows_dbc_and_mapping(tmp_path):
    a = Rig.from_mapping(_study(tmp_path), tmp_path)
    b = Rig.from_mapping(_study(tmp_path, normal_force="FzCell.FzTemp"), tmp_path)
    assert a.fingerprint() != b.fingerprint()
    assert a.fingerprint() == Rig.from_mapping(_study(tmp_path), tmp_path).fingerprint()


def test_dbc_with_overlapping_signals_loads_with_a_warning(tmp_path, caplog):
    # Vendors' DBCs often fail cantools' strict checks; each signal still decodes on its own.
    (tmp_path / "quirky.dbc").write_text(
        'VERSION ""\n\nNS_ :\n\nBS_:\n\nBU_: N\n\n'
        'BO_ 193 FzCell: 8 N\n'
        ' SG_ Fz : 0|24@1- (1e-05,0) [-83|83] "N" N\n'
        ' SG_ FzHigh : 16|16@1+ (1,0) [0|65535] "" N\n\n'
        'BO_ 194 FxCell: 8 N\n'
        ' SG_ Fx : 0|24@1- (1e-05,0) [-83|83] "N" N\n')
    with caplog.at_level("WARNING", logger="evtribo.canlog.rig"):
        rig = Rig.from_mapping({"dbc": "quirky.dbc", "normal_force": "FzCell.Fz",
                                "tangential_force": "FxCell.Fx"}, tmp_path)
    assert rig.normal_force.qualified_name == "FzCell.Fz"
    assert "decoding it anyway" in caplog.text


@pytest.mark.parametrize(("make", "needle"), [
    (lambda p: p.mkdir(), "is a folder"),
    (lambda p: p.write_bytes(b'dbc = "caf\xe9.dbc"\n'), "not UTF-8"),
])
def test_rig_file_that_is_a_folder_or_not_utf8_is_a_named_rig_error(tmp_path, make, needle):
    path = tmp_path / "rig.toml"
    make(path)
    with pytest.raises(RigConfigError, match=needle) as err:
        load_rig(path)
    assert err.value.path == str(path)


def test_counter_is_the_role_or_a_counter_named_signal_of_the_force_message(tmp_path):
    rig = default_rig()
    assert rig.counter("normal") is rig.normal_force_counter
    toml = tmp_path / "rig.toml"
    toml.write_text(f'dbc = "{rig.dbc}"\nnormal_force = "FzCell.Fz"\n'
                    'tangential_force = "FxCell.Fx"\n')
    plain = load_rig(toml)
    assert plain.counter("normal").qualified_name == "FzCell.FzCounter"
    toml.write_text(f'dbc = "{rig.dbc}"\nnormal_force = "HvStatus.HvAmp"\n'
                    'tangential_force = "FxCell.Fx"\n')
    assert load_rig(toml).counter("normal").qualified_name == "HvStatus.HvCounter"
