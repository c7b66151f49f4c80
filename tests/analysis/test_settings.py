"""The analysis settings: defaults, ``analysis/default.toml``, ``[analysis]`` of study.toml and
the command line's overrides."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pandas as pd
import pytest

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_study
from evtribo.analysis.settings import SETTING_HELP, AnalysisSettings, parse_setting
from evtribo.cli import main
from evtribo.errors import ConfigError, toml_key_line
from evtribo.results.pipeline import analyze_study

DEFAULT_TOML = Path(__file__).resolve().parents[2] / "analysis" / "default.toml"


def test_default_toml_lists_every_setting_with_the_package_default_and_its_meaning():
    text = DEFAULT_TOML.read_text(encoding="utf-8")
    table = tomllib.loads(text)["analysis"]
    assert table == AnalysisSettings().to_dict()
    assert list(table) == list(SETTING_HELP)
    flat = " ".join(line.lstrip("# ") for line in text.splitlines() if line.startswith("#"))
    for meaning in SETTING_HELP.values():
        assert meaning in flat
    # it is a valid [analysis] table as it stands
    assert AnalysisSettings().updated(table) == AnalysisSettings()


def test_values_are_checked_and_errors_name_the_line_and_key():
    text = 'name = "x"\n\n[rig]\ndbc = "a.dbc"\n\n[analysis]\nguard_s = 0.2\nguard_sec = 1\n'
    with pytest.raises(ConfigError) as err:
        AnalysisSettings().updated({"guard_s": 0.2, "guard_sec": 1}, source="study.toml",
                                   text=text)
    assert err.value.line == 8 and err.value.key == "analysis.guard_sec"
    assert "did you mean 'guard_s'?" in str(err.value)
    for bad in ({"min_window_s": 0}, {"confidence": 1.0}, {"n_boot": 10.5},
                {"hum": "notch"}, {"tare": "lift"}, {"seed": -1}, {"smooth_s": "0.1"},
                {"max_window_s": 0.1}):
        with pytest.raises(ConfigError):
            AnalysisSettings().updated(bad)
    assert AnalysisSettings().updated({"n_boot": 500.0, "guard_s": 1}).n_boot == 500
    assert parse_setting("guard_s=0.3") == ("guard_s", 0.3)
    assert parse_setting("hum=keep") == ("hum", "keep")
    assert parse_setting("tare = none") == ("tare", "none")
    assert toml_key_line("analysis.seed = 3\n", "analysis", "seed") == 1
    assert toml_key_line("[rig]\ncalibration = {matrix = 1}\n", "rig.calibration",
                         "matrix") == 2


@pytest.fixture(scope="module")
def small_study(tmp_path_factory):
    root = tmp_path_factory.mktemp("settings-study")
    simulate_study(root, [SubjectParams(name="P01", mu=0.4)], amplitudes=(80.0, 140.0),
                   config=TrialConfig(duration_s=10.0, tare_s=1.5, fz_offset_N=0.03,
                                      fx_offset_N=-0.02), sine_trial=False)
    return root


def _with_analysis(root: Path, table: str) -> None:
    toml = root / "study.toml"
    text = toml.read_text(encoding="utf-8").split("\n[analysis]")[0]
    toml.write_text(text + ("\n[analysis]\n" + table if table else ""), encoding="utf-8")


def test_the_study_s_analysis_table_is_honoured_and_reported(small_study, tmp_path):
    _with_analysis(small_study, "guard_s = 0.6\nn_boot = 300\ntare = \"none\"\n")
    try:
        res = analyze_study(small_study, tmp_path / "a", jobs=1)
        summary = json.loads((tmp_path / "a" / "summary.json").read_text(encoding="utf-8"))
        assert summary["settings"]["guard_s"] == 0.6 and summary["settings"]["n_boot"] == 300
        assert summary["settings"]["tare"] == "none"
        assert (res.trials.tare == "none").all() and res.trials.normal_offset_N.isna().all()
        _with_analysis(small_study, "")
        base = analyze_study(small_study, tmp_path / "b", jobs=1,
                             settings=AnalysisSettings(n_boot=300))
        assert base.trials.tare.str.startswith("lifted").all()
        # a longer guard leaves less of each phase: fewer window-seconds, none near a switch
        span = (res.windows.t_end_s - res.windows.t_start_s).sum()
        base_span = (base.windows.t_end_s - base.windows.t_start_s).sum()
        assert span < base_span - 1.0
    finally:
        _with_analysis(small_study, "")


def test_the_command_line_overrides_the_study(small_study, tmp_path, capsys):
    _with_analysis(small_study, 'tare = "none"\n')
    try:
        assert main(["analyze", str(small_study), "--out", str(tmp_path / "o"), "--jobs", "1",
                     "--tare", "lifted", "--set", "n_boot=200", "--set", "hum=keep",
                     "--guard-s", "0.25", "--seed", "7", "--confidence", "0.9"]) == 0
        summary = json.loads((tmp_path / "o" / "summary.json").read_text(encoding="utf-8"))
        assert summary["settings"]["tare"] == "lifted"
        assert summary["settings"]["n_boot"] == 200
        assert (summary["settings"]["guard_s"], summary["settings"]["seed"],
                summary["settings"]["confidence"]) == (0.25, 7, 0.9)
        assert summary["settings"]["hum"] == "keep"
        trials = pd.read_csv(tmp_path / "o" / "trials.csv")
        assert (trials.tare == "lifted").all()
        assert trials.normal_offset_N.tolist() == pytest.approx([0.03, 0.03], abs=0.002)
        with pytest.raises(SystemExit) as stop:  # argparse's own usage error
            main(["analyze", str(small_study), "--out", str(tmp_path / "p"),
                  "--tare", "sideways"])
        assert stop.value.code == 2 and "invalid choice" in capsys.readouterr().err
    finally:
        _with_analysis(small_study, "")
