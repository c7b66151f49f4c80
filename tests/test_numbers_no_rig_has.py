"""Numbers no rig has: every number a user gives (study.toml's ``[rig.calibration]`` and
``[analysis]``, a sidecar's, ``simulate``'s and ``acquire``'s options) is either within
bounds generous enough for any real rig, where the results are finite, or refused with exit
2 naming the key; the bounds are the ones docs/study-format.md and ``--help`` give."""

from __future__ import annotations

import argparse
import json
import math
import re
from dataclasses import fields
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st

from evtribo.analysis.settings import AnalysisSettings, setting_bounds
from evtribo.cli import main
from evtribo.cli.recording._bounds import BOUNDS, check_bounds
from evtribo.documents.calibration import MAX_ENTRY, MAX_OFFSET_N, Calibration
from evtribo.documents.sidecar import SIDECAR_BOUNDS, parse_sidecar
from evtribo.errors import ConfigError, SidecarError

STUDY_FORMAT = Path(__file__).parents[1] / "docs" / "study-format.md"
NUMERIC = [f.name for f in fields(AnalysisSettings) if f.type in ("float", "int")]

_finite = st.floats(allow_nan=False, allow_infinity=False)
_number = st.one_of(_finite, st.integers(-10**30, 10**30),
                    st.floats(-1e7, 1e7, allow_nan=False))


def _documented() -> dict[str, str]:
    """docs/study-format.md's table of bounds: key -> allowed."""
    rows = re.findall(r"^\s*\| `([^|]+)` \| ([^|]+) \|$", STUDY_FORMAT.read_text("utf-8"),
                      re.M)
    return {k: v.strip() for k, v in rows}


def _within(text: str, value: float) -> bool:
    """Whether *value* satisfies ``>= 0 and <= 3,600`` (the docs' words)."""
    m = re.fullmatch(r"(>=?) (\S+) and <= (\S+)", text)
    assert m, text
    low, high = float(m.group(2).replace(",", "")), float(m.group(3).replace(",", ""))
    return (value >= low if m.group(1) == ">=" else value > low) and value <= high


def test_the_documented_bounds_are_the_code_s():
    table = _documented()
    for name in NUMERIC:
        assert table[f"analysis.{name}"] == setting_bounds(name), name
    assert f"±{MAX_OFFSET_N:g} N" in table[
        "rig.calibration.normal_offset_N`, `rig.calibration.tangential_offset_N"]
    assert f"±{MAX_ENTRY:g}" in table["rig.calibration.matrix"]
    text = STUDY_FORMAT.read_text("utf-8")
    assert "`amplitude_V` from 0 to 100,000 V, `frequency_Hz` from 0 to 10⁸ Hz" in text
    assert (SIDECAR_BOUNDS["amplitude_V"][0], SIDECAR_BOUNDS["frequency_Hz"][0],
            SIDECAR_BOUNDS["tare_s"][0]) == (1e5, 1e8, 3600.0)


@given(name=st.sampled_from(NUMERIC), value=_number)
def test_an_analysis_setting_is_refused_naming_it_or_within_its_bounds(name, value):
    try:
        got = AnalysisSettings().updated({name: value}, source="study.toml")
    except ConfigError as err:
        assert err.key == f"analysis.{name}" and err.path == "study.toml"
        return
    assert _within(setting_bounds(name), float(getattr(got, name)))


@given(entries=st.lists(_number, min_size=4, max_size=4), offset=_number)
def test_a_calibration_is_refused_naming_its_key_or_within_its_bounds(entries, offset):
    matrix = [entries[:2], entries[2:]]
    try:
        cal = Calibration.from_mapping({"matrix": matrix, "normal_offset_N": offset})
    except ConfigError as err:
        assert err.key in ("rig.calibration.matrix", "rig.calibration.normal_offset_N")
        return
    assert cal.matrix is not None and cal.normal_offset_N is not None
    assert all(abs(x) <= MAX_ENTRY for r in cal.matrix for x in r)
    assert abs(cal.normal_offset_N) <= MAX_OFFSET_N


@given(key=st.sampled_from(sorted(SIDECAR_BOUNDS)), value=_number)
def test_a_sidecar_number_is_refused_naming_its_key_or_within_its_bounds(key, value):
    try:
        parse_sidecar({key: value}, path="P01/run-01.json", default_subject="P01")
    except SidecarError as err:
        assert err.key == key
        return
    assert 0 <= value <= SIDECAR_BOUNDS[key][0]


@given(flag=st.sampled_from(sorted(BOUNDS)), value=_finite)
def test_a_recording_option_is_refused_naming_it_or_within_its_bounds(flag, value):
    bound = BOUNDS[flag]
    try:
        check_bounds(argparse.Namespace(**{flag[2:].replace("-", "_"): value}), [flag])
    except ConfigError as err:
        assert err.key == flag
        assert not (bound.low <= value <= bound.high) or (
            value == bound.low and not bound.low_allowed)
        return
    assert bound.low <= value <= bound.high


