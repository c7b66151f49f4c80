"""compare --models: each candidate fitted per subject, ranked by AIC, models.csv and the
frequency-response figures; on data made with each candidate the true one ranks first."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from matplotlib.axes import Axes

from evtribo.cli import main
from evtribo.errors import ConfigError
from evtribo.figures.frequency_plots import plot_frequency_response
from evtribo.figures.plots import new_axes
from evtribo.fit.models import CANDIDATES, MODELS_COLUMNS, fit_models, models_table, resolve_models
from evtribo.report.compare import compare
from sweep_data import sweep_out, sweep_rows

ALL = tuple(CANDIDATES)


def _strict_json(text: str) -> dict:
    def refuse(name: str) -> None:
        raise ValueError(f"not JSON: {name}")
    return json.loads(text, parse_constant=refuse)


def test_an_unknown_model_is_refused_naming_the_known_ones():
    with pytest.raises(ConfigError) as err:
        resolve_models("paper,jkr")
    assert err.value.key == "models"
    assert "'jkr'" in err.value.message
    for name in ALL:
        assert name in err.value.message
    assert resolve_models(" circuit, paper,circuit") == ("circuit", "paper")


def test_compare_models_writes_the_table_and_a_figure_per_subject(tmp_path):
    out = tmp_path / "out"
    truth = sweep_out(out, "circuit", seed=3)
    result = compare(out, fit="h_L,r_g", models=",".join(ALL), formats=("png",), dpi=40)
    table = pd.read_csv(out / "models.csv")
    assert tuple(table.columns) == MODELS_COLUMNS
    assert list(table["subject"]) == sorted(table["subject"])  # P01's rows, then P02's
    for subject, rows in table.groupby("subject", sort=False):
        assert sorted(rows["model"]) == sorted(ALL)
        assert list(rows["aic"]) == sorted(rows["aic"])
        assert rows["delta_aic"].iloc[0] == 0.0 and (rows["delta_aic"] >= 0).all()
        assert rows["akaike_weight"].sum() == pytest.approx(1.0)
        assert rows["model"].iloc[0] == "circuit"
        circuit = rows[rows["model"] == "circuit"].iloc[0]
        assert circuit["n_params"] == 2 and circuit["n_points"] == 80
        fitted = dict(kv.split("=") for kv in circuit["fitted"].split("; "))
        assert set(fitted) == {"h_L", "r_g"}
        assert float(fitted["h_L"]) == pytest.approx(truth[subject]["h_L"], rel=0.05)
        assert float(fitted["r_g"]) == pytest.approx(truth[subject]["r_g"], rel=0.1)
    doc = _strict_json((out / "fit.json").read_text())
    stems = {f["stem"]: f for f in doc["figures"] if f["kind"] == "frequency_response"}
    assert set(stems) == {"frequency_response_P01", "frequency_response_P02"}
    assert {f["subject"] for f in stems.values()} == {"P01", "P02"}
    for stem in stems:
        assert (out / "figures" / f"{stem}.png").is_file()
    assert "models.csv" in doc["output_sha256"]
    [ranked] = [n for n in result.notes if n.kind == "models-ranked"]
    assert "AICc" in ranked.text  # 40 points for 3 parameters: AICc
    assert ranked.effect == "information"
    assert [w["kind"] for w in doc["warnings"]] == [n.kind for n in result.notes]


def test_fit_json_is_strict_json_with_an_infinite_resistance(tmp_path):
    """A paper-made sweep leaves r_g undetermined above: its interval runs to infinity,
    written as null (JSON has no infinity), and the fixed r_sc = inf likewise."""
    out = tmp_path / "out"
    sweep_out(out, "paper", seed=1)
    compare(out, fit="h_L,r_g", formats=("png",), dpi=40)
    doc = _strict_json((out / "fit.json").read_text())
    assert doc["fixed_parameters"]["r_sc"] is None
    for subject in ("P01", "P02"):
        r_g = doc["subjects"][subject]["estimates"]["r_g"]
        assert r_g["ci_high"] is None


def test_the_command_line_takes_models(tmp_path, capsys):
    out = tmp_path / "out"
    sweep_out(out, "hertz", seed=2)
    assert main(["compare", str(out), "--models", "paper,hertz"]) == 0
    table = pd.read_csv(out / "models.csv")
    assert list(table.groupby("subject")["model"].first()) == ["hertz", "hertz"]


def test_criteria_follow_their_formulas():
    rows, _ = sweep_rows("paper", 5, subjects=1)
    few = rows.iloc[::8]  # 10 points: AICc
    for data, criterion in ((few, "AICc"), (rows, "AICc")):
        fits = fit_models(data, ["paper", "circuit"])
        for f in fits:
            n, k = f.n_points, f.n_params + 1
            assert f.criterion == criterion
            aic = n * math.log(f.wrss / n) + 2 * k
            assert f.aic == pytest.approx(aic + 2 * k * (k + 1) / (n - k - 1))
            assert f.bic == pytest.approx(n * math.log(f.wrss / n) + k * math.log(n))
    big = pd.concat([rows] * 3, ignore_index=True)  # 240 points, 3 parameters: AIC
    fits = fit_models(big, ["paper", "circuit"])
    for f in fits:
        n, k = f.n_points, f.n_params + 1
        assert f.criterion == "AIC"
        assert f.aic == pytest.approx(n * math.log(f.wrss / n) + 2 * k)


def test_a_model_that_cannot_be_fitted_is_a_row_without_numbers():
    rows, _ = sweep_rows("paper", 0, subjects=1)
    one = rows.iloc[:2]  # 2 points: the circuit (2 parameters) has no degree of freedom
    table = models_table(fit_models(one, ["paper", "circuit"]))
    assert len(table) == 2
    assert table["aic"].isna().any()  # AICc needs n > K + 1


def _winners(model: str, seeds: range) -> tuple[int, int]:
    wins = total = 0
    for seed in seeds:
        rows, _ = sweep_rows(model, seed)
        table = models_table(fit_models(rows, ALL))
        for _, g in table.groupby("subject"):
            total += 1
            wins += g["model"].iloc[0] == model
    return wins, total


@pytest.mark.parametrize("model", ALL)
def test_the_true_model_has_the_lowest_aic(model):
    wins, total = _winners(model, range(2))
    assert wins >= 0.9 * total, f"{model}: {wins} of {total}"


@pytest.mark.slow
@pytest.mark.parametrize("model", ALL)
def test_the_true_model_has_the_lowest_aic_in_nine_seeds_of_ten(model):
    wins, total = _winners(model, range(2, 12))
    assert wins >= 0.9 * total, f"{model}: {wins} of {total}"


def test_the_frequency_response_figure_draws_on_the_axes_given():
    rows, _ = sweep_rows("circuit", 0, subjects=1)
    fits = fit_models(rows, ["paper", "circuit"])
    ax = new_axes()
    assert plot_frequency_response(rows, fits, subject="P01", ax=ax) is ax
    lines = ax.get_lines()
    # per drive (every amplitude at each normal force: 10): one curve per model; the
    # circuit's falls at low frequency
    curves = [ln for ln in lines if len(ln.get_xdata()) == 121]
    assert len(curves) == 10 * 2
    circuit = curves[[f.model for f in fits].index("circuit")].get_ydata()
    assert circuit[0] < 0.5 * circuit[-1]
    new = plot_frequency_response(rows, fits, subject="P01")
    assert isinstance(new, Axes) and new is not ax
    assert np.isclose(np.log10(new.get_xlim()), np.log10([10, 20000]), atol=0.3).all()


def test_one_frequency_draws_no_frequency_figure_and_a_leak_at_its_bound_is_said(tmp_path):
    """A study at one drive frequency: no F_el-versus-frequency figure (one x-value), the
    models ranked over the study, and the circuit's r_g, which one frequency cannot set,
    named at its bound wherever the optimiser left it there."""
    out = tmp_path / "out"
    sweep_out(out, "paper", seed=4)
    elec = pd.read_csv(out / "electrostatic.csv")
    f0 = sorted(elec["frequency_Hz"].unique())[-1]
    elec[elec["frequency_Hz"] == f0].to_csv(out / "electrostatic.csv", index=False)
    for name in ("electrostatic_bootstrap.csv", "sine_trace.csv"):
        (out / name).unlink(missing_ok=True)
    result = compare(out, models="paper,circuit", formats=("png",), dpi=40,
                     trial_checks=False)
    assert not [f for f in result.figures if f.kind == "frequency_response"]
    kinds = [n.kind for n in result.notes]
    assert "models-one-frequency" in kinds and "models-ranked" in kinds
    assert any("at a single frequency" in n.text for n in result.notes)
    table = pd.read_csv(out / "models.csv", keep_default_na=False)
    bounded = table[table["at_bound"] != ""]
    assert set(bounded["at_bound"]) <= {"r_g"}
    if len(bounded):
        [said] = [n for n in result.notes if n.kind == "model-at-bound"]
        assert said.text.startswith("Model circuit: r_g at its bound")
        assert all(str(s) in said.value("subjects") for s in bounded["subject"])


def test_the_study_ranking_sums_each_model_over_the_subjects_with_every_model():
    from evtribo.fit.models import study_ranking, verdict

    rows = []
    for subject, aics in (("P01", {"paper": 0.0, "maugis": 1.0, "hertz": 9.0}),
                          ("P02", {"paper": 2.0, "maugis": 1.5, "hertz": 12.0}),
                          ("P03", {"paper": 1.0, "maugis": math.nan, "hertz": 3.0})):
        best = min(v for v in aics.values() if math.isfinite(v))
        rows += [{"subject": subject, "model": m, "aic": a, "delta_aic": a - best,
                  "criterion": "AICc", "at_bound": ""} for m, a in aics.items()]
    ranking = study_ranking(pd.DataFrame(rows))
    assert list(ranking["model"]) == ["paper", "maugis", "hertz"]
    assert (ranking["subjects"] == 2).all()  # P03 lacks maugis's criterion
    assert list(ranking["aic_sum"]) == [2.0, 2.5, 21.0]
    assert ranking["akaike_weight"].sum() == pytest.approx(1.0)
    assert list(ranking["best_in"]) == [1, 1, 0]
    said = verdict(ranking)
    assert said.startswith("paper lowest summed AICc over 2 subject(s)")
    assert "maugis indistinguishable from it (ΔAICc 0.5 < 2)" in said
    assert "hertz ΔAICc 19.0" in said


def test_the_ranking_of_models_csv_read_back_where_no_parameter_is_at_a_bound(tmp_path):
    """models.csv read back as the report reads it, with no parameter at a bound: its empty
    at_bound column comes back as numbers (NaN), and the ranking is that of the table
    written."""
    from evtribo.fit.models import study_ranking

    rows = [{"subject": s, "model": m, "aic": a, "delta_aic": a - 1.0, "criterion": "AIC",
             "at_bound": ""} for s in ("P01", "P02") for m, a in (("paper", 1.0),
                                                                 ("hertz", 4.0))]
    written = pd.DataFrame(rows)
    written.to_csv(tmp_path / "models.csv", index=False)
    read = pd.read_csv(tmp_path / "models.csv", dtype={"subject": str, "model": str})
    assert read["at_bound"].isna().all()
    pd.testing.assert_frame_equal(study_ranking(read), study_ranking(written))
    assert list(study_ranking(read)["at_bound_in"]) == [0, 0]


def test_a_parameter_on_a_bound_of_its_range_is_found():
    from evtribo.fit.models import _at_bound

    lower, upper = np.array([0.0, -3.0]), np.array([np.inf, 3.0])
    assert _at_bound(("h_L", "r_g"), np.array([1.0, 3.0]), lower, upper) == ("r_g",)
    assert _at_bound(("h_L", "r_g"), np.array([0.0, 0.2]), lower, upper) == ("h_L",)
    assert _at_bound(("h_L", "r_g"), np.array([1.0, 2.99]), lower, upper) == ()
