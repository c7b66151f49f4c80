"""Contact of a parabolic elastic fingertip on a flat screen: Hertz, JKR (eq. 3) and DMT.

Two layers of functions:

- mechanics in terms of load, surface energy, radius and modulus
  (``hertz_radius``, ``jkr_radius``, ``dmt_radius``, pull-off forces), the textbook results the
  Maugis-Dugdale solution is checked against;
- the paper's quantities for a normal force and an applied voltage
  (``contact_area_hertz``, ``contact_area_jkr``, ``area_increase_pct``), where the surface
  energy comes from the capacitor model (eq. 9).

Loads below the pull-off force have no contact solution: those elements are NaN.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evtribo.model.electrostatics import _f, _out, surface_energy
from evtribo.model.params import TABLE_1, ModelParameters
from evtribo.util.docstrings import fill_doc

__all__ = [
    "area_increase_pct",
    "contact_area_hertz",
    "contact_area_jkr",
    "contact_radius_hertz",
    "contact_radius_jkr",
    "dmt_pulloff_force",
    "dmt_radius",
    "hertz_radius",
    "jkr_pulloff_force",
    "jkr_radius",
]


def jkr_terms(normal_force: ArrayLike, delta_gamma: ArrayLike, R: ArrayLike,
              E_star: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The two dimensionless terms of eq. (3): ``x = 9 pi dg / (8 E* R)`` (adhesion) and
    ``y = 3 F / (4 E* R^2)`` (load); ``A / (pi R^2) = (sqrt(x) + sqrt(x + y))^(4/3)``.

    Parameters
    ----------
    normal_force : float or ndarray
        External normal force F_ext, N.
    delta_gamma : float or ndarray
        Relative surface energy, J/m^2.
    R : float or ndarray
        Radius of the parabolic profile, m.
    E_star : float or ndarray
        Effective modulus, Pa.
    """
    dg, r, e = _f(delta_gamma), _f(R), _f(E_star)
    return 9.0 * np.pi * dg / (8.0 * e * r), 3.0 * _f(normal_force) / (4.0 * e * r**2)


def hertz_radius(normal_force: ArrayLike, R: ArrayLike, E_star: ArrayLike) -> NDArray[np.float64]:
    """Hertz contact radius of a parabolic body, a^3 = 3 F R / (4 E*).

    Parameters
    ----------
    normal_force : float or ndarray
        Normal load F, N (NaN for F < 0).
    R : float or ndarray
        Radius of the profile, m.
    E_star : float or ndarray
        Effective modulus, Pa.

    Returns
    -------
    ndarray
        a, m.
    """
    f = _f(normal_force)
    with np.errstate(invalid="ignore"):
        a = np.cbrt(3.0 * f * _f(R) / (4.0 * _f(E_star)))
    return _out(np.where(f >= 0, a, np.nan))


def jkr_radius(normal_force: ArrayLike, delta_gamma: ArrayLike, R: ArrayLike,
               E_star: ArrayLike) -> NDArray[np.float64]:
    """JKR contact radius on the stable (load-controlled) branch, in the form of eq. (3).

    (a/R)^(3/2) = sqrt(9 pi dg / (8 E* R)) + sqrt(9 pi dg / (8 E* R) + 3 F / (4 E* R^2)),
    which is a^3 = (3R/4E*) (F + 3 pi dg R + sqrt(6 pi dg R F + (3 pi dg R)^2)).

    Parameters
    ----------
    normal_force : float or ndarray
        External normal load F, N; NaN below the pull-off force -(3/2) pi dg R.
    delta_gamma : float or ndarray
        Relative surface energy (work of adhesion), J/m^2.
    R : float or ndarray
        Radius of the profile, m.
    E_star : float or ndarray
        Effective modulus, Pa.

    Returns
    -------
    ndarray
        a, m.
    """
    x, y = jkr_terms(normal_force, delta_gamma, R, E_star)
    with np.errstate(invalid="ignore"):
        s = np.sqrt(x) + np.sqrt(x + y)
    return _out(_f(R) * s ** (2.0 / 3.0))


