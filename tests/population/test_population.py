"""From subjects to the population (study format §10): population.csv's rows, missing data,
outliers, contrasts, and too few subjects."""

from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st

sys.path.insert(0, str(Path(__file__).parent))

from evtribo.fit.tables import ResultTables
from evtribo.population.estimates import CONTRAST_COLUMNS, POPULATION_COLUMNS, population
from evtribo.population.per_subject import HOLM_ALPHA, holm
from population_sim import hierarchical_tables


def _only(tables: ResultTables, keep: list[str]) -> ResultTables:
    def sel(df: pd.DataFrame) -> pd.DataFrame:
        return df[df["subject"].isin(keep)].reset_index(drop=True)

    return dataclasses.replace(tables, electrostatic=sel(tables.electrostatic),
                               windows=sel(tables.windows), bootstrap=sel(tables.bootstrap))


def _scale(tables: ResultTables, subject: str, factor: float) -> None:
    """Multiply a subject's forces (and their intervals and replicates) by *factor*."""
    es = tables.electrostatic
    cols = ["electrostatic_force_N", "electrostatic_force_ci_low_N",
            "electrostatic_force_ci_high_N"]
    es.loc[es["subject"] == subject, cols] *= factor
    boot = tables.bootstrap
    boot.loc[boot["subject"] == subject, "electrostatic_force_N"] *= factor


def _rows(pop, quantity: str, analysis: str = "primary") -> pd.DataFrame:
    t = pop.table
    return t[(t["quantity"] == quantity) & (t["analysis"] == analysis)]


def test_population_csv_has_the_columns_and_rows_of_the_spec():
    tables, truth = hierarchical_tables(np.random.default_rng(3), 6)
    pop = population(tables)
    assert tuple(pop.table.columns) == POPULATION_COLUMNS
    assert tuple(pop.contrasts.columns) == CONTRAST_COLUMNS
    assert list(pop.primary["quantity"]) == ["electrostatic_force_N"] * 5 + [
        "exponent", "prefactor_N"] + ["friction_increase_pct"] * 5 + ["mu"]
    forces = _rows(pop, "electrostatic_force_N")
    assert (forces["waveform"] == "square").all() and (forces["frequency_Hz"] == 1e4).all()
    assert forces["method"].str.startswith("nonlinear mixed model on the linear scale").all()
    assert _rows(pop, "exponent")["amplitude_V"].isna().all()
    mu = _rows(pop, "mu").iloc[0]
    assert mu["waveform"] == "" and math.isnan(mu["frequency_Hz"])
    assert mu["ci_low"] < truth.mu < mu["ci_high"]
    assert (pop.primary["n_subjects"] == 6).all()
    assert set(pop.table["analysis"]) <= {"primary", "meta-analysis"}
    # the prefactor is the population's line at 1 V
    n = _rows(pop, "exponent").iloc[0]["estimate"]
    k = _rows(pop, "prefactor_N").iloc[0]["estimate"]
    f100 = pop.lines[("square", 1e4)].at(math.log(100.0)).value
    assert math.log(k) + n * math.log(100.0) == pytest.approx(f100, rel=1e-9)
    # the journals' columns: prediction interval, tau's interval, I^2 and the checks
    for _, r in pop.primary[pop.primary["quantity"] != "prefactor_N"].iterrows():
        assert r["pi_low"] < r["ci_low"] <= r["estimate"] <= r["ci_high"] < r["pi_high"]
        assert r["between_sd_low"] <= r["between_subject_sd"] <= r["between_sd_high"]
        assert 0.0 <= r["i2_low"] <= r["i2"] <= r["i2_high"] <= 1.0
    assert _rows(pop, "exponent").iloc[0]["checks"] == "ok (3 optimisers agree)"
    text = pop.files()
    assert set(text) == {"population.csv", "population_contrasts.csv",
                         "population_subjects.csv"}
    assert text["population.csv"].splitlines()[0] == ",".join(POPULATION_COLUMNS)


def test_fewer_than_three_subjects_no_rows_and_why():
    tables, _ = hierarchical_tables(np.random.default_rng(3), 6)
    pop = population(_only(tables, ["S01", "S02"]))
    assert pop.table.empty and pop.contrasts.empty
    assert pop.files() == {}
    assert pop.notes[0].kind == "population-too-few" and pop.notes[0].effect == "number"
    assert pop.notes[0].text.startswith("2 subject(s) with electrostatic forces: a "
                                        "population estimate needs at least 3")


