"""ON/OFF condition of every grid point, from the amplifier's status or the sidecar.

The amplifier reports whether the high voltage is on in status frames. The switch happened
somewhere between the last frame with the old state and the first with the new one; that
interval, widened by a guard time on both sides (the load cells' and the finger's response),
is excluded. Before the first status frame, and after the last one for longer than a few
status periods, the state is unknown and excluded too.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from evtribo.analysis.forces.align import nominal_period

#: Grid-point codes.
OFF = 0
ON = 1
EXCLUDED = -1

#: Time excluded on both sides of an ON/OFF switch, s.
DEFAULT_GUARD_S = 0.15

_NAMES = {"on": ON, "off": OFF}


def constant_condition(n: int, condition: str) -> npt.NDArray[np.int8]:
    """Every one of *n* grid points in the same condition (``"on"`` or ``"off"``).

    Parameters
    ----------
    n : int
        Number of grid points.
    condition : {"on", "off"}
        The whole trial's condition, as the sidecar gives it.

    Returns
    -------
    ndarray of int8
        ``ON`` or ``OFF`` codes.
    """
    if condition not in _NAMES:
        raise ValueError(f"condition must be 'on' or 'off' for a whole trial, got {condition!r}")
    return np.full(n, _NAMES[condition], dtype=np.int8)


def condition_from_excitation(
    t_grid: npt.ArrayLike,
    t_excitation: npt.ArrayLike,
    enabled: npt.ArrayLike,
    *,
    guard_s: float = DEFAULT_GUARD_S,
    max_hold_periods: float = 3.0,
) -> npt.NDArray[np.int8]:
    """The condition at every grid point from the amplifier's ON/OFF status samples.

    Parameters
    ----------
    t_grid : array_like of float, s
        Grid times, on the clock of ``t_excitation``.
    t_excitation : array_like of float, s
        Times of the status samples.
    enabled : array_like of bool or int
        High voltage on (nonzero) or off (0) at each status sample.
    guard_s : float, s
        Excluded before the last sample of the old state and after the first of the new one.
    max_hold_periods : float
        After the last status sample the state is held this many status periods, then unknown.

    Returns
    -------
    ndarray of int8
        ``ON``, ``OFF`` or ``EXCLUDED`` for each grid point.
    """
    t_grid = np.asarray(t_grid, dtype=np.float64)
    te = np.asarray(t_excitation, dtype=np.float64).ravel()
    on = np.asarray(enabled).ravel().astype(bool)
    out = np.full(t_grid.shape, EXCLUDED, dtype=np.int8)
    if te.size == 0:
        return out
    order = np.argsort(te, kind="stable")
    te, on = te[order], on[order]
    idx = np.searchsorted(te, t_grid, side="right") - 1
    known = idx >= 0
    period = nominal_period(te) if te.size > 1 else 0.0
    hold = max_hold_periods * period if np.isfinite(period) else 0.0
    known &= t_grid <= te[-1] + hold
    out[known] = np.where(on[idx[known]], ON, OFF)
    switches = np.flatnonzero(on[1:] != on[:-1])
    # each switch between te[k] (old state) and te[k+1] (new state)
    los = np.searchsorted(t_grid, te[switches] - guard_s, side="left")
    his = np.searchsorted(t_grid, te[switches + 1] + guard_s, side="right")
    for lo, hi in zip(los.tolist(), his.tolist(), strict=True):
        out[lo:hi] = EXCLUDED
    return out


def condition_name(code: int) -> str:
    """``"on"`` or ``"off"`` for a grid-point code.

    Parameters
    ----------
    code : int
        ``ON`` or ``OFF``.

    Returns
    -------
    str
    """
    return "on" if code == ON else "off" if code == OFF else "excluded"


__all__ = ["DEFAULT_GUARD_S", "EXCLUDED", "OFF", "ON", "condition_from_excitation",
           "condition_name", "constant_condition"]
