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

sys.path.insert(0, str(Path(__file__).parent))

from evtribo.fit.tables import ResultTables
from evtribo.population.estimates import CONTRAST_COLUMNS, POPULATION_COLUMNS, population
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


def _rows(pop, quantity: str) -> pd.DataFrame:
    return pop.table[pop.table["quantity"] == quantity]


def test_population_csv_has_the_columns_and_rows_of_the_spec():
    tables, truth = hierarchical_tables(np.random.default_rng(3), 6)
    pop = population(tables)
    assert tuple(pop.table.columns) == POPULATION_COLUMNS
    assert tuple(pop.contrasts.columns) == CONTRAST_COLUMNS
    assert list(pop.table["quantity"]) == ["electrostatic_force_N"] * 5 + [
        "exponent", "prefactor_N", "mu"]
    forces = _rows(pop, "electrostatic_force_N")
    assert (forces["waveform"] == "square").all() and (forces["frequency_Hz"] == 1e4).all()
    assert _rows(pop, "exponent")["amplitude_V"].isna().all()
    mu = _rows(pop, "mu").iloc[0]
    assert mu["waveform"] == "" and math.isnan(mu["frequency_Hz"])
    assert mu["ci_low"] < truth.mu < mu["ci_high"]
    assert (pop.table["n_subjects"] == 6).all()
    assert pop.table["method"].str.contains("REML").sum() == 2  # exponent and prefactor
    # the prefactor is the population's line at 1 V
    n = _rows(pop, "exponent").iloc[0]["estimate"]
    k = _rows(pop, "prefactor_N").iloc[0]["estimate"]
    f100 = pop.lines[("square", 1e4)].at(math.log(100.0)).value
    assert math.log(k) + n * math.log(100.0) == pytest.approx(f100, rel=1e-9)
    text = pop.files()
    assert set(text) == {"population.csv", "population_contrasts.csv"}
    assert text["population.csv"].splitlines()[0] == ",".join(POPULATION_COLUMNS)


def test_fewer_than_three_subjects_no_rows_and_why():
    tables, _ = hierarchical_tables(np.random.default_rng(3), 6)
    pop = population(_only(tables, ["S01", "S02"]))
    assert pop.table.empty and pop.contrasts.empty
    assert pop.files() == {}
    assert pop.notes[0].startswith("2 subject(s) with electrostatic forces: a population "
                                   "estimate needs at least 3")


def test_missing_amplitudes_still_contribute():
    """S01 measured at 100 V only: it counts at 100 V and nowhere else; S02 without 140 V:
    it counts everywhere it was measured, the power law included."""
    tables, _ = hierarchical_tables(
        np.random.default_rng(8), 6,
        drop=lambda i, a: (i == 0 and a != 100.0) or (i == 1 and a == 140.0))
    pop = population(tables)
    n_at = dict(zip(_rows(pop, "electrostatic_force_N")["amplitude_V"],
                    _rows(pop, "electrostatic_force_N")["n_subjects"], strict=True))
    assert n_at == {60.0: 5, 80.0: 5, 100.0: 6, 120.0: 5, 140.0: 4}
    assert _rows(pop, "exponent").iloc[0]["n_subjects"] == 5
    assert set(pop.lines[("square", 1e4)].subjects) == {"S02", "S03", "S04", "S05", "S06"}


def test_a_force_without_a_logarithm_is_left_out_and_named():
    tables, _ = hierarchical_tables(np.random.default_rng(9), 5)
    es = tables.electrostatic
    hit = (es["subject"] == "S04") & (es["amplitude_V"] == 60.0)
    es.loc[hit, "electrostatic_force_N"] = -0.002
    pop = population(tables)
    assert _rows(pop, "electrostatic_force_N").iloc[0]["n_subjects"] == 4
    assert any(n.startswith("S04, square 10000 Hz, 60 V: F_el not positive") for n in pop.notes)


def test_one_subject_far_off_is_named_and_left_out():
    """Subjects whose forces spread by a factor of 1.35 (one SD of log F) and one subject
    at twelve times the population's typical force (eight SDs): named, left out, and the
    population's estimates are those of the others."""
    tables, truth = hierarchical_tables(np.random.default_rng(12), 8, sd_log_f=0.3)
    rest = population(_only(tables, [f"S{i:02d}" for i in range(1, 9) if i != 3]))
    _scale(tables, "S03", math.exp(math.log(0.1) + 2.5 - truth.subjects["S03"]["log_f100"]))
    pop = population(tables)
    assert {o.subject for o in pop.outliers if "square" in o.quantity} == {"S03"}
    assert pop.left_out == {("square", 1e4): {"S03"}}
    assert "F_el of its power law at 95.8 V, square 10000 Hz" in {
        o.quantity for o in pop.outliers}
    for q in ("electrostatic_force_N", "exponent", "prefactor_N"):
        got, ref = _rows(pop, q), _rows(rest, q)
        np.testing.assert_allclose(got["estimate"], ref["estimate"], rtol=1e-6)
        np.testing.assert_allclose(got["ci_high"], ref["ci_high"], rtol=1e-6)
        assert (got["n_subjects"] == 7).all()
        assert got["method"].str.contains("left out as outliers: S03").all()
    text = next(o for o in pop.outliers if o.subject == "S03").describe()
    assert text.startswith("S03: F_el of its power law at 95.8 V") and " mN" in text


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


def test_one_amplitude_only_gives_forces_and_says_why_no_power_law():
    """Every subject measured at 100 V only: the force at 100 V, no exponent, and why."""
    tables, _ = hierarchical_tables(np.random.default_rng(16), 5)
    keep = tables.electrostatic["amplitude_V"] == 100.0
    one = dataclasses.replace(
        tables, electrostatic=tables.electrostatic[keep].reset_index(drop=True),
        bootstrap=tables.bootstrap[tables.bootstrap["amplitude_V"] == 100.0])
    pop = population(one)
    forces = _rows(pop, "electrostatic_force_N")
    assert list(forces["amplitude_V"]) == [100.0] and forces.iloc[0]["n_subjects"] == 5
    assert _rows(pop, "exponent").empty and _rows(pop, "prefactor_N").empty
    assert "square 10000 Hz: one amplitude only, no power law" in pop.notes


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
    assert pop.notes[0].startswith("0 subject(s) with electrostatic forces")
    two = population(_only(off, ["S01", "S02"]))
    assert two.table.empty and two.files() == {}
    assert "friction coefficient mu: 2 subject(s) to pool; a population estimate needs at " \
        "least 3" in two.notes