def test_missing_amplitudes_still_contribute():
    """S01 measured at 100 V only, S02 without 140 V: every subject is in the mixed model,
    which counts each cell it has."""
    tables, _ = hierarchical_tables(
        np.random.default_rng(8), 6,
        drop=lambda i, a: (i == 0 and a != 100.0) or (i == 1 and a == 140.0))
    pop = population(tables)
    assert (_rows(pop, "electrostatic_force_N")["n_subjects"] == 6).all()
    assert _rows(pop, "exponent").iloc[0]["n_subjects"] == 6
    assert set(pop.lines[("square", 1e4)].subjects) == {f"S0{i}" for i in range(1, 7)}
    meta = dict(zip(_rows(pop, "electrostatic_force_N", "meta-analysis")["amplitude_V"],
                    _rows(pop, "electrostatic_force_N", "meta-analysis")["n_subjects"],
                    strict=True))
    assert all(n == (6 if a == 100.0 else 5 if a != 140.0 else 4) for a, n in meta.items())


def test_a_force_below_zero_counts_in_the_mixed_model():
    """S04's force at 60 V came out negative: it counts in the mixed model (every subject
    at every amplitude), not in the meta-analysis of log F_el at 60 V, and the notes say
    so."""
    tables, _ = hierarchical_tables(np.random.default_rng(9), 5)
    es = tables.electrostatic
    hit = (es["subject"] == "S04") & (es["amplitude_V"] == 60.0)
    es.loc[hit, "electrostatic_force_N"] = -0.002
    es.loc[hit, "electrostatic_force_ci_low_N"] = -0.004
    es.loc[hit, "electrostatic_force_ci_high_N"] = 0.0
    pop = population(tables)
    assert _rows(pop, "electrostatic_force_N").iloc[0]["n_subjects"] == 5
    assert 60.0 not in set(_rows(pop, "electrostatic_force_N", "meta-analysis")["amplitude_V"])
    [said] = [n for n in pop.notes if n.kind == "population-cell-not-positive"]
    assert said.scope.subject == "S04" and said.scope.amplitude_V == 60.0
    assert said.text.startswith("S04, square 10000 Hz, 60 V: F_el not positive (no "
                                "logarithm): counted in the mixed model")
    row = pop.subjects[(pop.subjects["subject"] == "S04")
                       & (pop.subjects["amplitude_V"] == 60.0)].iloc[0]
    assert row["friction_increase_pct"] < 0


def test_one_subject_far_off_is_named_and_kept_with_a_row_without_it():
    """Subjects whose forces spread by a factor of 1.35 (one SD of log F) and one subject
    at twelve times the population's typical force (eight SDs): named, kept in every primary
    row, and the rows "without S03" are the others' estimates."""
    tables, truth = hierarchical_tables(np.random.default_rng(12), 8, sd_log_f=0.3)
    rest = population(_only(tables, [f"S{i:02d}" for i in range(1, 9) if i != 3]))
    _scale(tables, "S03", math.exp(math.log(0.1) + 2.5 - truth.subjects["S03"]["log_f100"]))
    pop = population(tables)
    assert {o.subject for o in pop.outliers if "square" in o.quantity} == {"S03"}
    assert pop.far == {("square", 1e4): {"S03"}}
    for q in ("electrostatic_force_N", "exponent", "prefactor_N"):
        got, ref = _rows(pop, q, "without S03"), _rows(rest, q)
        np.testing.assert_allclose(got["estimate"], ref["estimate"], rtol=1e-3)
        np.testing.assert_allclose(got["ci_high"], ref["ci_high"], rtol=1e-2)
        assert (got["n_subjects"] == 7).all()
        assert (_rows(pop, q)["n_subjects"] == 8).all()
    assert (_rows(pop, "electrostatic_force_N")["estimate"].to_numpy()
            > _rows(rest, "electrostatic_force_N")["estimate"].to_numpy()).all()
    text = next(o for o in pop.outliers if o.subject == "S03").describe()
    assert text.startswith("S03: F_el of its power law at ") and " mN" in text


