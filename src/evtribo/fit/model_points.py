"""The model at measured points: eq. (11) and eq. (5) for square and sine drives.

Square-wave points are compared with the model at U = A (U^2 is constant for a square wave);
sine-wave points with the model averaged over one period of U(t) = A sin(wt). When the
layers conduct (finite ``r_sc`` or ``r_g``) and the points' drive frequencies are given, A is
the effective amplitude the gap sees at that frequency and waveform
(:func:`evtribo.model.circuit.effective_voltage`, study format section 9).
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Iterable, Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evtribo.model import electrostatic_force, friction_force
from evtribo.model.circuit import effective_voltage
from evtribo.model.params import TABLE_1, ModelParameters
from evtribo.util.docstrings import fill_doc

__all__ = ["ForceFunction", "gap_amplitude", "gap_amplitude_fixed", "mean_electrostatic_force",
           "mean_electrostatic_force_many", "mean_friction_force", "model_exponent"]

_PHASES = np.linspace(0.0, 2.0 * np.pi, 64, endpoint=False)

#: A contact's electrostatic force ``(normal_force, voltage, params) -> N`` (eq. 11's form).
ForceFunction = Callable[[ArrayLike, ArrayLike, ModelParameters], ArrayLike]


def _is_sine(waveform: ArrayLike) -> NDArray[np.bool_]:
    w = np.asarray(waveform, dtype=object)
    return np.array([str(x).strip().lower() == "sine" for x in np.atleast_1d(w)]).reshape(
        np.shape(w))


def gap_amplitude(amplitude: ArrayLike, frequency: ArrayLike | None, waveform: ArrayLike,
                  params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """The amplitude the paper's model is evaluated with at each point, V.

    Parameters
    ----------
    amplitude : float or ndarray
        Voltage amplitude A, V.
    frequency : float or ndarray or None
        Drive frequency, Hz; None (or resistances both infinite) gives A itself.
    waveform : str or ndarray of str
        ``"sine"`` or anything else (square).
    params : ModelParameters
        The layers' resistances ``r_sc``, ``r_g`` and thicknesses.

    Returns
    -------
    ndarray
        A's effective value (NaN where the frequency is needed but not finite and > 0).
    """
    amp = np.asarray(amplitude, dtype=float)
    if frequency is None or gap_amplitude_fixed(params):
        return amp
    amp, f = np.broadcast_arrays(amp, np.asarray(frequency, dtype=float))
    sine = np.broadcast_to(_is_sine(waveform), amp.shape)
    out = np.full(amp.shape, np.nan)
    ok = np.isfinite(f) & (f > 0)
    for wave, pick in (("sine", ok & sine), ("square", ok & ~sine)):
        if pick.any():  # U_eff is U times a gain of the frequency: one per frequency
            freqs, where = np.unique(f[pick], return_inverse=True)
            gain = np.atleast_1d(effective_voltage(1.0, freqs, wave, params))
            out[pick] = np.abs(amp[pick]) * gain[where]
    return out


def gap_amplitude_fixed(params: ModelParameters, varying: Iterable[str] = ()) -> bool:
    """Whether :func:`gap_amplitude` is the drive's amplitude itself at any frequency, for
    every value of the parameters named in *varying*.

    Parameters
    ----------
    params : ModelParameters
        The layers' resistances ``r_sc`` and ``r_g``.
    varying : iterable of str
        Names of the parameters that take other values (fitted ones, say).

    Returns
    -------
    bool
        Both resistances infinite in *params*, and neither among *varying*.
    """
    return (math.isinf(params.r_sc) and math.isinf(params.r_g)
            and not {"r_sc", "r_g"} & set(varying))


def mean_electrostatic_force(normal_force: ArrayLike, amplitude: ArrayLike,
                             waveform: ArrayLike = "square",
                             params: ModelParameters = TABLE_1, *,
                             frequency: ArrayLike | None = None,
                             force: ForceFunction | None = None) -> NDArray[np.float64]:
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
    frequency : float or ndarray, optional
        Drive frequency, Hz: with finite resistances, A becomes the gap's effective
        amplitude (:func:`gap_amplitude`).
    force : callable, optional
        The contact's electrostatic force ``(normal_force, voltage, params)``; eq. (11),
        :func:`evtribo.model.electrostatic_force`, by default.

    Returns
    -------
    ndarray
        Mean electrostatic force, N.
    """
    func = electrostatic_force if force is None else force
    amp = gap_amplitude(amplitude, frequency, waveform, params)
    fn, amp = np.broadcast_arrays(np.asarray(normal_force, float), amp)
    sine = np.broadcast_to(_is_sine(waveform), fn.shape)
    out = np.asarray(func(fn, amp, params), dtype=float).copy()
    if np.any(sine):
        u = amp[sine][:, None] * np.sin(_PHASES)[None, :]
        out[sine] = np.asarray(func(fn[sine][:, None], u, params),
                               dtype=float).mean(axis=1)
    return out


