"""The drive's frequency: the layers as a circuit (an extension of the paper's model).

The seed paper treats the stratum corneum as a perfect insulator and the air gap as a pure
capacitor: its high-frequency limit. Here each layer is a capacitor in parallel with a
resistance, per unit area (study format, section 9):

- stratum corneum: ``c_sc = eps_0 eps_sc / h_sc`` (F/m^2) in parallel with ``r_sc`` (Ohm m^2);
- air gap: ``c_g = eps_0 eps_L / h_L`` in parallel with a leakage ``r_g``;
- insulator: ``c_i = eps_0 eps_i / h_i``.

With ``z = r / (1 + j w r c)`` for each layer (``1 / (j w c_i)`` for the insulator), the gap's
share of a sinusoidal voltage, relative to the paper's capacitive division, is

    H(w) = [z_g / (z_sc + z_g + z_i)] / [(1/c_g) / (1/c_sc + 1/c_g + 1/c_i)]

and the paper's model (eqs. 8, 9, 11) is evaluated with the amplitude the gap sees: for a
sine of amplitude U at f, ``U |H(2 pi f)|`` (the force then oscillates at 2f about its
mean); for a square wave of amplitude U at f, ``U_eff^2 = sum_{k odd} 8 U^2 |H(2 pi k f)|^2
/ (k^2 pi^2)``, the mean square of the filtered wave. With ``r_sc = r_g = inf`` (the
defaults) ``H = 1`` and the paper's model is unchanged at every frequency. A leaky gap
(finite ``r_g``) loses the force below its corner ``1 / (2 pi r_g (c_g + ...))``; a
conducting stratum corneum (finite ``r_sc``) puts more of the voltage on the gap at low
frequency (the Johnsen-Rahbek regime), raising the force.
"""

from __future__ import annotations

from typing import TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evtribo.model.friction import electrostatic_force
from evtribo.model.params import TABLE_1, ModelParameters
from evtribo.util.docstrings import fill_doc

__all__ = ["WAVEFORMS", "effective_voltage", "electrostatic_force_drive", "gap_factor",
           "layer_elastances"]

#: Waveforms of the drive.
WAVEFORMS = ("sine", "square")
#: Odd harmonics summed for a square wave (the rest is added with the last one's gain).
SQUARE_HARMONICS = 400
#: Phases a sine's period is averaged over.
SINE_PHASES = 64


def _f(x: ArrayLike) -> NDArray[np.float64]:
    return np.asarray(x, dtype=float)


_S = TypeVar("_S", bound=np.generic)


def _out(x: NDArray[_S]) -> NDArray[_S]:
    """*x*, or its element when it has no dimension (a scalar in, a scalar out)."""
    return x[()] if x.ndim == 0 else x