def test_a_subject_excluded_beforehand_is_out_and_named():
    tables, _ = hierarchical_tables(np.random.default_rng(13), 6)
    pop = population(tables, exclude={"S02": "load cell recalibrated during the session"})
    rest = population(_only(tables, ["S01", "S03", "S04", "S05", "S06"]))
    assert (pop.primary["n_subjects"] == 5).all()
    np.testing.assert_allclose(_rows(pop, "exponent")["estimate"],
                               _rows(rest, "exponent")["estimate"], rtol=1e-6)
    assert pop.excluded == {"S02": "load cell recalibrated during the session"}
    assert pop.notes[0].kind == "population-excluded" and pop.notes[0].scope.subject == "S02"
    assert pop.notes[0].text == ("S02: excluded from the population's estimates by the "
                                 "study's rule written beforehand (study.toml [population]): "
                                 "load cell recalibrated during the session")
    assert "S02" not in set(pop.subjects["subject"])
    assert pop.as_json()["excluded"] == [{"subject": "S02", "reason": "load cell "
                                          "recalibrated during the session"}]


def test_each_subject_s_test_of_a_positive_force_is_holm_corrected():
    """A responding population and one subject with no force at all: the others' tests
    reject F_el <= 0 after Holm's correction, its does not; the relative friction increase
    is F_el over the normal force ON."""
    tables, _ = hierarchical_tables(np.random.default_rng(15), 6)
    es = tables.electrostatic
    none = es["subject"] == "S05"
    noise = np.array([-0.003, 0.002, -0.001, 0.001, -0.002])  # no trend, about zero
    es.loc[none, "electrostatic_force_N"] = noise
    es.loc[none, "electrostatic_force_ci_low_N"] = noise - 0.006
    es.loc[none, "electrostatic_force_ci_high_N"] = noise + 0.006
    boot = tables.bootstrap  # its errors independent: no replicates of the new cells
    tables = dataclasses.replace(tables, bootstrap=boot[boot["subject"] != "S05"])
    pop = population(tables)
    verdict = pop.subjects.groupby("subject")["responds"].first()
    assert not verdict["S05"] and verdict.drop("S05").all()
    p = pop.subjects.groupby("subject")[["p_one_sided", "p_holm"]].first()
    assert (p["p_holm"] >= p["p_one_sided"]).all()
    row = pop.subjects.iloc[0]
    assert row["friction_increase_pct"] == pytest.approx(
        100 * row["electrostatic_force_N"] / row["normal_force_N"])


@given(st.lists(st.one_of(st.floats(min_value=0.0, max_value=1.0), st.just(math.nan),
                         st.sampled_from([0.0, 1e-300, 0.01, 0.5, 1.0])), max_size=30))
def test_holm_adjusts_as_statsmodels_does(p):
    """Holm's adjustment is statsmodels' own, number for number (NaN, ties, 0 and 1 too)."""
    from unittest import mock

    from statsmodels.stats.multitest import multipletests

    # statsmodels collects the garbage after each Holm adjustment (long, in a suite's
    # full heap); its numbers are the same without
    with mock.patch("gc.collect", return_value=0):
        expected = multipletests(np.asarray(p, float), alpha=HOLM_ALPHA, method="holm")[1]
    np.testing.assert_array_equal(holm(p), expected)


def test_contrast_between_drives_every_subject_had():
    """A sine drive at 10 Hz giving each subject half its square-wave force: the ratio's
    interval holds 0.5, the exponents' difference holds 0."""
    tables, _ = hierarchical_tables(np.random.default_rng(14), 6)
    es, boot = tables.electrostatic, tables.bootstrap
    rng = np.random.default_rng(15)
    sine = es.copy()
    factor = 0.5 * np.exp(0.02 * rng.standard_normal(len(sine)))
    for c in ("electrostatic_force_N", "electrostatic_force_ci_low_N",
              "electrostatic_force_ci_high_N"):
        sine[c] *= factor
    sine["waveform"], sine["frequency_Hz"] = "sine", 10.0
    sine_boot = boot.copy()
    sine_boot["electrostatic_force_N"] *= 0.5
    sine_boot["waveform"], sine_boot["frequency_Hz"] = "sine", 10.0
    both = dataclasses.replace(tables, electrostatic=pd.concat([es, sine], ignore_index=True),
                               bootstrap=pd.concat([boot, sine_boot], ignore_index=True))
    pop = population(both)
    c = pop.contrasts.set_index("quantity")
    ratio = c.loc["electrostatic_force_N"]
    assert (ratio["condition_a"], ratio["condition_b"]) == ("square 10000 Hz", "sine 10 Hz")
    assert ratio["ci_low"] < 0.5 < ratio["ci_high"] and math.isnan(ratio["difference"])
    assert ratio["n_subjects"] == 6
    diff = c.loc["exponent"]
    assert diff["ci_low"] < 0.0 < diff["ci_high"] and math.isnan(diff["ratio"])
    assert set(_rows(pop, "exponent")["waveform"]) == {"square", "sine"}
    assert set(pop.subjects["waveform"]) == {"square", "sine"}


