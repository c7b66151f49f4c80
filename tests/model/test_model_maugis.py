"""Maugis-Dugdale: the equations are satisfied, and the JKR/DMT limits and pull-off forces
come out of the general solution (checked against the independent closed forms)."""

import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo import model
from evtribo.model import TABLE_1

LOADS = np.array([-1.2, -0.5, 0.0, 1.0, 10.0, 1e3, 1e5])


def _residuals(load, lam, big_a, m):
    """Maugis' two equations, evaluated at the solution (both should be 0)."""
    s = math.sqrt(m * m - 1.0)
    at = math.atan(s)
    eq1 = (lam * big_a**2 / 2 * (s + (m * m - 2) * at)
           + 4 * lam**2 * big_a / 3 * (s * at - m + 1) - 1.0)
    eq2 = big_a**3 - lam * big_a**2 * (s + m * m * at) - load
    return eq1, eq2 / max(1.0, abs(load))


@settings(max_examples=60, deadline=None)
@given(lam=st.floats(1e-3, 1e3), load=st.floats(-1.49, 1e6))
def test_solution_satisfies_maugis_equations(lam, load):
    big_a, m = model.md_dimensionless(load, lam)
    assert np.isfinite(big_a) and big_a > 0 and m >= 1
    eq1, eq2 = _residuals(load, lam, float(big_a), float(m))
    # s = sqrt(m^2 - 1) recomputed from the rounded m carries a relative error ~ eps/(m^2 - 1)
    tol = 1e-8 + 4e-16 / (m * m - 1.0)
    assert abs(eq1) < tol and abs(eq2) < tol


def test_jkr_limit_for_large_lambda():
    big_a, m = model.md_dimensionless(LOADS, 1e3)
    jkr = LOADS + 3 + np.sqrt(6 * LOADS + 9)  # A^3 of JKR in Maugis' units
    assert np.allclose(big_a**3, jkr, rtol=1e-5)
    assert np.all(m - 1 < 1e-5)  # the cohesive zone vanishes


def test_dmt_limit_for_small_lambda():
    big_a, m = model.md_dimensionless(LOADS, 1e-4)
    assert np.allclose(big_a**3, LOADS + 2, rtol=1e-3, atol=1e-3)
    assert np.all(m[LOADS <= 10] > 5)  # the cohesive zone is much wider than the contact


def test_pulloff_limits_and_monotone_transition():
    lam = np.array([1e-4, 1e-2, 0.1, 0.5, 1.0, 2.0, 5.0, 1e2, 1e4])
    po = model.md_pulloff_load(lam)
    assert po[0] == pytest.approx(-2.0, abs=1e-4)   # DMT: -2 pi dg R
    assert po[-1] == pytest.approx(-1.5, abs=1e-6)  # JKR: -(3/2) pi dg R
    assert np.all(np.diff(po) > 0)
    # below the pull-off load there is no contact
    assert np.isnan(model.md_dimensionless(po[4] - 1e-6, lam[4])[0])
    assert np.isfinite(model.md_dimensionless(po[4] + 1e-6, lam[4])[0])


def test_dimensional_pulloff_forces():
    """Pull-off in newtons: -(3/2) pi dg R at a huge voltage (JKR), -2 pi dg R at a tiny one."""
    for u, factor in ((1e5, 1.5), (1e-3, 2.0)):
        dg = model.surface_energy(u)
        f_po = -factor * np.pi * dg * TABLE_1.R
        lam = model.maugis_parameter(u)
        assert model.md_pulloff_load(lam) * np.pi * dg * TABLE_1.R == pytest.approx(
            f_po, rel=1e-4)
        assert np.isnan(model.maugis_dugdale(f_po * 1.01, u).a)
        assert np.isfinite(model.maugis_dugdale(f_po * 0.99, u).a)


def test_dimensional_jkr_limit_matches_eq3():
    f = np.array([0.01, 0.5, 2.0])
    u = 1e5  # lambda ~ 1.5e4
    assert model.maugis_parameter(u) > 1e4
    md = model.maugis_dugdale(f, u)
    assert np.allclose(md.a, model.contact_radius_jkr(f, u), rtol=1e-6)
    assert np.allclose(model.electrostatic_force_md(f, u), model.electrostatic_force(f, u),
                       rtol=1e-5)


def test_without_voltage_md_is_hertz():
    f = np.array([0.1, 1.0])
    md = model.maugis_dugdale(f, 0.0)
    assert np.array_equal(md.a, model.contact_radius_hertz(f)) and np.array_equal(md.c, md.a)
    assert np.all(md.lam == 0)
    assert np.allclose(model.friction_force_md(f, 0.0), TABLE_1.mu * f)


