"""The parallel-plate capacitor of the seed paper (eqs. 4, 6-10), vectorised, SI units.

Finger (conductive tissue) and screen (conductive layer) are the plates; between them lie the
stratum corneum, the equivalent air gap and the screen's insulating layer in series. The
electrostatic attraction per unit area is the Dugdale stress sigma_0 of the Maugis model, and
the work of separating the plates is the relative surface energy Delta-gamma. Both scale with
U^2, so their ratio ``eps_L * effective_gap`` (the Dugdale range) does not depend on the
voltage.

``voltage`` is always the instantaneous (or amplitude) value in V; only U^2 matters.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evtribo.model.params import TABLE_1, ModelParameters
from evtribo.util.docstrings import fill_doc

__all__ = [
    "adhesion_stress",
    "attraction_force",
    "capacitance",
    "dugdale_range",
    "effective_modulus",
    "effective_modulus_soft",
    "surface_energy",
]


def _f(x: ArrayLike) -> NDArray[np.float64]:
    """An input as a float array (the model's functions broadcast)."""
    return np.asarray(x, dtype=float)


def _out(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Return a 0-d result as a numpy scalar, arrays unchanged."""
    return x[()] if x.ndim == 0 else x


def _gap(params: ModelParameters, h_L: ArrayLike | None) -> NDArray[np.float64]:
    """Air-equivalent gap h_sc/eps_sc + h_L/eps_L + h_i/eps_i, m (h_L may be an array)."""
    h = params.h_L if h_L is None else np.asarray(h_L, dtype=float)
    return np.asarray(params.h_sc / params.eps_sc + h / params.eps_L
                      + params.h_i / params.eps_i, dtype=float)


def capacitance(area: ArrayLike, params: ModelParameters = TABLE_1, *,
                h_L: ArrayLike | None = None) -> NDArray[np.float64]:
    """Capacitance of the layered parallel-plate capacitor (eq. 6).

    Parameters
    ----------
    area : float or ndarray
        Plate (apparent contact) area A, m^2.
    params : ModelParameters
        Permittivities and thicknesses (Table 1 by default).
    h_L : float or ndarray, optional
        Air-gap thickness, m; defaults to ``params.h_L``.

    Returns
    -------
    ndarray
        C = eps_0 A / (h_sc/eps_sc + h_L/eps_L + h_i/eps_i), F.
    """
    a = np.asarray(area, dtype=float)
    return _out(params.eps_0 * a / _gap(params, h_L))


def attraction_force(area: ArrayLike, voltage: ArrayLike, params: ModelParameters = TABLE_1,
                     *, h_L: ArrayLike | None = None) -> NDArray[np.float64]:
    """Electrostatic attraction between the plates, -1/2 U^2 dC/dh_L (eq. 7).

    Parameters
    ----------
    area : float or ndarray
        Plate area A, m^2.
    voltage : float or ndarray
        Applied voltage U (instantaneous or amplitude), V.
    params : ModelParameters
        Permittivities and thicknesses.
    h_L : float or ndarray, optional
        Air-gap thickness, m; defaults to ``params.h_L``.

    Returns
    -------
    ndarray
        F = eps_0 A U^2 / (2 eps_L gap^2), N (>= 0).
    """
    a = np.asarray(area, dtype=float)
    return _out(a * adhesion_stress(voltage, params, h_L=h_L))


def adhesion_stress(voltage: ArrayLike, params: ModelParameters = TABLE_1, *,
                    h_L: ArrayLike | None = None) -> NDArray[np.float64]:
    """Adhesive force per unit area sigma_0(h_L, U) (eq. 8), the Dugdale stress.

    Parameters
    ----------
    voltage : float or ndarray
        Applied voltage U, V.
    params : ModelParameters
        Permittivities and thicknesses.
    h_L : float or ndarray, optional
        Air-gap thickness, m; defaults to ``params.h_L``.

    Returns
    -------
    ndarray
        sigma_0 = eps_0 U^2 / (2 eps_L gap^2), Pa.
    """
    u = np.asarray(voltage, dtype=float)
    return _out(params.eps_0 * u**2 / (2.0 * params.eps_L * _gap(params, h_L) ** 2))


def surface_energy(voltage: ArrayLike, params: ModelParameters = TABLE_1, *,
                   h_L: ArrayLike | None = None) -> NDArray[np.float64]:
    """Relative surface energy Delta-gamma(U, h_L) (eq. 9): sigma integrated from h_L to inf.

    Parameters
    ----------
    voltage : float or ndarray
        Applied voltage U, V.
    params : ModelParameters
        Permittivities and thicknesses.
    h_L : float or ndarray, optional
        Air-gap thickness, m; defaults to ``params.h_L``.

    Returns
    -------
    ndarray
        Delta-gamma = eps_0 U^2 / (2 gap), J/m^2.
    """
    u = np.asarray(voltage, dtype=float)
    return _out(params.eps_0 * u**2 / (2.0 * _gap(params, h_L)))


@fill_doc
def dugdale_range(params: ModelParameters = TABLE_1) -> float:
    """Range of the Dugdale stress, h_0 = Delta-gamma / sigma_0 = eps_L * gap, m.

    The same at every voltage, since both sigma_0 and Delta-gamma scale with U^2
    (5.48 um for Table 1).

    Parameters
    ----------
    %(params)s

    Returns
    -------
    float
        h_0, m.
    """
    return params.eps_L * params.effective_gap


def effective_modulus(E1: ArrayLike, nu1: ArrayLike, E2: ArrayLike = np.inf,
                      nu2: ArrayLike = 0.0) -> NDArray[np.float64]:
    """Effective elastic modulus of two bodies in contact (eq. 4).

    Parameters
    ----------
    E1, E2 : float or ndarray
        Young's moduli, Pa (``E2 = inf``: a rigid counter-body).
    nu1, nu2 : float or ndarray
        Poisson's ratios, between -1 and 0.5.

    Returns
    -------
    ndarray
        E* with 1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2, Pa.

    Raises
    ------
    ValueError
        For a modulus <= 0 or a Poisson's ratio outside (-1, 0.5].
    """
    e1, e2 = np.asarray(E1, dtype=float), np.asarray(E2, dtype=float)
    n1, n2 = np.asarray(nu1, dtype=float), np.asarray(nu2, dtype=float)
    if np.any(~(e1 > 0)) or np.any(~(e2 > 0)):
        raise ValueError(f"Young's moduli must be > 0 Pa, got E1={E1!r}, E2={E2!r}")
    for name, n in (("nu1", n1), ("nu2", n2)):
        if np.any(~((n > -1) & (n <= 0.5))):
            raise ValueError(f"Poisson's ratio {name} must lie in (-1, 0.5], got {n!r}")
    return _out(1.0 / ((1.0 - n1**2) / e1 + (1.0 - n2**2) / e2))


def effective_modulus_soft(E_soft: ArrayLike, nu_soft: ArrayLike = 0.5) -> NDArray[np.float64]:
    """Effective modulus when the counter-body is rigid (eq. 10): E_skin / (1 - nu_skin^2).

    Parameters
    ----------
    E_soft : float or ndarray
        Young's modulus of the soft body (skin), Pa.
    nu_soft : float or ndarray
        Its Poisson's ratio (0.5: incompressible).

    Returns
    -------
    ndarray
        E*, Pa.
    """
    return effective_modulus(E_soft, nu_soft)
