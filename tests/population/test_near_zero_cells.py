"""A study whose lowest amplitude gives forces near zero or below it (1 V beside 140 V):
``compare`` and ``report`` run through, every number they write is a number or absent
(never infinite), and what a fit could not use is said."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

sys.path.insert(0, str(Path(__file__).parents[1]))

from evtribo.cli import main
from evtribo.population.estimates import population
from population_cells import cell_study


@pytest.fixture(scope="module")
def near_zero(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Three simulated subjects at 1 V and 140 V, analysed."""
    base = tmp_path_factory.mktemp("near-zero")
    study, out = base / "study", base / "out"
    assert main(["simulate", "--study", str(study), "--subjects", "3", "--amplitudes",
                 "1,140"]) == 0
    assert main(["analyze", str(study), "--out", str(out), "--jobs", "2"]) == 0
    return out


def _numbers(table: pd.DataFrame) -> pd.DataFrame:
    return table.select_dtypes("number")


def test_the_study_has_cells_at_or_below_zero(near_zero):
    es = pd.read_csv(near_zero / "electrostatic.csv")
    low = es[es["amplitude_V"] == 1.0]
    assert (low["electrostatic_force_ci_low_N"] <= 0).sum() >= 2


def test_compare_and_report_run_and_write_no_infinite_number(near_zero, capsys):
    assert main(["compare", str(near_zero), "--dpi", "40", "--no-trial-checks"]) == 0, \
        capsys.readouterr().err
    assert main(["report", str(near_zero)]) == 0, capsys.readouterr().err
    for name in ("population.csv", "fit.csv", "population_subjects.csv"):
        table = pd.read_csv(near_zero / name)
        values = _numbers(table).to_numpy(float)
        assert not (values[~pd.isna(values)] == math.inf).any(), name
        assert not (values[~pd.isna(values)] == -math.inf).any(), name
    pop = pd.read_csv(near_zero / "population.csv", keep_default_na=False, na_values=[""])
    primary = pop[pop["analysis"] == "primary"]
    # an end of an interval the data do not bound is absent, and the checks say why
    absent = primary[primary[["ci_low", "ci_high"]].isna().any(axis=1)]
    assert all(c and c != "ok" for c in absent["checks"].fillna("")), absent


@settings(max_examples=8)
@given(seed=st.integers(0, 2**32 - 1), log10_f100=st.floats(-9.0, -2.0),
       amplitudes=st.sampled_from([(1.0, 140.0), (1.0, 2.0), (1.0, 2.0, 140.0),
                                   (1.0, 60.0, 140.0)]),
       k=st.integers(3, 5))
def test_population_of_cells_near_zero_is_a_number_or_absent(seed, log10_f100, amplitudes, k):
    """Whatever the cells (forces far below their errors, negative ones, a power law no
    amplitude determines), the population's rows hold numbers or nothing, and a row whose
    interval is absent says why in its checks."""
    tables, _ = cell_study(np.random.default_rng(seed), k, error_N=2e-3,
                           f100=10.0**log10_f100, amplitudes=amplitudes, replicates=40)
    pop = population(tables)
    values = pop.table.select_dtypes("number").to_numpy(float)
    assert not np.isinf(values).any()
    primary = pop.table[(pop.table["analysis"] == "primary")
                        & (pop.table["quantity"] != "mu")]
    for _, row in primary[primary[["ci_low", "ci_high"]].isna().any(axis=1)].iterrows():
        assert row["checks"] and row["checks"] != "ok", row