def test_maugis_parameter_definition_and_scaling():
    u = np.array([10.0, 140.0])
    sigma0, dg = model.adhesion_stress(u), model.surface_energy(u)
    k = 4 * TABLE_1.E_star / 3
    lam = 2 * sigma0 * (TABLE_1.R / (np.pi * dg * k**2)) ** (1 / 3)
    assert np.allclose(model.maugis_parameter(u), lam, rtol=1e-12)
    # dg / sigma_0 is a constant gap, so lambda grows as U^(4/3)
    slope = np.log(lam[1] / lam[0]) / np.log(u[1] / u[0])
    assert slope == pytest.approx(4 / 3, rel=1e-9)


def test_departure_from_jkr_at_table_1_is_small_but_real():
    """For Table 1 the cohesive zone adds about 1 % at 0.5 N and 140 V; less at 2 N."""
    dep = model.md_jkr_departure(np.array([0.1, 0.5, 2.0]), 140.0)
    assert np.all(dep > 0) and np.all(dep < 0.05)
    assert dep[0] > dep[1] > dep[2]
    assert model.md_jkr_departure(0.5, 0.0) == 0.0
    # eq. (1) with Maugis' b exceeds eq. (5) with b = a
    assert model.friction_force_md(0.5, 140.0) > model.friction_force(0.5, 140.0)


def test_broadcasting_shapes():
    md = model.maugis_dugdale(np.linspace(0.1, 1, 4)[:, None], np.array([60.0, 140.0]))
    assert md.a.shape == md.c.shape == md.lam.shape == (4, 2)
    assert np.all(md.c >= md.a)


def test_documented_lambda_table_is_current():
    """The lambda-versus-voltage table in the module's docstring matches the code."""
    from evtribo.model import maugis

    lines = maugis.__doc__.splitlines()
    volts = [float(v) for v in next(ln for ln in lines if ln.startswith("U (V)")).split()[2:]]
    lams = [float(v) for v in next(ln for ln in lines if re.match(r"lambda\s+\d", ln)).split()[1:]]
    assert len(volts) == len(lams) == 6
    assert np.allclose(model.maugis_parameter(np.array(volts)), lams, atol=6e-4)


@settings(deadline=None, max_examples=200)
@given(lam=st.lists(st.floats(0.005, 80.0), min_size=1, max_size=40),
       offset=st.floats(-0.01, 1e5), seed=st.integers(0, 99))
def test_the_vectorised_solver_is_the_point_by_point_one(lam, offset, seed):
    """Every point solved in lockstep agrees with the scalar root search to 1e-9, below
    the pull-off (NaN) and near it included. Within 1e-6 of the pull-off load the problem
    itself is ill-conditioned (dA/dP is infinite at the pull-off: an error of P's rounding
    becomes an error of x = ln s of order its square root), so there the tolerance grows
    as 1e-9 sqrt(1e-6 / (P - P_po))."""
    from evtribo.model import maugis

    lam_a = np.asarray(lam)
    rng = np.random.default_rng(seed)
    pull = np.array([maugis._pulloff(float(v))[1] for v in lam_a])
    above = offset * rng.uniform(0.0, 1.0, lam_a.size)
    load = pull + above
    a_v, m_v = maugis.md_dimensionless(load, lam_a)
    ref = np.array([maugis._solve(float(p), float(v)) for p, v in zip(load, lam_a,
                                                                      strict=True)])
    np.testing.assert_array_equal(np.isnan(np.atleast_1d(a_v)), np.isnan(ref[:, 0]))
    with np.errstate(divide="ignore"):
        rtol = 1e-9 * np.maximum(1.0, np.sqrt(1e-6 / np.maximum(above, 1e-300)))
    ok = ~np.isnan(ref[:, 0])
    for got, want in ((a_v, ref[:, 0]), (m_v, ref[:, 1])):
        err = np.abs(np.atleast_1d(got)[ok] / want[ok] - 1.0)
        assert np.all(err <= rtol[ok]), (err.max(), rtol[ok][err.argmax()])


def test_the_vectorised_solver_matches_on_a_realistic_sweep():
    """10,000 points of 0.1-2 N at 10-200 V (every point its own lambda): the lockstep
    solution is the point-by-point one to 1e-9 (measured: 1.5e-13)."""
    from evtribo.model import maugis

    rng = np.random.default_rng(0)
    force, voltage = rng.uniform(0.1, 2.0, 10_000), rng.uniform(10.0, 200.0, 10_000)
    lam = np.asarray(model.maugis_parameter(voltage))
    load = force / (np.pi * np.asarray(model.surface_energy(voltage)) * TABLE_1.R)
    a_v, m_v = maugis.md_dimensionless(load, lam)
    pick = rng.choice(10_000, 300, replace=False)
    ref = np.array([maugis._solve(float(load[i]), float(lam[i])) for i in pick])
    np.testing.assert_allclose(a_v[pick], ref[:, 0], rtol=1e-9)
    np.testing.assert_allclose(m_v[pick], ref[:, 1], rtol=1e-9)
