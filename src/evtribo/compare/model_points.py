"""The model at measured points: eq. (11) and eq. (5) for square and sine drives.

Square-wave points are compared with the model at U = A (U^2 is constant for a square wave);
sine-wave points with the model averaged over one period of U(t) = A sin(wt).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evtribo._docs import fill_doc
from evtribo.model import electrostatic_force, friction_force
from evtribo.model.params import TABLE_1, ModelParameters

__all__ = ["mean_electrostatic_force", "mean_friction_force", "model_exponent"]

_PHASES = np.linspace(0.0, 2.0 * np.pi, 64, endpoint=False)


def _is_sine(waveform: ArrayLike) -> NDArray[np.bool_]:
    w = np.asarray(waveform, dtype=object)
    return np.array([str(x).strip().lower() == "sine" for x in np.atleast_1d(w)]).reshape(
        np.shape(w))


def mean_electrostatic_force(normal_force: ArrayLike, amplitude: ArrayLike,
                             waveform: ArrayLike = "square",
                             params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """Time-averaged model electrostatic force (eq. 11) for a drive of given amplitude.

    Parameters
    ----------
    normal_force : float or ndarray
        External normal force, N.
    amplitude : float or ndarray
        Voltage amplitude A, V.
    waveform : str or ndarray of str
        ``"sine"`` (average over U = A sin(phi)) or anything else (square: U = A).
    params : ModelParameters
        Model parameters.

    Returns
    -------
    ndarray
        Mean electrostatic force, N.
    """
    fn, amp = np.broadcast_arrays(np.asarray(normal_force, float), np.asarray(amplitude, float))
    sine = np.broadcast_to(_is_sine(waveform), fn.shape)
    out = np.asarray(electrostatic_force(fn, amp, params), dtype=float).copy()
    if np.any(sine):
        u = amp[sine][:, None] * np.sin(_PHASES)[None, :]
        out[sine] = np.asarray(electrostatic_force(fn[sine][:, None], u, params),
                               dtype=float).mean(axis=1)
    return out


@fill_doc
def mean_friction_force(normal_force: ArrayLike, amplitude: ArrayLike,
                        waveform: ArrayLike = "square",
                        params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """Time-averaged model friction force (eq. 5); amplitude 0 is the OFF condition.

    Parameters
    ----------
    %(normal_force)s
    amplitude : float or ndarray
        Amplitude of the drive, V (0: OFF).
    waveform : str or array of str
        ``"square"`` or ``"sine"`` (the model averaged over one period).
    %(params)s

    Returns
    -------
    ndarray
        The friction force, N.
    """
    fn, amp = np.broadcast_arrays(np.asarray(normal_force, float), np.asarray(amplitude, float))
    sine = np.broadcast_to(_is_sine(waveform), fn.shape)
    out = np.asarray(friction_force(fn, amp, params), dtype=float).copy()
    if np.any(sine):
        u = amp[sine][:, None] * np.sin(_PHASES)[None, :]
        out[sine] = np.asarray(friction_force(fn[sine][:, None], u, params),
                               dtype=float).mean(axis=1)
    return out


def model_exponent(normal_force: float, u_min: float, u_max: float,
                   params: ModelParameters, waveform: str = "square") -> float:
    """Mean local slope d ln F_el / d ln U of the model between two amplitudes.

    It is the exponent a power law fitted to the model over [u_min, u_max] would have
    (2 when the contact area does not depend on the voltage, up to 10/3, eq. 12).

    Parameters
    ----------
    normal_force : float
        External normal force, N.
    u_min, u_max : float
        Amplitude range, V (NaN when they are equal).
    params : ModelParameters
        Model parameters.
    waveform : str
        Drive waveform.

    Returns
    -------
    float
        The mean slope (NaN when the range is empty).
    """
    if not (u_min > 0 and u_max > u_min):
        return math.nan
    f = mean_electrostatic_force(normal_force, np.array([u_min, u_max]), waveform, params)
    return float(np.log(f[1] / f[0]) / np.log(u_max / u_min))


# ------------------------------------------------------------------------------- results
