"""Simulated subjects drawn from a population with known parameters."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from evtribo.acquisition.simulator import (
    SubjectParams,
    SubjectPopulation,
    population_subjects,
)
from evtribo.cli import main
from evtribo.errors import ConfigError
from evtribo.study import discover_trials


def test_subjects_follow_the_population():
    """400 subjects: μ's mean and SD, and the medians and log-SDs of h_L and F_n, those of
    the population (within four standard errors of each)."""
    pop = SubjectPopulation(mu=0.45, mu_sd=0.08, h_L=4e-6, h_L_log_sd=0.4,
                            normal_force_N=0.7, force_log_sd=0.25)
    subjects = population_subjects(400, pop, seed=3)
    assert [s.name for s in subjects[:3]] == ["P01", "P02", "P03"]
    mu = np.array([s.mu for s in subjects])
    log_h = np.log([s.h_L for s in subjects])
    log_f = np.log([s.normal_force_N for s in subjects])
    se = 1 / math.sqrt(400)
    assert abs(mu.mean() - 0.45) < 4 * 0.08 * se
    assert abs(mu.std(ddof=1) / 0.08 - 1) < 4 * se / math.sqrt(2)
    assert abs(log_h.mean() - math.log(4e-6)) < 4 * 0.4 * se
    assert abs(log_h.std(ddof=1) / 0.4 - 1) < 4 * se / math.sqrt(2)
    assert abs(log_f.mean() - math.log(0.7)) < 4 * 0.25 * se
    assert abs(log_f.std(ddof=1) / 0.25 - 1) < 4 * se / math.sqrt(2)
    assert min(mu) >= 0.05


def test_draws_are_reproducible_and_keep_the_template():
    template = SubjectParams(stroke_length_m=0.05, model={"r_g": 80.0})
    a = population_subjects(5, seed=7, template=template)
    assert a == population_subjects(5, seed=7, template=template)
    assert a != population_subjects(5, seed=8, template=template)
    assert all(s.stroke_length_m == 0.05 and s.model == {"r_g": 80.0} for s in a)
    same = population_subjects(4, SubjectPopulation(mu_sd=0.0, h_L_log_sd=0.0,
                                                    force_log_sd=0.0))
    assert {(s.mu, s.h_L, s.normal_force_N) for s in same} == {(0.5, 5e-6, 0.5)}


@pytest.mark.parametrize(("kwargs", "key"), [({"h_L_log_sd": -0.1}, "h_L_log_sd"),
                                             ({"mu": 0.0}, "mu"),
                                             ({"normal_force_N": math.nan}, "normal_force_N"),
                                             ({"force_log_sd": 5.0}, "force_log_sd")])
def test_a_bad_population_is_refused(kwargs, key):
    with pytest.raises(ConfigError) as err:
        SubjectPopulation(**kwargs)
    assert err.value.key == f"SubjectPopulation.{key}"


def test_cli_writes_a_population_study(tmp_path, capsys):
    study = tmp_path / "pop"
    code = main(["simulate", "--study", str(study), "--subjects", "3", "--amplitudes",
                 "140,60", "--duration", "2", "--ideal", "--air-gap-spread", "0.5",
                 "--seed", "4"])
    assert code == 0
    out = capsys.readouterr().out
    assert "3 subjects x 2 amplitudes (6 trials), drawn with seed 4" in out
    trials, _ = discover_trials(study)
    assert sorted((t.subject, t.name) for t in trials) == [
        (s, r) for s in ("P01", "P02", "P03") for r in ("run-01", "run-02")]
    drawn = population_subjects(3, SubjectPopulation(h_L_log_sd=0.5), seed=4)
    for s in drawn:
        side = json.loads((study / s.name / "run-02.json").read_text(encoding="utf-8"))
        assert side["amplitude_V"] == 140.0
        truth = side["simulation"]["subject"]
        assert (truth["mu"], truth["h_L"], truth["normal_force_N"]) == (
            s.mu, s.h_L, s.normal_force_N)
        assert f"{s.name} " in out and f"{s.h_L * 1e6:10.3f}" in out