@fill_doc
def dmt_radius(normal_force: ArrayLike, delta_gamma: ArrayLike, R: ArrayLike,
               E_star: ArrayLike) -> NDArray[np.float64]:
    """DMT contact radius, a^3 = 3 R (F + 2 pi dg R) / (4 E*).

    Parameters
    ----------
    %(normal_force)s
    delta_gamma : float or ndarray
        Relative surface energy, J/m^2.
    R : float or ndarray
        Radius of the fingertip, m.
    E_star : float or ndarray
        Effective elastic modulus, Pa.

    Returns
    -------
    ndarray
        The contact radius, m; NaN below the pull-off force -2 pi dg R.
    """
    f, dg, r = _f(normal_force), _f(delta_gamma), _f(R)
    return hertz_radius(f + 2.0 * np.pi * dg * r, r, E_star)


def jkr_pulloff_force(delta_gamma: ArrayLike, R: ArrayLike) -> NDArray[np.float64]:
    """Load-controlled JKR pull-off force, -(3/2) pi dg R, N.

    Parameters
    ----------
    delta_gamma : float or ndarray
        Relative surface energy, J/m^2.
    R : float or ndarray
        Radius of the fingertip, m.

    Returns
    -------
    ndarray
        The pull-off force (negative), N.
    """
    return _out(-1.5 * np.pi * _f(delta_gamma) * _f(R))


def dmt_pulloff_force(delta_gamma: ArrayLike, R: ArrayLike) -> NDArray[np.float64]:
    """DMT pull-off force, -2 pi dg R, N.

    Parameters
    ----------
    delta_gamma : float or ndarray
        Relative surface energy, J/m^2.
    R : float or ndarray
        Radius of the fingertip, m.

    Returns
    -------
    ndarray
        The pull-off force (negative), N.
    """
    return _out(-2.0 * np.pi * _f(delta_gamma) * _f(R))


# --------------------------------------------------------------------- the paper's quantities
def contact_radius_hertz(normal_force: ArrayLike,
                         params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """Hertz contact radius for the fingertip (no adhesion), m.

    Parameters
    ----------
    normal_force : float or ndarray
        External normal force F_ext, N.
    params : ModelParameters
        Uses ``R`` and ``E_star``.

    Returns
    -------
    ndarray
        The contact radius, m.
    """
    return hertz_radius(normal_force, params.R, params.E_star)


def contact_area_hertz(normal_force: ArrayLike,
                       params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """Hertz (voltage OFF) contact area pi a^2, m^2.

    Parameters
    ----------
    normal_force : float or ndarray
        External normal force F_ext, N.
    params : ModelParameters
        Uses ``R`` and ``E_star``.

    Returns
    -------
    ndarray
        The contact area, m^2.
    """
    return _out(np.pi * _f(contact_radius_hertz(normal_force, params)) ** 2)


def contact_radius_jkr(normal_force: ArrayLike, voltage: ArrayLike,
                       params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """JKR contact radius with the electrostatic surface energy of eq. (9), m.

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
    ndarray
        The contact radius, m.
    """
    return jkr_radius(normal_force, surface_energy(voltage, params), params.R, params.E_star)


def contact_area_jkr(normal_force: ArrayLike, voltage: ArrayLike,
                     params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """Apparent contact area with voltage ON, eq. (3), m^2.

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
    ndarray
        A = pi R^2 (sqrt(9 pi dg/(8 E* R)) + sqrt(9 pi dg/(8 E* R) + 3 F/(4 E* R^2)))^(4/3).
    """
    return _out(np.pi * _f(contact_radius_jkr(normal_force, voltage, params)) ** 2)


def area_increase_pct(normal_force: ArrayLike, voltage: ArrayLike,
                      params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """Increase of the contact area due to the voltage, 100 (A_JKR / A_Hertz - 1) (Figure 7).

    Parameters
    ----------
    normal_force : float or ndarray
        External normal force F_ext, N (> 0).
    voltage : float or ndarray
        Applied voltage amplitude U, V.
    params : ModelParameters
        Table 1 by default.

    Returns
    -------
    ndarray
        Percent (>= 0).
    """
    # (A_JKR / A_Hertz) = (1 + t)^(4/3), t = (sqrt(x) + sqrt(x + y) - sqrt(y)) / sqrt(y),
    # written without cancellation so that it is exactly 0 without voltage.
    x, y = jkr_terms(normal_force, surface_energy(voltage, params), params.R, params.E_star)
    with np.errstate(divide="ignore", invalid="ignore"):
        ry = np.sqrt(y)
        t = (np.sqrt(x) + x / (np.sqrt(x + y) + ry)) / ry
        return _out(100.0 * np.expm1(4.0 / 3.0 * np.log1p(t)))
