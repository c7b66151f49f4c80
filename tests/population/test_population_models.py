"""The population model behind a registry (:mod:`evtribo.population.models`), chosen by
study.toml's ``[population] model``: the mixed model by default, the meta-analysis, or a
lab's own, registered from its module or through an entry point, in a real compare of a
small simulated study."""

from __future__ import annotations

import json
import logging
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import evtribo
from _plugins import install
from _small_study import AMPLITUDES, analyse, small_study
from evtribo.cli import main
from evtribo.fit.tables import read_results
from evtribo.population.estimates import population
from evtribo.population.models import MODELS, register
from evtribo.population.stats import POOL_METHOD
from evtribo.util import plugins

#: A lab's model, as its plug-in module holds it: F_el at each amplitude as the subjects'
#: plain mean, with Student's interval.
LAB_MODEL = '''
import math

import numpy as np
from scipy import special

from evtribo.population.data import ModelRow
from evtribo.population.models import ModelFit


class PlainMean:
    name = "mylab-mean"
    min_amplitudes = 1

    def fit(self, cells, notes):
        rows = []
        for amp in cells.amplitudes:
            f = []
            for s in cells.subjects:
                idx = s.select_linear(cells.condition)
                hit = idx[np.isclose(s.linear["amplitude_V"].to_numpy(float)[idx], amp)]
                if hit.size:
                    f.append(float(s.linear["force_N"].iloc[hit[0]]))
            sd = float(np.std(f, ddof=1))
            half = float(special.stdtrit(len(f) - 1, 0.975)) * sd / math.sqrt(len(f))
            mean = float(np.mean(f))
            rows.append(ModelRow("electrostatic_force_N", amp, (mean, mean - half, mean + half),
                                 sd, len(f), "mylab: the subjects' mean F_el, Student's t"))
        return ModelFit(rows)

    def far(self, fit, cells, alpha):
        return []
'''


@pytest.fixture(autouse=True)
def _no_plugins():
    plugins.forget()
    yield
    MODELS.unregister("mylab-mean")
    plugins.forget()


@pytest.fixture(scope="module")
def analysed(tmp_path_factory):
    """The small study analysed three times, its study.toml's ``[population]`` naming no
    model, the lab's and the meta-analysis (written before the analysis, as the rule
    must be)."""
    base = tmp_path_factory.mktemp("models")
    plain = small_study(base / "plain")
    out = {None: analyse(plain, base / "out-plain")}
    for model in ("mylab-mean", "meta-analysis"):
        study = base / f"study-{model}"
        shutil.copytree(plain, study)
        with (study / "study.toml").open("a", encoding="utf-8") as f:
            f.write(f'\n[population]\nmodel = "{model}"\n')
        out[model] = analyse(study, base / f"out-{model}")
    assert main(["compare", str(out[None]), "--dpi", "40", "--no-trial-checks"]) == 0
    return out


def _compared(out: Path, tmp_path: Path) -> pd.DataFrame:
    """compare of a copy of *out*, its population.csv (fit.json names the model)."""
    mine = tmp_path / "out"
    shutil.copytree(out, mine)
    assert main(["compare", str(mine), "--dpi", "40", "--no-trial-checks"]) == 0
    model = json.loads((mine / "fit.json").read_text(encoding="utf-8"))["population"]["model"]
    assert model == json.loads((out / "summary.json").read_text(encoding="utf-8"))[
        "study_dir"].rpartition("study-")[2]
    return pd.read_csv(mine / "population.csv")


def _f_el(table: pd.DataFrame, analysis: str) -> pd.DataFrame:
    return table[(table.quantity == "electrostatic_force_N") & (table.analysis == analysis)]


def test_the_builtin_models_and_an_unknown_one():
    assert list(MODELS)[:2] == ["mixed", "meta-analysis"]
    with pytest.raises(ValueError, match="'mixed' is registered already"):
        register(MODELS["mixed"])