@fill_doc
def layer_elastances(params: ModelParameters = TABLE_1, *, h_L: ArrayLike | None = None
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Inverse capacitances per unit area ``1/c = h / (eps_0 eps)`` of the stratum corneum,
    the air gap and the insulator, m^2/F (0 for a layer of zero thickness).

    Parameters
    ----------
    %(params)s
    h_L : float or ndarray, optional
        Air-gap thickness, m; defaults to ``params.h_L``.

    Returns
    -------
    (ndarray, ndarray, ndarray)
        The stratum corneum's, the gap's and the insulator's, m^2/F.
    """
    h = params.h_L if h_L is None else _f(h_L)
    e0 = params.eps_0
    return (_f(params.h_sc / (e0 * params.eps_sc)), _f(h / (e0 * params.eps_L)),
            _f(params.h_i / (e0 * params.eps_i)))


def _impedance(elastance: NDArray[np.float64], resistance: float,
               omega: NDArray[np.float64]) -> NDArray[np.complex128]:
    """``r / (1 + j w r c)`` per unit area, written ``s / (s/r + j w)`` with ``s = 1/c``,
    Ohm m^2 (a pure capacitor for ``r = inf``; 0 for a layer of zero thickness)."""
    g = 0.0 if np.isinf(resistance) else 1.0 / resistance
    return np.asarray(elastance / (elastance * g + 1j * omega), dtype=complex)


def gap_factor(frequency_Hz: ArrayLike, params: ModelParameters = TABLE_1, *,
               h_L: ArrayLike | None = None) -> NDArray[np.complex128]:
    """The gap's share of a sinusoidal voltage relative to the paper's division, ``H(w)``.

    Parameters
    ----------
    frequency_Hz : float or ndarray
        Frequency of the sinusoid, Hz (> 0).
    params : ModelParameters
        Thicknesses, permittivities and the resistances ``r_sc``, ``r_g`` (Ohm m^2).
    h_L : float or ndarray, optional
        Air-gap thickness, m; defaults to ``params.h_L``.

    Returns
    -------
    ndarray of complex
        ``H``; 1 when both resistances are infinite (and when the gap has no thickness).
    """
    f = _f(frequency_Hz)
    if np.any(~(f > 0)):
        raise ValueError("frequency_Hz must be > 0")
    s_sc, s_g, s_i = layer_elastances(params, h_L=h_L)
    if np.isinf(params.r_sc) and np.isinf(params.r_g):  # the paper's capacitors: exactly 1
        return _out(np.ones(np.broadcast_shapes(f.shape, s_g.shape), dtype=complex))
    omega = 2.0 * np.pi * f
    z_sc = _impedance(s_sc, params.r_sc, omega)
    z_g = _impedance(s_g, params.r_g, omega)
    z_i = s_i / (1j * omega)
    with np.errstate(invalid="ignore", divide="ignore"):
        h = (z_g / (z_sc + z_g + z_i)) / (s_g / (s_sc + s_g + s_i))
    return _out(np.where(s_g > 0, h, 1.0 + 0j))


def effective_voltage(voltage: ArrayLike, frequency_Hz: ArrayLike, waveform: str = "square",
                      params: ModelParameters = TABLE_1, *, h_L: ArrayLike | None = None
                      ) -> NDArray[np.float64]:
    """The amplitude the paper's model is evaluated with, for a drive of *voltage* at
    *frequency_Hz*, V.

    Parameters
    ----------
    voltage : float or ndarray
        Amplitude of the applied voltage U, V.
    frequency_Hz : float or ndarray
        Frequency of the drive, Hz (> 0).
    waveform : {"sine", "square"}
        Sine: ``U |H(2 pi f)|``. Square: ``U sqrt(sum_{k odd} 8 |H(2 pi k f)|^2 /
        (k^2 pi^2))``, with :data:`SQUARE_HARMONICS` odd harmonics summed and the rest of
        the series (whose terms sum to 1 when ``H = 1``) added with the last one's gain.
    params : ModelParameters
    h_L : float or ndarray, optional
        Air-gap thickness, m.

    Returns
    -------
    ndarray
        U_eff, V (equal to U when ``r_sc = r_g = inf``).
    """
    if waveform not in WAVEFORMS:
        raise ValueError(f"waveform must be one of {WAVEFORMS}, got {waveform!r}")
    u = np.abs(_f(voltage))
    f = _f(frequency_Hz)
    if waveform == "sine":
        return _out(u * np.abs(gap_factor(f, params, h_L=h_L)))
    k = 2.0 * np.arange(SQUARE_HARMONICS) + 1.0
    shape = np.broadcast_shapes(f.shape, np.shape(h_L) if h_L is not None else ())
    fk = np.broadcast_to(f, shape)[..., None] * k
    hk = h_L if h_L is None else np.broadcast_to(_f(h_L), shape)[..., None]
    gain2 = np.abs(gap_factor(fk, params, h_L=hk)) ** 2
    weights = 8.0 / (k**2 * np.pi**2)
    rest = 1.0 - weights.sum()
    mean_square = (gain2 * weights).sum(axis=-1) + rest * gain2[..., -1]
    return _out(u * np.sqrt(mean_square))


def electrostatic_force_drive(normal_force: ArrayLike, voltage: ArrayLike,
                              frequency_Hz: ArrayLike, waveform: str = "square",
                              params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """Mean electrostatic force of the paper's model (eq. 11) under a drive of *voltage*
    amplitude at *frequency_Hz*, with the gap's share of the voltage (:func:`gap_factor`).

    Parameters
    ----------
    normal_force : float or ndarray
        External normal force, N.
    voltage : float or ndarray
        Amplitude of the applied voltage, V.
    frequency_Hz : float or ndarray
        Frequency of the drive, Hz (> 0).
    waveform : {"sine", "square"}
        Square: eq. 11 at the effective amplitude. Sine: eq. 11 averaged over a period of a
        sine of the effective amplitude (the force oscillates at twice the frequency).
    params : ModelParameters

    Returns
    -------
    ndarray
        F_el, N.
    """
    u_eff = _f(effective_voltage(voltage, frequency_Hz, waveform, params))
    fn = _f(normal_force)
    if waveform == "square":
        return _out(_f(electrostatic_force(fn, u_eff, params)))
    phase = (np.arange(SINE_PHASES) + 0.5) / SINE_PHASES
    shape = np.broadcast_shapes(fn.shape, u_eff.shape)
    u = np.broadcast_to(u_eff, shape)[..., None] * np.sin(2.0 * np.pi * phase)
    forces = _f(electrostatic_force(np.broadcast_to(fn, shape)[..., None], u, params))
    return _out(forces.mean(axis=-1))
