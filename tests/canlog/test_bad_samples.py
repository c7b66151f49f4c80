"""Samples no load cell gives: a float force signal whose frames carry 3.4e38 (a float's
largest value, a node's way of saying "no reading") or NaN. Taken as forces, 20 such spikes
in a 16-s trial left it without a single window and no word why; they are bad samples,
outside the DBC's declared range (or no number at all), left out, counted and said."""

from __future__ import annotations

import re
import struct
from functools import cache

import numpy as np
import pytest

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_trial
from evtribo.analysis.trial import TrialMeta, analyze_signals
from evtribo.canlog.decode import decode_trial
from evtribo.canlog.rig import Calibration, default_rig, load_rig


def _float_rig(folder, fz_range="[-100|100]"):
    """The default rig with the normal force as a 32-bit IEEE float in bytes 0-3."""
    source = default_rig().dbc
    dbc = source.read_text(encoding="utf-8").replace(
        ' SG_ Fz : 0|24@1- (1e-05,0) [-83.88608|83.88607] "N" Logger',
        f' SG_ Fz : 0|32@1- (1,0) {fz_range} "N" Logger').replace(
        ' SG_ FzStatus : 24|8@1+ (1,0) [0|255] "" Logger\n', "")
    dbc = re.sub(r"VAL_ 193 FzStatus[^;]*;\n", "", dbc) + "\nSIG_VALTYPE_ 193 Fz : 1;\n"
    (folder / "float.dbc").write_text(dbc, encoding="utf-8")
    (folder / "float.toml").write_text(
        (source.parent / "default.toml").read_text(encoding="utf-8").replace(
            'dbc = "default.dbc"', 'dbc = "float.dbc"'), encoding="utf-8")
    return load_rig(folder / "float.toml")


@cache
def _frames():
    """A simulated trial, its normal force re-encoded as float32."""
    frames, _ = simulate_trial(SubjectParams(), TrialConfig(duration_s=16.0, seed=2))
    fz = np.flatnonzero(frames.arbitration_id == 0x0C1)
    raw = frames.data[fz, :3].astype(np.int64)
    code = raw[:, 0] | raw[:, 1] << 8 | raw[:, 2] << 16
    force = np.where(code >= 1 << 23, code - (1 << 24), code) * 1e-5
    frames.data = frames.data.copy()
    frames.data[fz, :4] = force.astype("<f4").view(np.uint8).reshape(-1, 4)
    return frames, fz


#: The simulated tangential cell reads zero at rest, as a calibrated rig's does.
EXACT = Calibration(tangential_offset_N=0.0)


def _spiked(value: float, n: int = 20):
    frames, fz = _frames()
    spiked = frames.take(np.arange(len(frames)))
    spiked.data = frames.data.copy()
    rows = np.random.default_rng(0).choice(fz[100:-100], n, replace=False)
    spiked.data[rows, :4] = np.frombuffer(struct.pack("<f", value), np.uint8)
    return spiked, rows


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    return _float_rig(tmp_path_factory.mktemp("float-rig"))


@pytest.fixture(scope="module")
def clean(rig):
    return analyze_signals(decode_trial(_frames()[0], rig), TrialMeta("P01", "run-01"),
                           calibration=EXACT)


@pytest.mark.parametrize("value", [3.4e38, float("nan"), -1e6])
def test_spikes_outside_the_declared_range_are_bad_samples_and_the_trial_is_analysed(
        rig, clean, value):
    assert len(clean.windows) >= 10
    frames, rows = _spiked(value)
    signals = decode_trial(frames, rig)
    assert np.all(np.abs(signals.normal.value) < 100)
    assert len(signals.normal.value) == len(_frames()[1]) - 20
    assert signals.normal.dropped == 0           # a bad sample is no lost frame
    (said,) = [w.text for w in signals.warnings if w.kind == "samples-bad"]
    assert said.startswith("20 samples of FzCell.Fz")
    first = frames.timestamp[rows.min()] - frames.timestamp[0]
    assert f"the first at {first:.3f} s" in said
    result = analyze_signals(signals, TrialMeta("P01", "run-01"), calibration=EXACT)
    assert len(result.windows) >= len(clean.windows) - 1
    assert any(w.kind == "samples-bad" for w in result.warnings)


def test_a_declared_range_most_samples_miss_is_said_not_applied(tmp_path):
    """A DBC whose range is wrong for the cell ([1|100] N, where the cell reads 0.5 N)
    keeps every sample, and says the range looks wrong."""
    rig = _float_rig(tmp_path, "[1|100]")
    signals = decode_trial(_frames()[0], rig)
    assert len(signals.normal.value) == len(_frames()[1])
    (said,) = [w.text for w in signals.warnings if w.kind == "samples-range-wrong"]
    assert "kept" in said
