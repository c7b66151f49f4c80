"""The Maugis-Dugdale adhesive contact (Maugis 1992), which the seed paper reduces to JKR.

The Dugdale stress is the electrostatic attraction sigma_0 (eq. 8); it acts wherever the gap is
below h_0 = Delta-gamma / sigma_0, i.e. over the contact (radius a) and an annulus out to the
cohesive-zone radius c (the paper's b). With K = 4 E* / 3 and Maugis' scales

    A = a / (pi dg R^2 / K)^(1/3),   P = F / (pi dg R),   m = c / a,
    lambda = 2 sigma_0 (R / (pi dg K^2))^(1/3),

the solution satisfies (D. Maugis, J. Colloid Interface Sci. 150, 243, 1992; s = sqrt(m^2 - 1))

    lambda A^2 / 2 [s + (m^2 - 2) atan s] + 4 lambda^2 A / 3 [s atan s - m + 1] = 1
    P = A^3 - lambda A^2 [s + m^2 atan s]
    Delta = A^2 - 4/3 A lambda s        (penetration / (pi^2 dg^2 R / K^2)^(1/3)).

For a given s the first equation is a quadratic in A, so A(s) and P(s) are closed forms; the
load-controlled, stable solution for a given P is found with one bracketed root search in
ln s on the branch between s -> 0 (A -> infinity) and the pull-off point (the minimum of P).
Arrays are solved all at once (:func:`md_dimensionless`): P is evaluated on a coarse grid of
ln s for every point, the first grid step where it falls below the point's load brackets the
stable root (P falls monotonically on the stable branch, so that step holds exactly one
root), and the Illinois variant of regula falsi on asinh P, in lockstep, narrows every
bracket to 1e-14 in ln s (relative, about 30 steps where a bisection needed 52). Only
points the coarse grid cannot place (loads within a grid step of the pull-off, or beyond the
grid) are solved one by one, with the pull-off point found first. The two agree to 1e-9
(1.5e-13 on 10,000 points of 0.1-2 N at 10-200 V) except within 1e-6 of the pull-off load,
where A itself is ill-conditioned (dA/dP is infinite at the pull-off); both agree with a
50-digit solution of Maugis' equations to 1e-12 (``tests/model/test_model_maugis_digits.py``).

Here dg / sigma_0 = eps_L * gap is the same at every voltage (5.48 um for Table 1), so
lambda = 2 sigma_0^(2/3) (R / (pi h_0 K^2))^(1/3) grows as U^(4/3). For Table 1 (computed by
this module; ``md_jkr_departure`` and :func:`evtribo.figures.model_figures.plot_maugis` give them):

=========  ======  ======  ======  ======  ======  ======
U (V)        10      30      60     100     140     150
lambda      0.071   0.306   0.772   1.525   2.389   2.619
=========  ======  ======  ======  ======  ======  ======

so the contact is DMT-like only below about 13 V (lambda < 0.1), passes lambda = 1 at 73 V and
would need 244 V to reach lambda = 5 (JKR-like). Yet the loads of electrovibration are
hundreds to thousands of pi dg R, where every lambda gives nearly the same contact: at 0.5 N
the cohesive zone is thin (c/a - 1 from 1.7 % at 10 V to 0.8 % at 140 V), the
Maugis-Dugdale area is 0.3-1.2 % below JKR's, and sigma_0 pi c^2 exceeds eq. (11) by 3.1 %
at 10 V and 0.7 % at 140 V. At 0.1 N the departures grow to 2.5 % (area, near 70 V) and
6.2 % (force, at 10 V); at 2 N they shrink to 0.2-0.7 % (area) and 0.4-1.7 % (force).
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import optimize

from evtribo.model.contact import hertz_radius
from evtribo.model.electrostatics import _out, adhesion_stress, surface_energy
from evtribo.model.params import TABLE_1, ModelParameters
from evtribo.util.docstrings import fill_doc

__all__ = [
    "MaugisDugdale",
    "contact_area_md",
    "electrostatic_force_md",
    "friction_force_md",
    "maugis_dugdale",
    "maugis_parameter",
    "md_dimensionless",
    "md_jkr_departure",
    "md_pulloff_load",
]

_X_GRID = np.linspace(-32.0, 18.0, 201)  # ln s; s from 1e-14 to 6.6e7 (round-off beyond)
_X_COARSE = np.linspace(-32.0, 18.0, 26)  # the vectorised solver's brackets
#: Width in ln s at which the vectorised solver stops narrowing a bracket.
_X_TOL = 1e-14
#: Most steps of the vectorised solver (regula falsi needs about a dozen).
_MAX_STEPS = 100


def _f1(s: float) -> float:
    """s + (s^2 - 1) atan s, with its series where the two terms cancel."""
    if s < 1e-2:
        s2 = s * s
        return s * s2 * (4.0 / 3.0 - s2 * (8.0 / 15.0 - s2 * 12.0 / 35.0))
    return s + (s * s - 1.0) * math.atan(s)


def _state(x: float, lam: float) -> tuple[float, float, float]:
    """(A, m, P) on the Maugis-Dugdale curve at s = exp(x) for parameter *lam*."""
    s = math.exp(x)
    m = math.sqrt(1.0 + s * s)
    at = math.atan(s)
    f2 = s * at - s * s / (m + 1.0)  # s atan s - (m - 1)
    alpha = 0.5 * lam * _f1(s)
    beta = 4.0 / 3.0 * lam * lam * f2
    a = 2.0 / (beta + math.sqrt(beta * beta + 4.0 * alpha))
    p = a**3 - lam * a * a * (s + m * m * at)
    return a, m, p


def _load(x: float, lam: float) -> float:
    return _state(x, lam)[2]


@functools.lru_cache(maxsize=256)
def _pulloff(lam: float) -> tuple[float, float]:
    """(ln s, P) at the minimum of P(s): the load-controlled pull-off point."""
    loads = np.array([_load(x, lam) for x in _X_GRID])
    i = int(np.argmin(loads))
    lo, hi = _X_GRID[max(i - 1, 0)], _X_GRID[min(i + 1, len(_X_GRID) - 1)]
    res = optimize.minimize_scalar(_load, bounds=(lo, hi), args=(lam,), method="bounded",
                                   options={"xatol": 1e-10})
    x = float(res.x) if res.fun <= loads[i] else float(_X_GRID[i])
    return x, min(float(res.fun), float(loads[i]))


def md_pulloff_load(lam: ArrayLike) -> NDArray[np.float64]:
    """Dimensionless pull-off load F_po / (pi dg R) under load control.

    Parameters
    ----------
    lam : float or ndarray
        Maugis parameter lambda (> 0).

    Returns
    -------
    ndarray
        Between -2 (DMT, lambda -> 0) and -3/2 (JKR, lambda -> infinity).
    """
    lam_a = np.asarray(lam, dtype=float)
    out = np.full(lam_a.shape, np.nan)
    for idx, value in np.ndenumerate(lam_a):
        if value > 0:
            out[idx] = _pulloff(float(value))[1]
    return _out(out)


def _solve(load: float, lam: float) -> tuple[float, float]:
    if not (lam > 0 and math.isfinite(load)):
        return math.nan, math.nan
    x_po, p_po = _pulloff(lam)
    if load < p_po:
        return math.nan, math.nan
    if load == p_po:
        a, m, _ = _state(x_po, lam)
        return a, m
    # bracket on the stable branch: step left from the pull-off point until P > load
    lo, step = x_po, 1.0
    while True:
        lo = lo - step
        if _load(lo, lam) > load:
            break
        step *= 2.0
        if lo < -700.0:
            return math.nan, math.nan
    hi = x_po
    for x in _X_GRID[::-1]:  # tighten the bracket using the grid
        if lo < x < hi:
            if _load(x, lam) > load:
                lo = x
                break
            hi = x
    x = optimize.brentq(lambda v: _load(v, lam) - load, lo, hi, xtol=1e-13, rtol=1e-13)
    a, m, _ = _state(x, lam)
    return a, m


def _state_v(x: NDArray[np.float64], lam: NDArray[np.float64]
             ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """:func:`_state` for arrays (broadcast): (A, m, P) at s = exp(x)."""
    s = np.exp(x)
    s2 = s * s
    m = np.sqrt(1.0 + s2)
    at = np.arctan(s)
    small = s < 1e-2
    f1 = np.where(small, s * s2 * (4.0 / 3.0 - s2 * (8.0 / 15.0 - s2 * 12.0 / 35.0)),
                  s + (s2 - 1.0) * at)
    f2 = s * at - s2 / (m + 1.0)
    alpha = 0.5 * lam * f1
    beta = 4.0 / 3.0 * lam * lam * f2
    a = 2.0 / (beta + np.sqrt(beta * beta + 4.0 * alpha))
    p = a**3 - lam * a * a * (s + m * m * at)
    return a, m, p


def _load_v(x: NDArray[np.float64], lam: NDArray[np.float64]) -> NDArray[np.float64]:
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        return _state_v(x, lam)[2]


def _illinois(lo: NDArray[np.float64], hi: NDArray[np.float64], target: NDArray[np.float64],
              lam: NDArray[np.float64]) -> NDArray[np.float64]:
    """The root of ``P(x) = target`` in each bracket [lo, hi] (P(lo) > target >= P(hi)),
    by the Illinois variant of regula falsi in lockstep on ``asinh P`` (nearly linear in
    x = ln s, where P itself varies by orders of magnitude): superlinear, and never leaving
    a bracket; a step that cannot shrink a bracket is a bisection. A bracket is done when
    it is narrower than :data:`_X_TOL` (relative to ln s, at least 1) or hits the root."""
    goal = np.arcsinh(target)

    def h(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.asarray(np.arcsinh(_load_v(x, lam)) - goal, dtype=float)

    f_lo, f_hi = h(lo), h(hi)
    side = np.zeros(lo.shape, dtype=np.int8)  # which end was kept last: +1 hi, -1 lo
    active = np.ones(lo.shape, dtype=bool)
    for _ in range(_MAX_STEPS):
        active &= (hi - lo) > _X_TOL * np.maximum(1.0, np.abs(lo))
        if not active.any():
            break
        with np.errstate(invalid="ignore", divide="ignore"):
            x = hi - f_hi * (hi - lo) / (f_hi - f_lo)
        bad = ~np.isfinite(x) | (x <= lo) | (x >= hi)
        x = np.where(bad, 0.5 * (lo + hi), x)
        fx = h(x)
        above = fx > 0
        # the end kept twice in a row has its value halved (Illinois)
        f_hi = np.where(above & (side == 1), 0.5 * f_hi, f_hi)
        f_lo = np.where(~above & (side == -1), 0.5 * f_lo, f_lo)
        lo = np.where(active & above, x, lo)
        hi = np.where(active & ~above, x, hi)
        f_lo = np.where(active & above, fx, f_lo)
        f_hi = np.where(active & ~above, fx, f_hi)
        side = np.where(above, 1, -1).astype(np.int8)
        hit = active & (fx == 0)
        lo, hi = np.where(hit, x, lo), np.where(hit, x, hi)
        active &= ~hit
    return np.asarray(0.5 * (lo + hi), dtype=float)


def _solve_many(load: NDArray[np.float64], lam: NDArray[np.float64]
                ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """(A, m, solved) for 1-d arrays: the stable root bracketed on the coarse grid, then
    narrowed in lockstep; ``solved`` is False where the grid cannot place it."""
    p_grid = _load_v(_X_COARSE[None, :], lam[:, None])
    below = p_grid <= load[:, None]
    first = np.argmax(below, axis=1)
    solved = below.any(axis=1) & (first > 0) & (lam > 0) & np.isfinite(load)
    idx = np.flatnonzero(solved)
    lo = _X_COARSE[first[idx] - 1]
    hi = _X_COARSE[first[idx]]
    x = _illinois(lo, hi, load[idx], lam[idx])
    a_out = np.full(load.shape, np.nan)
    m_out = np.full(load.shape, np.nan)
    a, m, _ = _state_v(x, lam[idx])
    a_out[idx], m_out[idx] = a, m
    return a_out, m_out, solved


def md_dimensionless(load: ArrayLike, lam: ArrayLike) -> tuple[NDArray[np.float64],
                                                               NDArray[np.float64]]:
    """Dimensionless Maugis-Dugdale solution under load control.

    Parameters
    ----------
    load : float or ndarray
        P = F / (pi dg R).
    lam : float or ndarray
        Maugis parameter lambda (> 0); broadcast against *load*.

    Returns
    -------
    A : ndarray
        a / (pi dg R^2 / K)^(1/3); NaN below the pull-off load.
    m : ndarray
        c / a >= 1.
    """
    p_b, l_b = np.broadcast_arrays(np.asarray(load, dtype=float), np.asarray(lam, dtype=float))
    flat_p, flat_l = p_b.ravel(), l_b.ravel()
    a_out, m_out, solved = _solve_many(flat_p, flat_l)
    for i in np.flatnonzero(~solved):  # near the pull-off, or off the grid: one by one
        a_out[i], m_out[i] = _solve(float(flat_p[i]), float(flat_l[i]))
    return _out(a_out.reshape(p_b.shape)), _out(m_out.reshape(p_b.shape))


class MaugisDugdale(NamedTuple):
    """The Maugis-Dugdale contact in SI units (arrays broadcast from the inputs)."""

    a: NDArray[np.float64]
    """Contact radius, m."""
    c: NDArray[np.float64]
    """Cohesive-zone radius (the paper's b), m."""
    lam: NDArray[np.float64]
    """Maugis parameter lambda (0 without voltage)."""
    load: NDArray[np.float64]
    """Dimensionless load F_ext / (pi dg R) (inf without voltage)."""


def maugis_parameter(voltage: ArrayLike, params: ModelParameters = TABLE_1,
                     normal_force: ArrayLike | None = None) -> NDArray[np.float64]:
    """Maugis' transition parameter lambda = 2 sigma_0 (R / (pi dg K^2))^(1/3), K = 4E*/3.

    Parameters
    ----------
    voltage : float or ndarray
        Applied voltage U, V.
    params : ModelParameters
        Table 1 by default.
    normal_force : optional
        Ignored (lambda does not depend on the load); accepted so that every function of
        this module can be called alike.

    Returns
    -------
    ndarray
        lambda, dimensionless; proportional to U^(4/3); 0 at U = 0.
    """
    sigma0 = np.asarray(adhesion_stress(voltage, params))
    k = 4.0 * params.E_star / 3.0
    h0 = params.eps_L * params.effective_gap  # dg / sigma0, independent of U
    lam = 2.0 * np.cbrt(sigma0**2 * params.R / (np.pi * h0 * k**2))
    if normal_force is not None:
        lam = np.broadcast_arrays(lam, np.asarray(normal_force, dtype=float))[0].copy()
    return _out(lam)


def maugis_dugdale(normal_force: ArrayLike, voltage: ArrayLike,
                   params: ModelParameters = TABLE_1) -> MaugisDugdale:
    """Full Maugis-Dugdale solution for the electroadhesive fingertip contact.

    Parameters
    ----------
    normal_force : float or ndarray
        External normal force F_ext, N.
    voltage : float or ndarray
        Applied voltage U (instantaneous or amplitude), V.
    params : ModelParameters
        Table 1 by default.

    Returns
    -------
    MaugisDugdale
        ``a`` and ``c`` in m, ``lam`` and the dimensionless ``load``. Without voltage the
        contact is Hertz's (c = a). NaN below the pull-off force.
    """
    f, u = np.broadcast_arrays(np.asarray(normal_force, dtype=float),
                               np.asarray(voltage, dtype=float))
    dg = np.asarray(surface_energy(u, params), dtype=float)
    lam = np.asarray(maugis_parameter(u, params), dtype=float)
    k = 4.0 * params.E_star / 3.0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        load = f / (np.pi * dg * params.R)
        # an adhesion too weak to be a float's share of the load (a voltage of 1e-149 V):
        # the contact is Hertz's
        adhesive = (dg > 0) & np.isfinite(load)
        big_a, m = md_dimensionless(np.where(adhesive, load, np.nan), lam)
        a = np.asarray(big_a) * np.cbrt(np.pi * dg * params.R**2 / k)
    hertz = np.asarray(hertz_radius(f, params.R, params.E_star), dtype=float)
    a = np.where(adhesive, a, hertz)
    c = np.where(adhesive, a * np.asarray(m), hertz)
    return MaugisDugdale(_out(a), _out(c), _out(lam), _out(load))


@fill_doc
def contact_area_md(normal_force: ArrayLike, voltage: ArrayLike,
                    params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """Maugis-Dugdale contact area pi a^2, m^2.

    Parameters
    ----------
    %(normal_force)s
    %(voltage)s
    %(params)s

    Returns
    -------
    ndarray
        The contact area, m^2.
    """
    return _out(np.pi * np.asarray(maugis_dugdale(normal_force, voltage, params).a) ** 2)


def electrostatic_force_md(normal_force: ArrayLike, voltage: ArrayLike,
                           params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """Electrostatic part of the contact force with Maugis' cohesive zone, sigma_0 pi c^2, N.

    Parameters
    ----------
    normal_force : float or ndarray
        External normal force F_ext, N.
    voltage : float or ndarray
        Applied voltage U, V.
    params : ModelParameters
        Table 1 by default.

    Returns
    -------
    ndarray
        The force, N.
    """
    c = np.asarray(maugis_dugdale(normal_force, voltage, params).c)
    return _out(np.asarray(adhesion_stress(voltage, params)) * np.pi * c**2)


def friction_force_md(normal_force: ArrayLike, voltage: ArrayLike,
                      params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """Friction in full slip, eq. (1): mu (F_ext + sigma_0 pi b^2) with Maugis' b = c, N.

    Parameters
    ----------
    normal_force : float or ndarray
        External normal force F_ext, N.
    voltage : float or ndarray
        Applied voltage U, V.
    params : ModelParameters
        Table 1 by default.

    Returns
    -------
    ndarray
        The friction force, N.
    """
    f = np.asarray(normal_force, dtype=float)
    return _out(params.friction(f + np.asarray(electrostatic_force_md(f, voltage, params))))


def md_jkr_departure(normal_force: ArrayLike, voltage: ArrayLike,
                     params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """Relative difference of the electrostatic force, Maugis-Dugdale versus JKR (eq. 11).

    Parameters
    ----------
    normal_force : float or ndarray
        External normal force F_ext, N.
    voltage : float or ndarray
        Applied voltage U, V (> 0).
    params : ModelParameters
        Table 1 by default.

    Returns
    -------
    ndarray
        sigma_0 pi c^2 / (sigma_0 pi a_JKR^2) - 1, dimensionless (0 when JKR holds, and
        without voltage).
    """
    from evtribo.model.contact import contact_area_jkr

    md = np.asarray(electrostatic_force_md(normal_force, voltage, params))
    jkr = np.asarray(adhesion_stress(voltage, params)) * np.asarray(
        contact_area_jkr(normal_force, voltage, params))
    with np.errstate(divide="ignore", invalid="ignore"):
        return _out(np.where(jkr > 0, md / jkr - 1.0, np.where(md > 0, np.inf, 0.0)))
