"""The physics of the finger on the screen, each piece as its source states it.

- The electrostatic force: the seed paper (Lubricants 2019, 7, 102), eqs. (8) sigma0, (9) Δγ,
  (3) the JKR contact area and (11) F_el = sigma0·A, with the paper's Table 1; or a power law
  k·U^n per subject.
- The friction law of a soft Hertzian finger pad, F_t = c·W^m (Adams et al., J. R. Soc.
  Interface 2013, doi:10.1098/rsif.2012.0467), with W = F_n + F_el while the voltage is on.
- The pad's pre-sliding at a reversal: Dahl's model, dF/dx = (F_slide - F)/δ.
"""

from __future__ import annotations

import numpy as np

from .config import Electrostatic

EPS0 = 8.854e-12  # F/m, the paper's value


def _series_thickness(e: Electrostatic, h_L: float) -> float:
    """h_sc/ε_sc + h_L/ε_L + h_i/ε_i, m (the bracket of eqs. 6-9)."""
    return e.h_sc_m / e.eps_sc + h_L / e.eps_L + e.h_i_m / e.eps_i


def paper_force(e: Electrostatic, h_L: float, voltage: np.ndarray,
                normal_force: np.ndarray) -> np.ndarray:
    """F_el = sigma0·A of eq. (11), N, at instantaneous voltage magnitudes and external loads.

    sigma0 from eq. (8) and Δγ from eq. (9) with the voltage's instantaneous value; the contact
    area A from eq. (3) (JKR, with F_ext the external normal force, clipped at 0).
    """
    u = np.asarray(voltage, dtype=float)
    f_ext = np.clip(np.asarray(normal_force, dtype=float), 0.0, None)
    d = _series_thickness(e, h_L)
    sigma0 = EPS0 * u**2 / (2.0 * e.eps_L) / d**2
    dgamma = EPS0 * u**2 / 2.0 / d
    adh = 9.0 * np.pi / 8.0 * dgamma / (e.E_star_Pa * e.R_m)
    ext = 0.75 * f_ext / (e.E_star_Pa * e.R_m**2)
    area = np.pi * e.R_m**2 * (np.sqrt(adh) + np.sqrt(adh + ext)) ** (4.0 / 3.0)
    return sigma0 * area


def power_force(k: float, n: float, voltage: np.ndarray) -> np.ndarray:
    """F_el = k·|u|^n, N, with k in N/V^n."""
    return k * np.abs(np.asarray(voltage, dtype=float)) ** n


def friction_prefactor(mu: float, m: float, f_ref: float) -> float:
    """c of F_t = c·W^m such that F_t/W = mu at W = f_ref."""
    return mu * f_ref ** (1.0 - m)


def sliding_friction(c: np.ndarray, load: np.ndarray, m: float) -> np.ndarray:
    """c·W^m, N (0 where the load is not positive)."""
    w = np.clip(load, 0.0, None)
    return c * w**m


def speed_factor(speed: np.ndarray, exponent: float, v_ref: float) -> np.ndarray:
    """(|v|/v_ref)^β, with |v| floored at 1 mm/s (a stroke's reversal)."""
    if exponent == 0.0:
        return np.ones_like(speed)
    return (np.maximum(np.abs(speed), 1e-3) / v_ref) ** exponent


def dahl(f_slide: np.ndarray, velocity: np.ndarray, dt: float, delta: float) -> np.ndarray:
    """The tangential force through Dahl's pre-sliding: F relaxes to ±F_slide over δ of travel.

    ``f_slide`` is the signed sliding friction (sign of the velocity), N; ``velocity`` m/s.
    """
    decay = np.exp(-np.abs(velocity) * dt / delta)
    out = np.empty_like(f_slide)
    f = 0.0
    for i in range(f_slide.size):
        target = f_slide[i]
        f = target + (f - target) * decay[i]
        out[i] = f
    return out


def moisture_factor(t_contact: np.ndarray, rise: float, tau: float) -> np.ndarray:
    """1 + rise·(1 - exp(-t/τ)): first-order kinetics of the pad's hydration (Dzidek 2017)."""
    t = np.clip(t_contact, 0.0, None)
    if rise == 0.0:
        return np.ones_like(t)
    return 1.0 + rise * (1.0 - np.exp(-t / tau))


def power_law_fit(voltages: np.ndarray, forces: np.ndarray) -> tuple[float, float]:
    """(k, n) of the least-squares line log F = log k + n·log U over positive forces."""
    u = np.asarray(voltages, dtype=float)
    f = np.asarray(forces, dtype=float)
    keep = f > 0
    if keep.sum() < 2:
        return float("nan"), float("nan")
    n, logk = np.polyfit(np.log(u[keep]), np.log(f[keep]), 1)
    return float(np.exp(logk)), float(n)
