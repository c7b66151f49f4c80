"""The rig's roles guessed from a DBC and a sample log (``evtribo init``), and the simulated
rig speaking other rigs' DBCs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.acquisition.simulator.anyrig import RigEncoder
from evtribo.acquisition.simulator.config import SubjectParams, TrialConfig
from evtribo.acquisition.simulator.core import TrialGenerator
from evtribo.canlog.decode import decode_trial
from evtribo.canlog.io import read_frames
from evtribo.canlog.io.candump_writer import write_candump
from evtribo.canlog.io.table import FrameTable
from evtribo.canlog.rig import default_rig, default_rig_path, load_rig
from evtribo.errors import OutputExistsError, RigConfigError
from evtribo.rigsetup import guess_roles, init_study, signal_stats
from evtribo.study import load_study

RIGS = Path(__file__).parents[1] / "data" / "rigs"
#: Three rigs of different shapes: the default one; Motorola cells on extended IDs with
#: other scales and counter widths; cells named only Ch1 / Ch2, without units, the
#: amplifier's status on an extended ID.
RIG_FILES = {"default": default_rig_path(), "motorola": RIGS / "motorola.toml",
             "channels": RIGS / "channels.toml", "lab": RIGS / "lab.toml"}


def simulated_frames(rig, seed: int = 3, duration_s: float = 6.0, **config) -> FrameTable:
    """A simulated trial in *rig*'s DBC."""
    gen = TrialGenerator(SubjectParams(), TrialConfig(duration_s=duration_s, seed=seed,
                                                      **config))
    enc = RigEncoder(rig)
    return FrameTable.concat([enc.convert(c) for c in gen.chunks()])


def sample_log(rig, path: Path, **kw) -> Path:
    write_candump(path, simulated_frames(rig, **kw))
    return path


@pytest.mark.parametrize("which", sorted(RIG_FILES))
def test_roles_guessed_from_a_sample_log(which, tmp_path):
    rig = load_rig(RIG_FILES[which])
    frames, _ = read_frames(sample_log(rig, tmp_path / "sample.log"))
    guesses = guess_roles(rig.database, signal_stats(frames, rig.database))
    named = {role: ref.qualified_name for role, ref in rig.roles.items()}
    got = {role: g.name for role, g in guesses.items() if role in named}
    assert got == named
    assert all(guesses[r].certain for r in ("normal_force", "tangential_force"))
    # a rig without an amplifier command message has none guessed
    assert all(g.name is None for r, g in guesses.items() if r not in named)


def test_names_alone_cannot_tell_ch1_from_ch2():
    rig = load_rig(RIG_FILES["channels"])
    guesses = guess_roles(rig.database)
    assert not guesses["normal_force"].certain
    assert "--log" in guesses["normal_force"].reason
    # the default rig's names are enough
    assert guess_roles(default_rig().database)["normal_force"].certain


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 10_000), swap=st.booleans())
def test_behaviour_outweighs_names(seed, swap):
    # whatever the seed, the positive steady cell is the normal one, the one changing sign
    # the tangential one; swapping which channel carries which force swaps the guess
    rig = load_rig(RIG_FILES["channels"])
    if swap:
        rig = type(rig)(**{**rig.__dict__, "normal_force": rig.tangential_force,
                           "tangential_force": rig.normal_force,
                           "normal_force_counter": rig.tangential_force_counter,
                           "tangential_force_counter": rig.normal_force_counter})
    frames = simulated_frames(rig, seed=seed, duration_s=5.0)
    guesses = guess_roles(rig.database, signal_stats(frames, rig.database))
    assert guesses["normal_force"].name == rig.normal_force.qualified_name
    assert guesses["tangential_force"].name == rig.tangential_force.qualified_name


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 10_000), which=st.sampled_from(["motorola", "channels"]),
       drop=st.sampled_from([0.0, 0.02]))
def test_encoded_frames_decode_to_the_default_rigs_values(seed, which, drop):
    rig = load_rig(RIG_FILES[which])
    gen = TrialGenerator(SubjectParams(), TrialConfig(duration_s=3.0, seed=seed,
                                                      drop_probability=drop))
    enc = RigEncoder(rig)
    chunks = list(gen.chunks())
    a = decode_trial(FrameTable.concat(chunks), default_rig())
    b = decode_trial(FrameTable.concat([enc.convert(c) for c in chunks]), rig)
    for cell in ("normal", "tangential"):
        ca, cb = getattr(a, cell), getattr(b, cell)
        scale = getattr(rig, f"{cell}_force").signal.scale
        np.testing.assert_array_equal(ca.t, cb.t)
        np.testing.assert_allclose(ca.value, cb.value, atol=scale / 2 + 1e-5)
        assert ca.dropped == cb.dropped
    np.testing.assert_array_equal(a.excitation.waveform, b.excitation.waveform)
    np.testing.assert_allclose(a.excitation.amplitude, b.excitation.amplitude, atol=0.01)