@pytest.mark.parametrize("command", ["simulate", "acquire"])
def test_help_gives_each_option_s_bounds(command, capsys):
    with pytest.raises(SystemExit):
        main([command, "--help"])
    text = re.sub(r"\s+", " ", capsys.readouterr().out)
    assert "--amplitude" in text and ">= 0 and <= 100000 V" in text


# -- end to end: the extremes a user may give, analysed ----------------------------------


@pytest.fixture(scope="module")
def small_study(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One simulated subject at 60 and 140 V, 8 s each."""
    study = tmp_path_factory.mktemp("extremes") / "study"
    for trial, amp in (("run-01", "60"), ("run-02", "140")):
        assert main(["simulate", "--study", str(study), "--subject", "P01", "--trial", trial,
                     "--duration", "8", "--amplitude", amp]) == 0
    return study


def _extremes() -> list[tuple[str, float]]:
    out = []
    for name in NUMERIC:
        m = re.fullmatch(r"(>=?) (\S+) and <= (\S+)", setting_bounds(name))
        assert m
        low, high = (float(x.replace(",", "")) for x in (m.group(2), m.group(3)))
        if name in ("n_boot", "seed"):
            high = min(high, 10_000)  # the highest n_boot costs minutes, not a risk
        out += [(name, high), (name, low if m.group(1) == ">=" else math.nextafter(low, 1))]
    return out


def _finite_tables(out: Path) -> None:
    for name in ("electrostatic.csv", "windows.csv", "trials.csv", "exponents.csv"):
        path = out / name
        if path.exists():
            values = pd.read_csv(path).select_dtypes("number").to_numpy(float)
            assert not np.isinf(values).any(), name


@pytest.mark.slow
@pytest.mark.parametrize(("name", "value"), _extremes())
def test_an_analysis_at_any_setting_s_extreme_gives_finite_numbers(name, value, small_study,
                                                                   tmp_path, capsys):
    pair = []  # min_window_s <= max_window_s, as the settings require
    if name == "max_window_s":
        pair = ["--set", f"min_window_s={min(value, 0.2)!r}"]
    if name == "min_window_s":
        pair = ["--set", f"max_window_s={max(value, 1.0)!r}"]
    out = tmp_path / "out"
    code = main(["analyze", str(small_study), "--out", str(out), "--jobs", "1",
                 "--set", f"{name}={value!r}", *pair])
    err = capsys.readouterr().err
    assert code in (0, 1), err
    assert "Warning" not in err and "failed" not in err, err
    if code == 0:
        _finite_tables(out)
        summary = json.loads((out / "summary.json").read_text("utf-8"))
        assert summary["settings"][name] == pytest.approx(value)


@pytest.mark.slow
@pytest.mark.parametrize("calibration", [
    f"matrix = [[{MAX_ENTRY}, {-MAX_ENTRY}], [{MAX_ENTRY}, {MAX_ENTRY}]]",
    f"matrix = [[{-MAX_ENTRY}, 0.0], [0.0, {MAX_ENTRY}]]",
    f"normal_offset_N = {MAX_OFFSET_N}\ntangential_offset_N = {-MAX_OFFSET_N}"])
def test_an_analysis_with_a_calibration_at_its_bounds_gives_finite_numbers(
        calibration, small_study, tmp_path, capsys):
    import shutil

    study = tmp_path / "study"
    shutil.copytree(small_study, study)
    with (study / "study.toml").open("a", encoding="utf-8") as fh:
        fh.write(f"\n[rig.calibration]\n{calibration}\n")
    code = main(["analyze", str(study), "--out", str(tmp_path / "out"), "--jobs", "1"])
    err = capsys.readouterr().err
    assert code in (0, 1), err
    assert "Warning" not in err and "failed" not in err, err
    if code == 0:
        _finite_tables(tmp_path / "out")


#: simulate's options at their highest (both numbers of a pair), each run on its own.
_SIMULATE_HIGHS = [(f, b.high) for f, b in BOUNDS.items()
                   if f not in ("--duration", "--band", "--seed", "--tare-s")]


@pytest.mark.slow
@pytest.mark.parametrize(("flag", "value"), _SIMULATE_HIGHS, ids=[f for f, _ in _SIMULATE_HIGHS])
def test_a_trial_simulated_at_an_option_s_highest_is_analysed_to_finite_numbers(
        flag, value, tmp_path, capsys):
    study = tmp_path / "study"
    pair = 2 if flag in ("--offsets", "--drift", "--crosstalk") else 1
    if flag == "--crosstalk":
        given = ["0.5", "-0.5"]  # (1, 1; 1, 1) is singular: each at half its highest
    else:
        given = [repr(value)] * pair
    code = main(["simulate", "--study", str(study), "--subject", "P01", "--trial", "run-01",
                 "--duration", "4", flag, *given])
    assert code == 0, capsys.readouterr().err
    code = main(["analyze", str(study), "--out", str(tmp_path / "out"), "--jobs", "1"])
    err = capsys.readouterr().err
    assert code in (0, 1), err
    assert "Warning" not in err and "failed" not in err, err
    if code == 0:
        _finite_tables(tmp_path / "out")