def mean_electrostatic_force_many(normal_force: ArrayLike, amplitude: ArrayLike,
                                  waveform: ArrayLike, params: ModelParameters,
                                  values: Mapping[str, ArrayLike], *,
                                  frequency: ArrayLike | None = None,
                                  force: ForceFunction | None = None) -> NDArray[np.float64]:
    """:func:`mean_electrostatic_force` at many values of some parameters at once (a fit's
    refits): row k is the force at the points with ``values[name][k]`` for each name.

    The model's functions are evaluated once, on arrays with a leading axis of the values,
    which gives each row the numbers of :func:`mean_electrostatic_force` (the same
    operations, element by element). The values are not checked: check each row (with
    :meth:`ModelParameters.with_values`) first.

    Parameters
    ----------
    normal_force : ndarray, shape (n_points,)
        External normal force at each point, N.
    amplitude : ndarray, shape (n_points,)
        Voltage amplitude A at each point, V.
    waveform : str or ndarray of str
        ``"sine"`` or anything else (square), at each point.
    params : ModelParameters
        The parameters not in *values*.
    values : mapping of str to array_like
        K values of each parameter that varies, SI units.
    frequency : float or ndarray, optional
        As for :func:`mean_electrostatic_force`, with the layers' resistances both
        infinite (the amplitude the gap sees then does not depend on the parameters).
    force : callable, optional
        As for :func:`mean_electrostatic_force`; it must take arrays of parameter values
        (eq. 11's :func:`evtribo.model.electrostatic_force`, the default, does).

    Returns
    -------
    ndarray, shape (K, n_points)

    Raises
    ------
    ValueError
        For points that are not one-dimensional, or a finite resistance with frequencies
        given (the gap's amplitude would then vary with the parameters: use
        :func:`mean_electrostatic_force` for each row).
    """
    func = electrostatic_force if force is None else force
    columns = {name: np.asarray(v, dtype=float).ravel() for name, v in values.items()}
    k = len(next(iter(columns.values()))) if columns else 1
    if frequency is not None and not gap_amplitude_fixed(params, columns):
        raise ValueError("the gap's amplitude varies with the parameters (a finite "
                         "resistance with the drive's frequency): one row at a time")
    fn, amp = np.broadcast_arrays(np.asarray(normal_force, float),
                                  np.asarray(amplitude, float))
    if fn.ndim != 1:
        raise ValueError(f"the points must be one-dimensional, not of shape {fn.shape}")
    sine = np.broadcast_to(_is_sine(waveform), fn.shape)
    out = np.broadcast_to(np.asarray(func(fn, amp, _stacked(params, columns, 1)), float),
                          (k, *fn.shape)).copy()
    if np.any(sine):
        u = amp[sine][:, None] * np.sin(_PHASES)[None, :]
        each = np.asarray(func(fn[sine][:, None], u, _stacked(params, columns, 2)), float)
        out[:, sine] = np.broadcast_to(each, (k, *u.shape)).mean(axis=-1)
    return out


def _stacked(params: ModelParameters, columns: Mapping[str, NDArray[np.float64]],
             trailing: int) -> ModelParameters:
    """*params* with each parameter of *columns* an array of its values along a leading
    axis (and *trailing* axes of length 1, to broadcast against the points)."""
    out = copy.copy(params)
    for name, column in columns.items():
        object.__setattr__(out, name, column.reshape(-1, *([1] * trailing)))
    return out


@fill_doc
def mean_friction_force(normal_force: ArrayLike, amplitude: ArrayLike,
                        waveform: ArrayLike = "square",
                        params: ModelParameters = TABLE_1, *,
                        frequency: ArrayLike | None = None) -> NDArray[np.float64]:
    """Time-averaged model friction force (eq. 5); amplitude 0 is the OFF condition.

    Parameters
    ----------
    %(normal_force)s
    amplitude : float or ndarray
        Amplitude of the drive, V (0: OFF).
    waveform : str or array of str
        ``"square"`` or ``"sine"`` (the model averaged over one period).
    %(params)s
    frequency : float or ndarray, optional
        Drive frequency, Hz (with finite resistances: :func:`gap_amplitude`).

    Returns
    -------
    ndarray
        The friction force, N.
    """
    amp_eff = gap_amplitude(amplitude, frequency, waveform, params)
    on = np.asarray(amplitude, float) != 0  # OFF stays 0 whatever its frequency
    amp_eff = np.where(on, amp_eff, 0.0)
    fn, amp = np.broadcast_arrays(np.asarray(normal_force, float), amp_eff)
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
