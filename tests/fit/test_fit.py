from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import quad

from evtribo.errors import ConfigError, UserInputError
from evtribo.fit.fit import fit_study, mean_electrostatic_force, model_exponent
from evtribo.fit.fit_csv import fit_table
from evtribo.fit.params import load_parameters, resolve_fit_names
from evtribo.fit.tables import read_results
from evtribo.model import TABLE_1, electrostatic_force
from synthetic import MU, TRUE_H_L, make_out


def test_fitted_air_gap_recovers_truth(out_dir):
    fits = fit_study(read_results(out_dir))
    assert [f.subject for f in fits] == list(TRUE_H_L)
    for f in fits:
        est = f["h_L"]
        truth = TRUE_H_L[f.subject]
        assert abs(est.value - truth) / truth < 0.10
        assert est.contains(truth), (est, truth)
        assert 0 < est.stderr < 0.1 * truth
        assert f.r2 > 0.95
        assert f.params.mu == pytest.approx(MU[f.subject], rel=0.05)


@pytest.mark.parametrize("seed", [2, 3, 4])
def test_air_gap_other_noise_draws(tmp_path, seed):
    fits = fit_study(read_results(make_out(tmp_path / "o", seed=seed, sine_trace=False)))
    for f in fits:
        truth = TRUE_H_L[f.subject]
        assert abs(f["h_L"].value - truth) / truth < 0.10
        assert f["h_L"].contains(truth)


def test_fit_mu_with_air_gap_uses_windows(out_dir):
    fits = fit_study(read_results(out_dir), fit=("h_L", "mu"))
    for f in fits:
        assert f["mu"].contains(MU[f.subject]) or \
            abs(f["mu"].value - MU[f.subject]) < 0.02 * MU[f.subject]
        assert abs(f["h_L"].value - TRUE_H_L[f.subject]) / TRUE_H_L[f.subject] < 0.10
        # a pair the data determine is not taken for an undetermined one
        assert math.isfinite(f["h_L"].stderr) and math.isfinite(f["mu"].stderr)


@pytest.fixture(scope="module")
def degenerate_fits(tmp_path_factory):
    """Both subjects of the synthetic folder fitted for h_L and E_star together."""
    out = make_out(tmp_path_factory.mktemp("degenerate") / "out", sine_trace=False)
    return fit_study(read_results(out), fit=("h_L", "E_star"))


def test_degenerate_pair_has_wide_interval(degenerate_fits):
    # h_L and E_star enter eq. 11 almost only through one combination: the intervals
    # must say the data do not pin them down
    for f in degenerate_fits:
        e = f["E_star"]
        assert not math.isfinite(e.stderr) or e.ci_high - e.ci_low > e.value


def test_degenerate_pair_is_undetermined_for_every_subject(degenerate_fits):
    # along the combination the data cannot see, one standard error moves each parameter
    # by more than its own value: not determined, whatever the scale the solution ended at
    # (no refits to the bootstrap replicates of an ill-posed fit)
    assert [f.subject for f in degenerate_fits] == list(TRUE_H_L)
    for f in degenerate_fits:
        assert f.interval_method == "jacobian", f.subject
        assert f.interval_note == "a parameter is not determined by the data", f.subject
        assert not math.isfinite(f["E_star"].stderr), f.subject


def test_fit_table_exponents(out_dir):
    tables = read_results(out_dir)
    table = fit_table(fit_study(tables), tables)
    assert len(table) == 2
    assert set(table["parameter"]) == {"h_L"}
    assert (table["unit"] == "m").all()
    ex = tables.exponents.set_index("subject")
    for _, row in table.iterrows():
        assert row["exponent"] == pytest.approx(ex.loc[row["subject"], "exponent"])
        assert 2.0 <= row["exponent_model"] < 2.2  # near U^2 at 0.5 N (eq. 13)


def test_model_exponent_matches_power_law():
    # independent check: the slope of the model between two amplitudes by hand
    p = TABLE_1
    f1, f2 = electrostatic_force(0.5, 60.0, p), electrostatic_force(0.5, 140.0, p)
    assert model_exponent(0.5, 60.0, 140.0, p) == pytest.approx(
        math.log(f2 / f1) / math.log(140 / 60))
    assert math.isnan(model_exponent(0.5, 100.0, 100.0, p))


def test_sine_average_against_quadrature():
    p = TABLE_1
    expected = quad(lambda phi: float(electrostatic_force(0.5, 100.0 * math.sin(phi), p)),
                    0.0, 2 * math.pi)[0] / (2 * math.pi)
    si = mean_electrostatic_force(0.5, 100.0, "sine", p)
    assert si == pytest.approx(expected, rel=1e-6)
    # with the load dominating the contact (eq. 13), F_el ~ U^2 averages to A^2/2
    big = mean_electrostatic_force(500.0, 100.0, "sine", p)
    assert big / mean_electrostatic_force(500.0, 100.0, "square", p) == pytest.approx(
        0.5, rel=1e-3)
    sq = mean_electrostatic_force(0.5, 100.0, "square", p)
    mixed = mean_electrostatic_force(np.array([0.5, 0.5]), np.array([100.0, 100.0]),
                                     np.array(["sine", "square"], dtype=object), p)
    np.testing.assert_allclose(mixed, [si, sq])


def test_resolve_fit_names():
    assert resolve_fit_names(None) == ("h_L",)
    assert resolve_fit_names("h_L, E_star,h_L") == ("h_L", "E_star")
    with pytest.raises(ConfigError, match="'foo', 'bar'"):
        resolve_fit_names("h_L,foo,bar")
    with pytest.raises(ConfigError):
        resolve_fit_names(",")


def test_load_parameters(tmp_path):
    good = tmp_path / "p.toml"
    good.write_text("E_star = 55e3\nh_sc = 250e-6\n")
    p = load_parameters(good)
    assert (p.E_star, p.h_sc, p.h_L) == (55e3, 250e-6, TABLE_1.h_L)
    nested = tmp_path / "n.toml"
    nested.write_text("[model]\nR = 0.02\n")
    assert load_parameters(nested).R == 0.02
    for text, key in (("Estar = 1\n", "Estar"), ("R = 'x'\n", "R"), ("R = -1\n", "R"),
                      ("[model]\nmu = true\n", "model.mu")):
        bad = tmp_path / "bad.toml"
        bad.write_text(text)
        with pytest.raises(ConfigError) as info:
            load_parameters(bad)
        assert info.value.key == key
        assert info.value.path == str(bad)
    broken = tmp_path / "broken.toml"
    broken.write_text("R = = 1\n")
    with pytest.raises(ConfigError, match="TOML"):
        load_parameters(broken)


def test_missing_column_names_file_and_column(out_dir):
    path = out_dir / "electrostatic.csv"
    pd.read_csv(path).drop(columns=["mu"]).to_csv(path, index=False)
    with pytest.raises(UserInputError) as info:
        read_results(out_dir)
    assert info.value.key == "mu" and info.value.path == str(path)


def test_missing_folder(tmp_path):
    with pytest.raises(UserInputError):
        read_results(tmp_path / "nope")
