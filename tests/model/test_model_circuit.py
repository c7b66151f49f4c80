"""The drive's frequency (study format, section 9): the layers as a circuit, checked against
the paper's limits, nodal analysis of the same circuit, and the filtered square wave
simulated in the time domain."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal

from evtribo import model
from evtribo.cli import main
from evtribo.errors import ConfigError

P = model.TABLE_1
FREQS = np.geomspace(0.1, 1e6, 25)


def test_infinite_resistances_give_the_paper_at_every_frequency():
    np.testing.assert_allclose(model.gap_factor(FREQS, P), 1.0, atol=1e-12)
    for waveform in ("sine", "square"):
        np.testing.assert_allclose(model.effective_voltage(140.0, FREQS, waveform, P), 140.0,
                                   rtol=1e-12)
    np.testing.assert_allclose(model.electrostatic_force_drive(0.5, 140.0, FREQS, "square"),
                               model.electrostatic_force(0.5, 140.0), rtol=1e-12)
    # a sine's mean over its period, as the paper's Figure 5 force averages
    phase = (np.arange(4096) + 0.5) / 4096
    mean = np.mean(model.electrostatic_force(0.5, 140.0 * np.sin(2 * np.pi * phase)))
    np.testing.assert_allclose(model.electrostatic_force_drive(0.5, 140.0, FREQS, "sine"),
                               mean, rtol=1e-6)


@pytest.mark.parametrize("changes", [{"r_g": 50.0}, {"r_sc": 20.0}, {"r_g": 80.0, "r_sc": 5.0}])
def test_high_frequency_tends_to_the_paper(changes):
    params = P.with_values(changes)
    assert abs(model.gap_factor(1e7, params)) == pytest.approx(1.0, abs=1e-4)
    assert model.electrostatic_force_drive(0.5, 140, 1e7, "square", params) == pytest.approx(
        float(model.electrostatic_force(0.5, 140, P)), rel=1e-3)


def test_a_leak_across_the_gap_removes_the_force_and_a_conducting_skin_raises_it():
    leaky = P.with_values(r_g=1e-6)
    assert np.all(np.abs(model.gap_factor(FREQS[FREQS < 1e4], leaky)) < 1e-3)
    assert model.electrostatic_force_drive(0.5, 140, 100.0, "square", leaky) < 1e-6
    skin = P.with_values(r_sc=10.0)
    low = model.electrostatic_force_drive(0.5, 140, 5.0, "square", skin)
    assert low > 1.05 * model.electrostatic_force(0.5, 140)
    # well below its corner the stratum corneum is shorted: the gap shares the voltage
    # with the insulator only
    s_sc, s_g, s_i = model.layer_elastances(skin)
    assert abs(model.gap_factor(0.01, skin)) == pytest.approx((s_sc + s_g + s_i) / (s_g + s_i),
                                                              rel=1e-4)


@settings(deadline=None)
@given(r_g=st.floats(1.0, 1e5), r_sc=st.floats(1.0, 1e5), h_L=st.floats(1e-7, 2e-5),
       f=st.floats(0.5, 5e4))
def test_gap_factor_is_the_circuit_solved_by_nodal_analysis(r_g, r_sc, h_L, f):
    """Nodes: finger (U), A (between stratum corneum and gap), B (between gap and
    insulator), screen (0); Kirchhoff's current law at A and B, solved as a linear system."""
    params = P.with_values(r_g=r_g, r_sc=r_sc, h_L=h_L)
    w = 2 * np.pi * f
    e0 = params.eps_0
    y_sc = 1 / r_sc + 1j * w * e0 * params.eps_sc / params.h_sc
    y_g = 1 / r_g + 1j * w * e0 * params.eps_L / h_L
    y_i = 1j * w * e0 * params.eps_i / params.h_i
    u = 1.0
    lhs = np.array([[y_sc + y_g, -y_g], [-y_g, y_g + y_i]])
    rhs = np.array([y_sc * u, 0.0])
    va, vb = np.linalg.solve(lhs, rhs)
    gap_share = (va - vb) / u
    s = [params.h_sc / (e0 * params.eps_sc), h_L / (e0 * params.eps_L),
         params.h_i / (e0 * params.eps_i)]
    paper_share = s[1] / sum(s)
    h = model.gap_factor(f, params)
    assert h == pytest.approx(gap_share / paper_share, rel=1e-9)


