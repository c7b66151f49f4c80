"""How much of a trial its windows used, and why the rest was left out: trials.csv's seconds.

While a trial is analysed, each continuous piece it is analysed in is handed to a
:class:`TrialSeconds` (an observer of :func:`~evtribo.analysis.trial.analyze_signals`),
which counts the piece's grid points by what became of them, each point once, in this
order:

- ``analysed_s``: inside a steady-sliding window (ON or OFF);
- ``excluded_lift_s``: the finger lifted, and leaving or touching down around it
  (:func:`~evtribo.analysis.piece_observer.lift_exclusion`, as the window search excludes it);
- ``excluded_switch_s``: the guard time around an ON/OFF switch (``guard_s`` each side);
- ``excluded_other_s``: no status frame tells ON from OFF there, or a load cell's data are
  missing;
- ``excluded_unsteady_s``: the rest, which the window search found not to be steady
  sliding (reversals, rests, stick phases, a pressing force that moved).

The five add up to the trial's ``duration_s`` (the pieces' total, for a trial analysed in
pieces), to a grid step per piece.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from evtribo.analysis.forces.conditions import EXCLUDED, OFF, ON
from evtribo.analysis.piece_observer import PieceState, lift_exclusion
from evtribo.util.running import true_runs

__all__ = ["SECONDS_COLUMNS", "TrialSeconds"]

#: trials.csv's columns of seconds, in their order.
SECONDS_COLUMNS = ("analysed_s", "excluded_switch_s", "excluded_lift_s",
                   "excluded_unsteady_s", "excluded_other_s")


def _switches(condition: npt.NDArray[np.int8]) -> npt.NDArray[np.bool_]:
    """The excluded runs between an ON and an OFF stretch (the guard around a switch)."""
    out = np.zeros(condition.size, dtype=bool)
    for a, b in true_runs(condition == EXCLUDED):
        before = int(condition[a - 1]) if a > 0 else EXCLUDED
        after = int(condition[b]) if b < condition.size else EXCLUDED
        if {before, after} == {ON, OFF}:
            out[a:b] = True
    return out


class TrialSeconds:
    """Counts the seconds of a trial by what became of them (:data:`SECONDS_COLUMNS`)."""

    def __init__(self) -> None:
        self.seconds = dict.fromkeys(SECONDS_COLUMNS, 0.0)

    def __call__(self, piece: PieceState) -> None:
        """Count one analysed piece.

        Parameters
        ----------
        piece : PieceState
            What the analysis of the piece worked on.

        Returns
        -------
        None
        """
        f = piece.forces
        n = f.t.size
        if n == 0 or not f.rate_Hz > 0:
            return
        dt = 1.0 / f.rate_Hz
        left = np.ones(n, dtype=bool)

        def take(mask: npt.NDArray[np.bool_], column: str) -> None:
            nonlocal left
            mine = mask & left
            self.seconds[column] += float(np.count_nonzero(mine)) * dt
            left &= ~mine

        in_window = np.zeros(n, dtype=bool)
        w = piece.windows
        if len(w) and {"i_start", "i_stop"} <= set(w.columns):
            for a, b in zip(w["i_start"].to_numpy(np.int64), w["i_stop"].to_numpy(np.int64),
                            strict=True):
                in_window[max(a, 0):min(b, n)] = True
        take(in_window, "analysed_s")
        take(lift_exclusion(f.t, piece.lifted), "excluded_lift_s")
        cond = np.asarray(piece.condition)
        if cond.size == n:
            switch = _switches(cond)
            take(switch, "excluded_switch_s")
            take(cond == EXCLUDED, "excluded_other_s")
        take(~(np.isfinite(f.normal) & np.isfinite(f.tangential)), "excluded_other_s")
        take(left.copy(), "excluded_unsteady_s")

    def columns(self) -> dict[str, float]:
        """The seconds counted, rounded to the microsecond.

        Returns
        -------
        dict
            :data:`SECONDS_COLUMNS` -> s.
        """
        return {k: round(v, 6) for k, v in self.seconds.items()}
