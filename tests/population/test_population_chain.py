"""The population, end to end: ``simulate --subjects`` draws a population with known
parameters, ``analyze``, ``compare`` and ``report`` run on it, and the population's
estimates hold its truth; with two subjects, no estimates and the report says why."""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
import re
import sys
from html import unescape
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).parent))

import evtribo
from evtribo.acquisition.simulator import SubjectPopulation, population_subjects
from evtribo.cli import main
from evtribo.population.estimates import POPULATION_COLUMNS
from evtribo.report.compare import compare
from evtribo.report.study_report import build_report
from evtribo.results.outputs import compare_files
from evtribo.util.numbers import with_interval
from population_sim import hierarchical_tables, write_result_folder

AMPS = (60.0, 90.0, 140.0)
POPULATION = SubjectPopulation(mu=0.5, mu_sd=0.1, h_L=5e-6, h_L_log_sd=0.3,
                               normal_force_N=0.5, force_log_sd=0.3)
SEED = 5


def _section(html: str, title: str) -> str:
    """The text of the report's section *title*."""
    start = html.index(f">{title}</h2>")
    end = html.find("<h2", start)
    return re.sub(r"\s+", " ", unescape(re.sub(r"<[^>]+>", " ", html[start:end])))


@pytest.fixture(scope="module")
def chain(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """Six subjects drawn from POPULATION through the real rig simulation, analysed and
    compared by the command line; the report written."""
    base = tmp_path_factory.mktemp("population")
    study, out = base / "study", base / "out"
    assert main(["simulate", "--study", str(study), "--subjects", "6", "--amplitudes",
                 ",".join(f"{a:g}" for a in AMPS), "--duration", "10", "--seed",
                 str(SEED)]) == 0
    assert main(["analyze", str(study), "--out", str(out), "--jobs", "2"]) == 0
    assert main(["compare", str(out), "--dpi", "40", "--no-trial-checks"]) == 0
    assert main(["report", str(out), "--tables", "md"]) == 0
    return study, out


def _sample_truth(study: Path) -> tuple[dict[float, float], float]:
    """The drawn subjects' geometric-mean true F_el at each amplitude (the simulator's mean
    over each trial's ON phases, at the normal force the subject pressed with) and their
    mean power-law exponent."""
    true = {}
    for sidecar in sorted(study.glob("P*/run-*.json")):
        doc = json.loads(sidecar.read_text(encoding="utf-8"))
        true[(doc["subject"], doc["amplitude_V"])] = doc["simulation"][
            "electrostatic_force_mean_N"]
    subjects = sorted({s for s, _ in true})
    logs = np.log([[true[(s, a)] for a in AMPS] for s in subjects])
    slopes = [np.polyfit(np.log(AMPS), row, 1)[0] for row in logs]
    return dict(zip(AMPS, np.exp(logs.mean(axis=0)), strict=True)), float(np.mean(slopes))


@pytest.mark.slow
def test_population_estimates_recover_the_drawn_subjects(chain):
    """The estimates are the six drawn subjects' own (within their measurement's
    precision), and the intervals hold them. That the intervals hold the population's
    truth in 95 % of such studies is test_population_coverage's."""
    study, out = chain
    table = pd.read_csv(out / "population.csv", keep_default_na=False, na_values=[""])
    assert tuple(table.columns) == POPULATION_COLUMNS
    truth, exponent = _sample_truth(study)
    table = table[table["analysis"] == "primary"]
    forces = table[table["quantity"] == "electrostatic_force_N"]
    assert list(forces["amplitude_V"]) == list(AMPS)
    for _, r in forces.iterrows():
        assert r["estimate"] == pytest.approx(truth[r["amplitude_V"]], rel=0.05)
        assert r["ci_low"] <= truth[r["amplitude_V"]] <= r["ci_high"]
    n = table[table["quantity"] == "exponent"].iloc[0]
    assert n["estimate"] == pytest.approx(exponent, abs=0.03)
    assert n["ci_low"] <= exponent <= n["ci_high"]
    assert n["n_subjects"] == 6
    drawn = population_subjects(6, POPULATION, seed=SEED)
    gap = table[table["quantity"] == "h_L_m"].iloc[0]
    mean_gap = math.exp(np.mean(np.log([s.h_L for s in drawn])))
    assert gap["estimate"] == pytest.approx(mean_gap, rel=0.03)
    assert gap["ci_low"] <= mean_gap <= gap["ci_high"]
    mu = table[table["quantity"] == "mu"].iloc[0]
    mean_mu = float(np.mean([s.mu for s in drawn]))
    assert mu["estimate"] == pytest.approx(mean_mu, abs=0.02)
    assert mu["ci_low"] <= mean_mu <= mu["ci_high"]


@pytest.mark.slow
def test_compare_writes_the_population_and_the_report_shows_it(chain):
    _, out = chain
    doc = json.loads((out / "fit.json").read_text(encoding="utf-8"))
    assert doc["population"]["n_subjects"] == 6
    assert {"population.csv", "population_contrasts.csv",
            "population_subjects.csv"} <= set(doc["output_sha256"])
    kinds = [f for f in doc["figures"] if f["kind"] == "population"]
    assert [f["stem"] for f in kinds] == ["population_square_10000Hz"]
    assert (out / "figures" / "population_square_10000Hz.png").is_file()
    assert {"population.csv", "population_contrasts.csv",
            "figures/population_square_10000Hz.png"} <= set(compare_files(out))
    html = (out / "report.html").read_text(encoding="utf-8")
    heads = re.findall(r"<h2[^>]*>([^<]+)</h2>", html)
    assert heads.index("Population") == heads.index("Model fit") + 1
    text = _section(html, "Population")
    assert "the population's exponent n = " in text
    assert "2, the square law" in text and "10/3" in text
    assert "For a methods section" in text and "nonlinear mixed-effects model" in text
    assert "Relative friction increase" in text and "p (Holm)" in text
    methods = text[text.index("For a methods section"):]
    depth = itertools.accumulate(1 if c == "(" else -1 if c == ")" else 0 for c in methods)
    assert max(depth) <= 1, methods  # no parenthesis inside another
    md = (out / "tables" / "population.md").read_text(encoding="utf-8")
    assert "| square | 10 kHz |" in md


@pytest.mark.slow
def test_the_api_gives_the_same_population(chain):
    _, out = chain
    results = evtribo.load_results(out)
    on_disk = results.fit.population
    fit = evtribo.compare(results)
    assert list(fit.population.columns) == list(POPULATION_COLUMNS)
    pd.testing.assert_frame_equal(
        fit.population.drop(columns=["method"]).reset_index(drop=True),
        on_disk.drop(columns=["method"]).reset_index(drop=True), check_dtype=False,
        rtol=1e-9)
    assert "population_square_10000Hz" in fit.figures


def test_two_subjects_no_population_and_the_report_says_why(compared_out):
    """The synthetic study of two subjects: no population files, and the reason."""
    assert not (compared_out / "population.csv").exists()
    doc = json.loads((compared_out / "fit.json").read_text(encoding="utf-8"))
    assert doc["population"]["notes"][0].startswith("2 subject(s) with electrostatic")
    html = build_report(compared_out, compared_out.parent / "r.html").read_text("utf-8")
    assert ("No population estimates: 2 subject(s) with electrostatic forces: a population "
            "estimate needs at least 3") in _section(html, "Population")


def test_the_report_names_the_subject_far_from_the_others(tmp_path):
    """Eight subjects, one at twelve times the others' typical force: the report names it,
    keeps it in every estimate and shows them without it."""
    tables, truth = hierarchical_tables(np.random.default_rng(12), 8, sd_log_f=0.3)
    factor = math.exp(math.log(0.1) + 2.5 - truth.subjects["S03"]["log_f100"])
    es = tables.electrostatic
    cols = ["electrostatic_force_N", "electrostatic_force_ci_low_N",
            "electrostatic_force_ci_high_N"]
    es.loc[es["subject"] == "S03", cols] *= factor
    tables.bootstrap.loc[tables.bootstrap["subject"] == "S03", "electrostatic_force_N"] *= factor
    out = write_result_folder(tmp_path / "out", tables)
    compare(out, dpi=30, trial_checks=False)
    text = _section(build_report(out, tmp_path / "r.html").read_text("utf-8"), "Population")
    assert "S03 lies far from the other subjects: F_el of its power law at " in text
    assert "It is in every estimate above" in text and "without S03" in text
    table = pd.read_csv(out / "population.csv", keep_default_na=False, na_values=[""])
    square = table[table["waveform"] == "square"]
    assert (square.loc[square["analysis"] == "primary", "n_subjects"] == 8).all()
    assert (square.loc[square["analysis"] == "without S03", "n_subjects"] == 7).all()


def test_a_study_of_off_trials_reports_the_population_s_mu(tmp_path, capsys):
    """Five subjects' OFF windows and no electrostatic force: compare writes mu's row of
    population.csv and prints it, and the report's Population section follows the table
    of mu with it and a paragraph for a methods section."""
    tables, _ = hierarchical_tables(np.random.default_rng(21), 5)
    off = dataclasses.replace(tables, electrostatic=tables.electrostatic.iloc[:0],
                              bootstrap=tables.bootstrap.iloc[:0])
    out = write_result_folder(tmp_path / "out", off)
    assert main(["compare", str(out), "--dpi", "30", "--no-trial-checks"]) == 0
    table = pd.read_csv(out / "population.csv")
    assert list(table["quantity"]) == ["mu"] and table["n_subjects"].iloc[0] == 5
    mu = table.iloc[0]
    assert (f"population (5 subjects): μ = {mu['estimate']:.3g} [{mu['ci_low']:.3g}, "
            f"{mu['ci_high']:.3g}]") in capsys.readouterr().out
    html = build_report(out, tmp_path / "r.html").read_text("utf-8")
    assert html.index(">Friction coefficient</h2>") < html.index(">Population</h2>")
    text = _section(html, "Population")
    assert "The population's friction coefficient μ" in text
    assert with_interval(mu["estimate"], mu["ci_low"], mu["ci_high"]) in text, text
    assert "per-subject results of 5 subjects: the population's friction coefficient" in text
    assert "electrostatic" not in text


def test_compare_goes_on_past_a_subject_without_a_force(tmp_path, capsys):
    """S03's forces are noise about zero (some negative): compare fits the others, says
    S03's air gap is not determined (an infinite interval), leaves it out of the
    population's air gap and keeps it in the population's forces; no numpy warning (pytest
    turns any into an error)."""
    tables, _ = hierarchical_tables(np.random.default_rng(23), 5)
    es, boot = tables.electrostatic, tables.bootstrap
    rng = np.random.default_rng(24)
    none = es["subject"] == "S03"
    noise = rng.normal(0.0, 0.004, int(none.sum()))
    es.loc[none, "electrostatic_force_N"] = noise
    es.loc[none, "electrostatic_force_ci_low_N"] = noise - 0.008
    es.loc[none, "electrostatic_force_ci_high_N"] = noise + 0.008
    mine = boot["subject"] == "S03"
    at = boot.loc[mine, "amplitude_V"].map(dict(zip(es.loc[none, "amplitude_V"], noise,
                                                    strict=True)))
    boot.loc[mine, "electrostatic_force_N"] = at + rng.normal(0.0, 0.004, int(mine.sum()))
    out = write_result_folder(tmp_path / "out", tables)
    assert main(["compare", str(out), "--dpi", "30", "--no-trial-checks"]) == 0
    fit = pd.read_csv(out / "fit.csv")
    gap = fit[(fit["subject"] == "S03") & (fit["parameter"] == "h_L")].iloc[0]
    assert math.isinf(gap["ci_high"])
    assert ((fit["subject"] != "S03") & np.isfinite(fit["ci_high"])).sum() == 4
    said = capsys.readouterr().err  # compare's warnings, each kind once, on its console
    assert "S03: h_L is not determined by these data" in said
    assert "] model parameters of forces that do not differ from zero: S03\n" in said
    table = pd.read_csv(out / "population.csv", keep_default_na=False, na_values=[""])
    primary = table[table["analysis"] == "primary"]
    assert (primary.loc[primary["quantity"] == "electrostatic_force_N", "n_subjects"]
            == 5).all()
    assert primary.loc[primary["quantity"] == "h_L_m", "n_subjects"].tolist() == [4]


@pytest.mark.parametrize("subjects", [3, 6])
def test_the_population_figure_shows_the_subjects_not_the_whole_prediction_band(chain,
                                                                              subjects):
    """Every subject's point and the mean's band are inside the force axis; the prediction
    band (wide with few subjects: three give its t one degree of freedom) runs beyond it
    only with a word on the plot."""
    import dataclasses

    from evtribo.figures.population_plots import plot_population
    from evtribo.figures.style import journal_style
    from evtribo.fit.tables import read_results
    from evtribo.population.estimates import population

    _, out = chain
    tables = read_results(out)
    kept = tables.subjects[:subjects]

    def only(df):
        return None if df is None else df[df["subject"].astype(str).isin(kept)]

    tables = dataclasses.replace(
        tables, **{name: only(getattr(tables, name)) for name in
                   ("electrostatic", "windows", "exponents", "trials", "bootstrap")})
    pop = population(tables)
    condition = next(iter(pop.lines))
    with journal_style():
        ax = plot_population(tables.electrostatic, pop, condition)
    low, high = ax.get_ylim()
    forces = 1e3 * tables.electrostatic["electrostatic_force_N"].to_numpy(float)
    assert np.all((forces[forces > 0] >= low) & (forces[forces > 0] <= high))
    assert high / low < 1e3  # decades of the data, not the band of a new subject
    edges = [line.get_ydata() for line in ax.get_lines() if line.get_linewidth() == 0.6]
    assert len(edges) == 2  # the prediction band's
    beyond = any(np.nanmin(y) < low or np.nanmax(y) > high for y in edges)
    said = any("beyond the axes" in t.get_text() for t in ax.texts)
    assert said == beyond
    assert beyond == (subjects == 3)