@pytest.mark.parametrize(("r_sc", "r_g", "f"), [(np.inf, 80.0, 20.0), (np.inf, 80.0, 300.0),
                                                (20.0, np.inf, 10.0), (30.0, 200.0, 50.0)])
def test_the_square_wave_sum_is_the_filtered_square_wave_averaged(r_sc, r_g, f):
    """The mean square of the gap's voltage under a square wave, simulated in the time
    domain (scipy's lsim of the circuit's transfer function), is U_eff^2."""
    params = P.with_values(r_sc=r_sc, r_g=r_g)
    e0 = params.eps_0
    c_sc, c_g = e0 * params.eps_sc / params.h_sc, e0 * params.eps_L / params.h_L
    c_i = e0 * params.eps_i / params.h_i

    def layer(r, c):  # impedance r / (1 + s r c) as (num, den) polynomials in s
        return ([0.0, 1.0 / c], [1.0, 0.0]) if np.isinf(r) else ([r], [r * c, 1.0])

    (ns, ds), (ng, dg), (ni, di) = layer(r_sc, c_sc), layer(r_g, c_g), ([1.0 / c_i], [1.0, 0.0])
    # H_abs = z_g / (z_sc + z_g + z_i), all over the common denominator ds*dg*di
    num = np.polymul(np.polymul(ng, ds), di)
    den = np.polyadd(np.polyadd(np.polymul(np.polymul(ns, dg), di),
                                np.polymul(np.polymul(ng, ds), di)),
                     np.polymul(np.polymul(ni, ds), dg))
    system = signal.TransferFunction(num, den)
    periods, per = 60, 4000
    t = np.arange(periods * per) / (per * f)
    u = np.where(np.mod(t * f, 1.0) < 0.5, 1.0, -1.0)
    _, y, _ = signal.lsim(system, u, t)
    last = y[-10 * per:]  # steady state: the last ten periods
    paper_share = (1 / c_g) / (1 / c_sc + 1 / c_g + 1 / c_i)
    mean_square = np.mean(last**2) / paper_share**2
    u_eff = model.effective_voltage(1.0, f, "square", params)
    assert u_eff**2 == pytest.approx(mean_square, rel=2e-3)


def test_the_sine_amplitude_is_scaled_by_the_gain_at_its_frequency():
    params = P.with_values(r_g=80.0)
    for f in (5.0, 50.0, 500.0):
        assert model.effective_voltage(100.0, f, "sine", params) == pytest.approx(
            100.0 * abs(model.gap_factor(f, params)))
    gains = np.abs(model.gap_factor(FREQS, params))
    assert np.all(np.diff(gains) >= -1e-12) and gains[0] < 0.01  # a high-pass on the gap


def test_bad_values_are_refused():
    with pytest.raises(ConfigError, match="r_g"):
        P.with_values(r_g=0.0)
    with pytest.raises(ConfigError, match="r_sc"):
        P.with_values(r_sc=-float("inf"))
    assert P.with_values(r_g=float("inf")).r_g == float("inf")
    with pytest.raises(ValueError, match="frequency"):
        model.gap_factor(0.0, P)
    with pytest.raises(ValueError, match="waveform"):
        model.effective_voltage(100, 50, "triangle", P)


def test_the_command_line_evaluates_the_model_at_a_frequency(capsys):
    assert main(["model", "--voltage", "100", "--frequency", "50", "--waveform", "square",
                 "--set", "r_g=80", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    params = P.with_values(r_g=80.0)
    assert out["frequency_Hz"] == 50 and out["waveform"] == "square"
    assert out["gap_factor"] == pytest.approx(abs(model.gap_factor(50.0, params)))
    assert out["effective_voltage_V"] == pytest.approx(
        float(model.effective_voltage(100.0, 50.0, "square", params)))
    assert out["electrostatic_force_N"] == pytest.approx(
        float(model.electrostatic_force_drive(0.5, 100.0, 50.0, "square", params)))
    assert out["parameters"]["r_g"] == 80.0 and out["parameters"]["r_sc"] is None
    assert main(["model", "--voltage", "100", "--frequency", "10", "--waveform", "sine",
                 "--json"]) == 0
    sine = json.loads(capsys.readouterr().out)
    assert sine["electrostatic_force_N"] == pytest.approx(
        float(model.electrostatic_force_drive(0.5, 100.0, 10.0, "sine", P)))
    assert sine["gap_factor"] == 1.0 and sine["effective_voltage_V"] == 100.0
    assert main(["model", "--frequency", "0"]) == 2