def test_one_amplitude_only_gives_forces_and_says_why_no_power_law():
    """Every subject measured at 100 V only: the force at 100 V (the meta-analysis, valid
    there), no exponent, and why."""
    tables, _ = hierarchical_tables(np.random.default_rng(16), 5)
    keep = tables.electrostatic["amplitude_V"] == 100.0
    one = dataclasses.replace(
        tables, electrostatic=tables.electrostatic[keep].reset_index(drop=True),
        bootstrap=tables.bootstrap[tables.bootstrap["amplitude_V"] == 100.0])
    pop = population(one)
    forces = _rows(pop, "electrostatic_force_N", "meta-analysis")
    assert list(forces["amplitude_V"]) == [100.0] and forces.iloc[0]["n_subjects"] == 5
    assert _rows(pop, "exponent").empty and _rows(pop, "prefactor_N").empty
    assert ("square 10000 Hz: one amplitude only, no power law; the force there from the "
            "meta-analysis of log F_el where it is valid") in [n.text for n in pop.notes]
    assert "population-one-amplitude" in [n.kind for n in pop.notes]


def test_contrast_between_two_drive_frequencies():
    """The same subjects at 100 Hz, each with its forces at 10 kHz times its own factor
    (the population's 0.8, spread 5 % between subjects), measured with the same errors:
    the ratio's interval holds 1/0.8, the conditions named by their frequencies."""
    tables, _ = hierarchical_tables(np.random.default_rng(17), 7)
    es, boot = tables.electrostatic, tables.bootstrap
    own = dict(zip(es["subject"].unique(), 0.8 * np.exp(
        0.05 * np.random.default_rng(18).standard_normal(7)), strict=True))
    slow = es.copy()
    for c in ("electrostatic_force_N", "electrostatic_force_ci_low_N",
              "electrostatic_force_ci_high_N"):
        slow[c] *= slow["subject"].map(own)
    slow["frequency_Hz"] = 100.0
    slow_boot = boot.assign(frequency_Hz=100.0, electrostatic_force_N=boot[
        "electrostatic_force_N"] * boot["subject"].map(own))
    pop = population(dataclasses.replace(
        tables, electrostatic=pd.concat([es, slow], ignore_index=True),
        bootstrap=pd.concat([boot, slow_boot], ignore_index=True)))
    ratio = pop.contrasts.set_index("quantity").loc["electrostatic_force_N"]
    assert (ratio["condition_a"], ratio["condition_b"]) == ("square 100 Hz",
                                                            "square 10000 Hz")
    assert ratio["ci_low"] < 1 / 0.8 < ratio["ci_high"] and ratio["n_subjects"] == 7
    assert ratio["ci_high"] / ratio["ci_low"] < 1.2  # paired within subjects: narrow


def test_a_study_of_off_trials_gets_the_population_s_mu():
    """No electrostatic force at all (OFF trials only) but five subjects' OFF windows: the
    population's mu, and its file; the notes say why nothing else."""
    tables, truth = hierarchical_tables(np.random.default_rng(19), 5)
    off = dataclasses.replace(tables, electrostatic=tables.electrostatic.iloc[:0],
                              bootstrap=tables.bootstrap.iloc[:0])
    pop = population(off)
    assert list(pop.table["quantity"]) == ["mu"] and pop.n_subjects == 0
    mu = pop.table.iloc[0]
    assert mu["n_subjects"] == 5 and mu["ci_low"] < truth.mu < mu["ci_high"]
    assert pop.table.equals(_rows(population(tables), "mu").reset_index(drop=True))
    assert set(pop.files()) == {"population.csv", "population_contrasts.csv"}
    assert pop.notes[0].text.startswith("0 subject(s) with electrostatic forces")
    two = population(_only(off, ["S01", "S02"]))
    assert two.table.empty and two.files() == {}
    assert "friction coefficient mu: 2 subject(s) to pool; a population estimate needs at " \
        "least 3" in [n.text for n in two.notes]