def test_init_writes_a_study_that_loads_with_the_rigs_roles(tmp_path):
    rig = load_rig(RIG_FILES["channels"])
    log = sample_log(rig, tmp_path / "sample.log")
    result = init_study(tmp_path / "lab", rig.dbc, log=log)
    assert result.missing == []
    study = load_study(tmp_path / "lab")
    assert {r: ref.qualified_name for r, ref in study.rig.roles.items()} == \
        {r: ref.qualified_name for r, ref in rig.roles.items()}
    text = result.study_toml.read_text()
    # every key of the study format is there, the optional ones commented
    for key in ("# [rig.calibration]", "# normal_offset_N", "# [analysis]", "# guard_s",
                "# excitation_command_amplitude", "in the log positive and steady"):
        assert key in text
    assert (tmp_path / "lab" / "rig" / "channels.dbc").read_bytes() == rig.dbc.read_bytes()


def test_init_refuses_an_existing_study(tmp_path):
    init_study(tmp_path / "s", default_rig().dbc)
    before = (tmp_path / "s" / "study.toml").read_text()
    with pytest.raises(OutputExistsError, match="force"):
        init_study(tmp_path / "s", RIG_FILES["motorola"].with_suffix(".dbc"))
    assert (tmp_path / "s" / "study.toml").read_text() == before
    init_study(tmp_path / "s", RIG_FILES["motorola"].with_suffix(".dbc"), force=True)
    assert "NormalCell.Force_mN" in (tmp_path / "s" / "study.toml").read_text()
    # once the user has edited it, it is theirs: --force does not replace it either
    edited = (tmp_path / "s" / "study.toml").read_text() + "# roles checked by hand\n"
    (tmp_path / "s" / "study.toml").write_text(edited)
    with pytest.raises(OutputExistsError, match="not a file evtribo wrote"):
        init_study(tmp_path / "s", default_rig().dbc, force=True)
    assert (tmp_path / "s" / "study.toml").read_text() == edited


def test_init_names_a_missing_dbc(tmp_path):
    with pytest.raises(RigConfigError, match="not found"):
        init_study(tmp_path / "s", tmp_path / "nope.dbc")
    assert not (tmp_path / "s" / "study.toml").exists()


def test_inspect_shows_each_signal_s_range_behaviour_and_role(tmp_path, capsys):
    from evtribo.cli import main

    rig = load_rig(RIG_FILES["lab"])
    log = sample_log(rig, tmp_path / "sample.log")
    assert main(["inspect", str(log), "--dbc", str(rig.dbc)]) == 0
    out = capsys.readouterr().out
    rows = {line.split()[0]: line for line in out.splitlines()
            if line.startswith(("LoadCell", "AmpStatus"))}
    normal = rows["LoadCellN.Force"].split()
    assert normal[1] == "N" and float(normal[2]) == pytest.approx(1000, rel=0.01)
    lo, mean, hi = (float(x) for x in normal[3:6])
    assert 0 < lo < mean < hi < 2  # the pressing force
    assert rows["LoadCellN.Force"].endswith("-> normal_force")
    assert rows["LoadCellT.Force"].endswith("-> tangential_force")
    assert "changes sign" in rows["LoadCellT.Force"]
    assert rows["LoadCellN.Counter"].endswith("-> normal_force_counter")
    assert rows["AmpStatus.HV_On"].endswith("-> excitation_enabled")


def test_a_load_cell_s_name_is_no_reason_for_a_role(tmp_path):
    """Messages LoadCell1 and LoadCell2 both hold a load cell: their names tell no role, so
    no reason cites them, and the roles come from the log (as for Ch1 / Ch2)."""
    text = (RIGS / "lab.dbc").read_text().replace("LoadCellN", "LoadCell1") \
        .replace("LoadCellT", "LoadCell2")
    (tmp_path / "lab.dbc").write_text(text)
    toml = (RIGS / "lab.toml").read_text().replace("LoadCellN", "LoadCell1") \
        .replace("LoadCellT", "LoadCell2")
    (tmp_path / "lab.toml").write_text(toml)
    rig = load_rig(tmp_path / "lab.toml")
    names_only = guess_roles(rig.database)
    assert not names_only["normal_force"].certain
    frames = simulated_frames(rig, seed=5, duration_s=5.0)
    guesses = guess_roles(rig.database, signal_stats(frames, rig.database))
    assert guesses["normal_force"].name == "LoadCell1.Force"
    assert guesses["tangential_force"].name == "LoadCell2.Force"
    for role in ("normal_force", "tangential_force"):
        assert "LoadCell" not in guesses[role].reason, guesses[role].reason
        assert "name says" not in guesses[role].reason, guesses[role].reason