def _check_lab_model_was_used(table: pd.DataFrame, default: pd.DataFrame,
                              electrostatic: pd.DataFrame) -> None:
    primary = _f_el(table, "primary")
    assert list(primary.amplitude_V) == list(AMPLITUDES)
    assert (primary.method == "mylab: the subjects' mean F_el, Student's t").all()
    means = electrostatic.groupby("amplitude_V").electrostatic_force_N.mean()
    np.testing.assert_allclose(primary.estimate, means.loc[list(AMPLITUDES)], rtol=1e-12)
    assert (primary.n_subjects == 3).all() and (primary.ci_low < primary.estimate).all()
    # no power law from this model; the meta-analysis is there as the second method, the
    # rows of the quantities no model makes as they were
    assert not table.quantity.isin(["exponent", "prefactor_N"]).any()
    cols = [c for c in table.columns if c != "checks"]  # empty in both: no dtype read
    pd.testing.assert_frame_equal(_f_el(table, "meta-analysis")[cols].reset_index(drop=True),
                                  _f_el(default, "meta-analysis")[cols].reset_index(drop=True))
    rest = table.quantity.isin(["friction_increase_pct", "mu", "h_L_m"])
    pd.testing.assert_frame_equal(
        table[rest][cols].reset_index(drop=True),
        default[default.quantity.isin(["friction_increase_pct", "mu", "h_L_m"])][cols]
        .reset_index(drop=True))


def test_a_model_registered_from_a_module_is_chosen_by_population_model(analysed, tmp_path):
    namespace: dict[str, object] = {}
    exec(LAB_MODEL, namespace)  # the lab's module, as its source reads
    register(namespace["PlainMean"]())
    default = pd.read_csv(analysed[None] / "population.csv")
    _check_lab_model_was_used(_compared(analysed["mylab-mean"], tmp_path), default,
                              pd.read_csv(analysed[None] / "electrostatic.csv"))


def test_a_model_from_an_entry_point_is_chosen_by_population_model(analysed, tmp_path,
                                                                   monkeypatch):
    install(tmp_path, monkeypatch, "mylab_models", LAB_MODEL,
            entry_points={"evtribo.population_models": {"mean": "mylab_models:PlainMean"}})
    default = pd.read_csv(analysed[None] / "population.csv")
    _check_lab_model_was_used(_compared(analysed["mylab-mean"], tmp_path), default,
                              pd.read_csv(analysed[None] / "electrostatic.csv"))


def test_the_meta_analysis_as_the_primary_model(analysed, tmp_path):
    """Its rows are the primary ones, the same numbers the default's second method gives;
    no power law, no second method; the API's compare gives the same."""
    table = _compared(analysed["meta-analysis"], tmp_path)
    default = pd.read_csv(analysed[None] / "population.csv")
    primary, meta = _f_el(table, "primary"), _f_el(default, "meta-analysis")
    assert len(primary) == len(meta) > 0
    assert (primary.method == f"{POOL_METHOD}, of log F_el").all()
    cols = ["amplitude_V", "estimate", "ci_low", "ci_high", "between_subject_sd", "pi_low",
            "pi_high", "i2"]
    pd.testing.assert_frame_equal(primary[cols].reset_index(drop=True),
                                  meta[cols].reset_index(drop=True))
    assert table.analysis.isin(["primary"]).all()
    assert not table.quantity.isin(["exponent", "prefactor_N"]).any()
    api = evtribo.compare(evtribo.load_results(analysed["meta-analysis"]))
    pd.testing.assert_frame_equal(api.population.reset_index(drop=True)[cols],
                                  table[cols].reset_index(drop=True), check_dtype=False,
                                  check_column_type=False)  # the file read by pandas alone


def test_the_mixed_model_is_the_default(analysed):
    tables = read_results(analysed[None])
    default = pd.read_csv(analysed[None] / "population.csv")
    assert population(tables).table.equals(population(tables, model="mixed").table)
    assert _f_el(default, "primary").method.str.startswith("nonlinear mixed model").all()
    with pytest.raises(ValueError, match="must be one of mixed, meta-analysis, got 'bayes'"):
        population(tables, model="bayes")


def test_a_plug_in_with_a_builtin_s_name_is_said_and_skipped(tmp_path, monkeypatch, caplog):
    install(tmp_path, monkeypatch, "mylab_bad", "class Mixed:\n    name = 'mixed'\n"
            "    min_amplitudes = 2\n    def fit(self, cells, notes):\n        return None\n"
            "    def far(self, fit, cells, alpha):\n        return []\n",
            entry_points={"evtribo.population_models": {"mixed": "mylab_bad:Mixed"}})
    with caplog.at_level(logging.WARNING, logger="evtribo.util.plugins"):
        assert list(MODELS) == ["mixed", "meta-analysis"]
    assert "population model 'mixed' is registered already" in caplog.text
