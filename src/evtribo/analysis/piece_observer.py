"""What the analysis of a trial worked on, handed out as it goes: the data of a check of the
trial (:mod:`evtribo.results.trial_view`), which draws the forces, the ON/OFF phases, the
finger-lifted stretches and the windows exactly as
:func:`~evtribo.analysis.trial.analyze_signals` found them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from evtribo.analysis.forces.align import AlignedForces
from evtribo.analysis.forces.lifted import EDGE_S, Lifted

__all__ = ["PieceObserver", "PieceState", "lift_exclusion"]


def lift_exclusion(t: npt.NDArray[np.float64], lifted: list[Lifted]) -> npt.NDArray[np.bool_]:
    """The grid points no window may use because of the finger-lifted stretches: each
    stretch and the finger leaving or touching down around it (``2 * EDGE_S`` each side).

    Parameters
    ----------
    t : ndarray of float64, s
        Grid times.
    lifted : list of Lifted
        The finger-lifted stretches found.

    Returns
    -------
    ndarray of bool
        True where excluded.
    """
    exclude = np.zeros(t.size, dtype=bool)
    for s in lifted:
        exclude |= (t >= s.t_start - 2 * EDGE_S) & (t <= s.t_end + 2 * EDGE_S)
    return exclude


@dataclass(frozen=True)
class PieceState:
    """What the analysis of one continuous piece of a trial worked on and found (the
    figure of a trial's check draws it).

    Attributes
    ----------
    forces : AlignedForces
        The forces on their grid (the log's clock), calibrated, tared, hum removed: those
        the windows' means are taken from.
    condition : ndarray of int8
        ``ON``, ``OFF`` or ``EXCLUDED`` per grid point (:mod:`.conditions`).
    lifted : list of Lifted
        The finger-lifted stretches found.
    windows : pandas.DataFrame
        The windows (:func:`~evtribo.analysis.friction.windows.find_windows`' table: grid indices,
        times on the log's clock, condition, direction, means).
    info : dict
        The excitation's ``waveform``, ``frequency_Hz``, ``amplitude_V``, ``condition``.
    """

    forces: AlignedForces
    condition: npt.NDArray[np.int8]
    lifted: list[Lifted]
    windows: pd.DataFrame
    info: dict[str, Any]


#: Called with each piece's :class:`PieceState` (see :func:`analyze_signals`).
PieceObserver = Callable[[PieceState], None]
