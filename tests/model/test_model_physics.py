"""The capacitor, the contact and the friction against the paper's statements and
independent calculations (numerical derivatives and integrals, textbook JKR form)."""

import numpy as np
import pytest
from scipy import integrate

from evtribo import model
from evtribo.model import TABLE_1


# ---------------------------------------------------------------- electrostatics (eqs. 6-10)
def test_attraction_is_minus_half_u2_dc_dh():
    area, u, h, dh = 1e-4, 140.0, TABLE_1.h_L, 1e-10
    dc_dh = (model.capacitance(area, h_L=h + dh) - model.capacitance(area, h_L=h - dh)) / (2 * dh)
    assert model.attraction_force(area, u) == pytest.approx(-0.5 * u**2 * dc_dh, rel=1e-6)
    assert model.adhesion_stress(u) == pytest.approx(model.attraction_force(area, u) / area)


def test_capacitance_is_series_of_three_layers():
    p = TABLE_1
    layers = [p.eps_0 * p.eps_sc / p.h_sc, p.eps_0 * p.eps_L / p.h_L, p.eps_0 * p.eps_i / p.h_i]
    per_area = 1.0 / sum(1.0 / c for c in layers)
    assert model.capacitance(2e-4) == pytest.approx(2e-4 * per_area, rel=1e-12)


@pytest.mark.parametrize("u", [60.0, 140.0])
def test_surface_energy_is_work_of_separation(u):
    def sigma(h_um):  # integrate over micrometres: quad dislikes a 1e-6 scale
        return model.adhesion_stress(u, h_L=h_um * 1e-6) * 1e-6
    work, _ = integrate.quad(sigma, TABLE_1.h_L * 1e6, np.inf, epsrel=1e-10)
    assert model.surface_energy(u) == pytest.approx(work, rel=1e-7)
    # the Dugdale range dg / sigma_0 does not depend on the voltage
    assert model.surface_energy(u) / model.adhesion_stress(u) == pytest.approx(
        model.dugdale_range())


def test_square_law_of_stress_and_energy():
    u = np.array([30.0, 60.0, 120.0])
    for fn in (model.adhesion_stress, model.surface_energy):
        v = fn(u)
        assert v[1] / v[0] == pytest.approx(4.0) and v[2] / v[1] == pytest.approx(4.0)
        assert fn(-u[0]) == fn(u[0])


def test_effective_modulus():
    assert model.effective_modulus_soft(30e3, 0.5) == pytest.approx(40e3)
    assert model.effective_modulus(1e5, 0.3, 1e5, 0.3) == pytest.approx(1e5 / (2 * 0.91))
    assert model.effective_modulus(30e3, 0.5, 1e9, 0.25) < 40e3
    with pytest.raises(ValueError, match="moduli"):
        model.effective_modulus(0.0, 0.3)
    with pytest.raises(ValueError, match="Poisson"):
        model.effective_modulus(1e5, 0.7)


# ---------------------------------------------------------------- contact (eq. 3)
def test_jkr_reduces_to_hertz_without_surface_energy():
    f = np.logspace(-3, 1, 9)
    assert np.allclose(model.contact_area_jkr(f, 0.0), model.contact_area_hertz(f), rtol=1e-12)
    assert np.allclose(model.jkr_radius(f, 0.0, 0.01, 4e4), model.hertz_radius(f, 0.01, 4e4))
    assert np.allclose(model.area_increase_pct(f, 0.0), 0.0, atol=1e-9)


def test_eq3_equals_textbook_jkr():
    f, dg, r, e = np.array([-5e-4, 0.0, 0.1, 2.0]), 0.02, 0.01, 4e4
    k = 4 * e / 3
    w = 3 * np.pi * dg * r
    a3 = r / k * (f + w + np.sqrt(2 * w * f + w**2))
    assert np.allclose(model.jkr_radius(f, dg, r, e) ** 3, a3, rtol=1e-12)


def test_jkr_and_dmt_pulloff():
    dg, r, e = 0.02, 0.01, 4e4
    f_jkr, f_dmt = model.jkr_pulloff_force(dg, r), model.dmt_pulloff_force(dg, r)
    assert f_jkr == pytest.approx(-1.5 * np.pi * dg * r)
    assert np.isfinite(model.jkr_radius(f_jkr, dg, r, e))
    assert np.isnan(model.jkr_radius(f_jkr * 1.001, dg, r, e))
    assert model.dmt_radius(f_dmt, dg, r, e) == 0.0
    assert np.isnan(model.dmt_radius(f_dmt * 1.001, dg, r, e))
    assert np.isnan(model.hertz_radius(-1e-3, r, e))


def test_figure_7_statements():
    """≈13 % more area at 0.1 N and 150 V; ≈3 %, 'neglectable', at 2 N and 150 V."""
    pct = model.area_increase_pct(np.array([0.1, 0.5, 2.0]), 150.0)
    assert pct[0] == pytest.approx(13.0, abs=0.5)
    assert pct[2] == pytest.approx(3.0, abs=0.5)
    assert pct[0] > pct[1] > pct[2] > 0
    # and it grows monotonically with the voltage
    assert np.all(np.diff(model.area_increase_pct(0.1, np.linspace(0, 150, 31))) > 0)


def test_figure_3_example_fifty_percent_radius():
    """The paper's example: F_ext = 3 pi R dg gives a contact radius "about 50 %" larger
    (exactly ((6 + sqrt(27)) / 3)^(1/3) - 1 = 55 %)."""
    dg = model.surface_energy(140.0)
    f = 3 * np.pi * TABLE_1.R * dg
    ratio = model.contact_radius_jkr(f, 140.0) / model.contact_radius_hertz(f)
    assert 1.45 < ratio < 1.6


