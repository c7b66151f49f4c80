"""Friction in full slip with electroadhesion (eqs. 1, 2, 5, 11-13) and applied waveforms.

Coulomb's law with Derjaguin's two terms: the contact force is the external force plus the
electrostatic attraction over the adhesive zone, F_R = mu (F_ext + sigma_0 pi b^2) (eq. 1).
The paper (and these functions, unless named ``_md``) take JKR's asymptote b = a with the
contact area of eq. (3), giving the closed form of eq. (5); the electrostatic part is eq. (11).
:mod:`evtribo.model.maugis` solves the full Maugis-Dugdale cohesive zone instead.

In time, the model is quasi-static: the friction at each instant follows the instantaneous
voltage U(t), so a sine of frequency f gives a friction oscillating at 2 f (only U^2 enters).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evtribo.model.contact import contact_area_hertz, contact_area_jkr, jkr_terms
from evtribo.model.electrostatics import _f, _out, adhesion_stress, surface_energy
from evtribo.model.params import TABLE_1, ModelParameters
from evtribo.util.docstrings import fill_doc

__all__ = [
    "adhesion_load_ratio",
    "electrostatic_force",
    "electrostatic_force_adhesive_limit",
    "electrostatic_force_exponent",
    "electrostatic_force_load_limit",
    "friction_force",
    "friction_force_dugdale",
    "friction_time_series",
    "sine_voltage",
    "square_voltage",
]


def friction_force_dugdale(normal_force: ArrayLike, radius: ArrayLike, voltage: ArrayLike,
                           params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """Friction in full slip for a given adhesive-zone radius, eq. (1) (eq. (2) with r = a).

    Parameters
    ----------
    normal_force : float or ndarray
        External normal force F_ext, N.
    radius : float or ndarray
        Radius b of the zone where the electrostatic stress acts, m.
    voltage : float or ndarray
        Applied voltage U (instantaneous or amplitude), V.
    params : ModelParameters
        Uses ``mu`` and the capacitor's parameters.

    Returns
    -------
    ndarray
        F_R = mu (F_ext + sigma_0 pi b^2), N (with ``params.m`` not 1, the law
        :meth:`~evtribo.model.params.ModelParameters.friction` of that load).
    """
    sigma0 = _f(adhesion_stress(voltage, params))
    return _out(params.friction(_f(normal_force) + sigma0 * np.pi * _f(radius) ** 2))


def electrostatic_force(normal_force: ArrayLike, voltage: ArrayLike,
                        params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """Inferred electrostatic force, sigma_0 times the JKR contact area (eq. 11).

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
        F_el = sigma_0 A_JKR, N (>= 0).
    """
    return _out(_f(adhesion_stress(voltage, params))
                * _f(contact_area_jkr(normal_force, voltage, params)))


def friction_force(normal_force: ArrayLike, voltage: ArrayLike,
                   params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """Friction force in full slip with the JKR contact area (eq. 5).

    Parameters
    ----------
    normal_force : float or ndarray
        External normal force F_ext, N.
    voltage : float or ndarray
        Applied voltage U (instantaneous or amplitude), V; 0 gives mu F_ext.
    params : ModelParameters
        Table 1 by default.

    Returns
    -------
    ndarray
        F_R = mu (F_ext + F_el), N (with ``params.m`` not 1, the law
        :meth:`~evtribo.model.params.ModelParameters.friction` of that load).
    """
    f = _f(normal_force)
    return _out(params.friction(f + _f(electrostatic_force(f, voltage, params))))


def adhesion_load_ratio(normal_force: ArrayLike, voltage: ArrayLike,
                        params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """The ratio deciding between the limits (12) and (13): 3 pi R Delta-gamma / (2 F_ext).

    Parameters
    ----------
    normal_force : float or ndarray
        External normal force F_ext, N (> 0).
    voltage : float or ndarray
        Applied voltage U, V.
    params : ModelParameters
        Table 1 by default.

    Returns
    -------
    ndarray
        Dimensionless: >> 1 adhesion-dominated (F_el ~ U^(10/3)), << 1 load-dominated
        (F_el ~ U^2). 0.0015 at 0.5 N and 140 V for Table 1.
    """
    dg = _f(surface_energy(voltage, params))
    # no load and no voltage: NaN; no load (or next to none, 1e-300 N): beyond any float
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return _out(3.0 * np.pi * params.R * dg / (2.0 * _f(normal_force)))


def electrostatic_force_exponent(normal_force: ArrayLike, voltage: ArrayLike,
                                 params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """Local power-law exponent of eq. (11), d ln F_el / d ln U, in closed form.

    With x = 9 pi dg / (8 E* R) (proportional to U^2) and y = 3 F_ext / (4 E* R^2),
    n = 2 + 4/3 (sqrt(x) + x / sqrt(x + y)) / (sqrt(x) + sqrt(x + y)): 2 when the load
    dominates (eq. 13), 10/3 when adhesion does (eq. 12).

    Parameters
    ----------
    normal_force : float or ndarray
        External normal force F_ext, N (>= 0).
    voltage : float or ndarray
        Applied voltage U, V.
    params : ModelParameters
        Table 1 by default.

    Returns
    -------
    ndarray
        n, dimensionless, between 2 and 10/3 for F_ext >= 0.
    """
    x, y = jkr_terms(normal_force, surface_energy(voltage, params), params.R, params.E_star)
    rx, rxy = np.sqrt(x), np.sqrt(x + y)
    with np.errstate(divide="ignore", invalid="ignore"):
        n = 2.0 + 4.0 / 3.0 * (rx + x / rxy) / (rx + rxy)
    return _out(np.where(x == 0, 2.0, n))


@fill_doc
def electrostatic_force_adhesive_limit(normal_force: ArrayLike, voltage: ArrayLike,
                                       params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """Asymptote of eq. (11) when adhesion dominates (eq. 12), proportional to U^(10/3), N.

    sigma_0 pi R^2 (2 sqrt(9 pi dg / (8 E* R)))^(4/3): the contact is held by adhesion alone.

    Parameters
    ----------
    normal_force : float or ndarray
        Accepted for a uniform signature; it does not enter.
    %(voltage)s
    %(params)s

    Returns
    -------
    ndarray
        F_el, N.
    """
    sigma0 = _f(adhesion_stress(voltage, params))
    x, _ = jkr_terms(0.0, surface_energy(voltage, params), params.R, params.E_star)
    out = sigma0 * np.pi * params.R**2 * (2.0 * np.sqrt(x)) ** (4.0 / 3.0)
    return _out(np.broadcast_arrays(out, _f(normal_force))[0].copy())


@fill_doc
def electrostatic_force_load_limit(normal_force: ArrayLike, voltage: ArrayLike,
                                   params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """Asymptote of eq. (11) when the load dominates (eq. 13), sigma_0 A_Hertz ~ U^2, N.

    Parameters
    ----------
    %(normal_force)s
    %(voltage)s
    %(params)s

    Returns
    -------
    ndarray
        F_el, N.
    """
    return _out(_f(adhesion_stress(voltage, params))
                * _f(contact_area_hertz(normal_force, params)))


# --------------------------------------------------------------------------- time domain
def sine_voltage(t: ArrayLike, amplitude: float, frequency: float,
                 phase: float = 0.0) -> NDArray[np.float64]:
    """Instantaneous voltage of a sine, U(t) = amplitude sin(2 pi frequency t + phase).

    Parameters
    ----------
    t : float or ndarray
        Time, s.
    amplitude : float
        Amplitude, V.
    frequency : float
        Frequency, Hz.
    phase : float
        Phase, rad.

    Returns
    -------
    ndarray
        U(t), V.
    """
    return _out(amplitude * np.sin(2.0 * np.pi * frequency * _f(t) + phase))


def square_voltage(t: ArrayLike, amplitude: float, frequency: float) -> NDArray[np.float64]:
    """Instantaneous voltage of a bipolar square wave, +amplitude then -amplitude, V.

    Parameters
    ----------
    t : float or ndarray
        Time, s.
    amplitude : float
        Amplitude, V.
    frequency : float
        Frequency, Hz.

    Returns
    -------
    ndarray
        U(t) = amplitude for the first half of each period, -amplitude for the second, V.
    """
    phase = np.mod(_f(t) * frequency, 1.0)
    return _out(np.where(phase < 0.5, amplitude, -amplitude).astype(float))


def friction_time_series(t: ArrayLike, normal_force: ArrayLike,
                         voltage: ArrayLike | Callable[[NDArray[np.float64]], ArrayLike],
                         params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """Quasi-static friction force for any applied voltage U(t) (Figure 5), eq. (5) per sample.

    Parameters
    ----------
    t : ndarray
        Sample times, s.
    normal_force : float or ndarray
        External normal force F_ext, N: a constant or one value per sample.
    voltage : ndarray or callable
        Instantaneous voltage U(t) in V, one value per sample (any waveform, e.g.
        :func:`sine_voltage`), or a function of *t* returning it.
    params : ModelParameters
        Table 1 by default.

    Returns
    -------
    ndarray
        F_R(t), N, with the shape of *t*.

    Raises
    ------
    ValueError
        When *voltage* or *normal_force* do not have one value per sample.
    """
    times = _f(t)
    u = _f(voltage(times)) if callable(voltage) else _f(voltage)
    f = _f(normal_force)
    for name, arr in (("voltage", u), ("normal_force", f)):
        if arr.ndim and arr.shape != times.shape:
            raise ValueError(f"{name} has shape {arr.shape}; expected a scalar or one value "
                             f"per sample of t, shape {times.shape}")
    return _out(np.broadcast_to(_f(friction_force(f, u, params)), times.shape).copy())