# ---------------------------------------------------------------- friction (eqs. 1, 2, 5, 11)
def test_eq5_is_eq2_with_jkr_radius():
    f, u = np.linspace(0.05, 2, 7), 140.0
    eq2 = model.friction_force_dugdale(f, model.contact_radius_jkr(f, u), u)
    assert np.allclose(model.friction_force(f, u), eq2, rtol=1e-12)
    assert np.allclose(model.friction_force(f, 0.0), TABLE_1.mu * f)
    f_el = model.electrostatic_force(f, u)
    assert np.allclose(model.friction_force(f, u), TABLE_1.mu * (f + f_el))


def test_on_greater_than_off():
    f = np.linspace(0.01, 2, 20)
    assert np.all(model.friction_force(f, 140.0) > model.friction_force(f, 0.0))


def _log_slope(fn, f, u1, u2, params=TABLE_1):
    return np.log(fn(f, u2, params) / fn(f, u1, params)) / np.log(u2 / u1)


def test_square_law_at_table_1():
    """Local exponent of F_el between 60 V and 140 V at 0.5 N is 2 within 0.1 (eq. 13)."""
    assert model.adhesion_load_ratio(0.5, 140.0) < 0.1  # the assumption of eq. (13) holds
    assert _log_slope(model.electrostatic_force, 0.5, 60.0, 140.0) == pytest.approx(2, abs=0.1)
    u = np.linspace(60, 140, 9)
    n = model.electrostatic_force_exponent(0.5, u)
    assert np.all(np.abs(n - 2) < 0.1)


@pytest.mark.parametrize(("f", "params"), [
    (1e-9, TABLE_1),                              # vanishing external force
    (1e-3, TABLE_1.with_values(R=10.0)),          # huge fingertip radius, light load
])
def test_ten_thirds_law_when_adhesion_dominates(f, params):
    """3 pi R dg / (2 F_ext) >> 1 gives F_el ~ U^(10/3) (eq. 12)."""
    assert model.adhesion_load_ratio(f, 60.0, params) > 100
    slope = _log_slope(model.electrostatic_force, f, 60.0, 140.0, params)
    assert slope == pytest.approx(10 / 3, abs=0.02)
    limit = model.electrostatic_force_adhesive_limit(f, 100.0, params)
    assert model.electrostatic_force(f, 100.0, params) == pytest.approx(limit, rel=0.05)


def test_load_limit_asymptote():
    """F_el approaches sigma_0 A_Hertz as 3 pi R dg / (2 F_ext) -> 0, as its square root."""
    f = np.array([1.0, 100.0, 1e4])
    rel = model.electrostatic_force(f, 60.0) / model.electrostatic_force_load_limit(f, 60.0) - 1
    ratio = model.adhesion_load_ratio(f, 60.0)
    assert np.all(rel > 0) and rel[-1] < 1e-3
    assert np.allclose(rel / np.sqrt(ratio), rel[-1] / np.sqrt(ratio[-1]), rtol=0.05)


def test_closed_form_exponent_matches_numerical_derivative():
    f = np.array([1e-6, 1e-3, 0.1, 0.5, 2.0])
    u, du = 100.0, 1e-3
    numeric = _log_slope(model.electrostatic_force, f, u - du, u + du)
    assert np.allclose(model.electrostatic_force_exponent(f, u), numeric, atol=1e-6)


# ---------------------------------------------------------------- time domain (Figure 5)
def _dominant_frequency(t, x):
    spec = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(len(x))))
    return np.fft.rfftfreq(len(x), t[1] - t[0])[np.argmax(spec)]


def test_sine_friction_oscillates_at_twice_the_drive():
    t = np.arange(0, 2.0, 1 / 2000)
    u = model.sine_voltage(t, 140.0, 10.0)
    assert _dominant_frequency(t, u) == pytest.approx(10.0, abs=0.5)
    fr = model.friction_time_series(t, 0.5, u)
    assert _dominant_frequency(t, fr) == pytest.approx(20.0, abs=0.5)
    # maximal at each extremum of U, OFF level at each zero crossing
    assert fr.max() == pytest.approx(model.friction_force(0.5, 140.0), rel=1e-4)
    assert fr.min() == pytest.approx(model.friction_force(0.5, 0.0), rel=1e-3)


def test_square_wave_friction_is_steady():
    t = np.linspace(0, 1e-3, 1001)
    u = model.square_voltage(t, 140.0, 10e3)
    assert set(np.unique(u)) == {-140.0, 140.0}
    fr = model.friction_time_series(t, 0.5, u)
    assert np.ptp(fr) == 0.0 and fr[0] == model.friction_force(0.5, 140.0)


def test_time_series_accepts_callables_and_varying_load():
    t = np.linspace(0, 0.2, 401)
    load = 0.5 + 0.1 * np.sin(2 * np.pi * 2 * t)
    a = model.friction_time_series(t, load, lambda tt: model.sine_voltage(tt, 140, 10))
    b = model.friction_time_series(t, load, model.sine_voltage(t, 140, 10))
    assert a.shape == t.shape and np.array_equal(a, b)
    assert np.allclose(model.friction_time_series(t, load, 0.0), TABLE_1.mu * load)
    with pytest.raises(ValueError, match="voltage"):
        model.friction_time_series(t, 0.5, np.zeros(3))


def test_area_increase_is_ratio_of_areas():
    f, u = np.array([0.01, 0.1, 2.0]), np.array([[30.0], [150.0]])
    direct = 100 * (model.contact_area_jkr(f, u) / model.contact_area_hertz(f) - 1)
    assert np.allclose(model.area_increase_pct(f, u), direct, rtol=1e-10)
