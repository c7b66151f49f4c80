"""The cross-talk matrix of a rig's load cells, measured from calibration recordings.

``F_n,read = F_n + a F_t`` and ``F_t,read = F_t + b F_n`` (:mod:`.crosstalk`). Two recordings
tell them, with nothing but a finger:

- **pressing without sliding** (``evtribo acquire`` with the finger lifted for the tare
  stretch, then pressing harder and lighter, from a light touch to about twice the usual
  force, without moving): the true tangential force stays near zero, so the tangential
  reading's slope against the normal reading is ``b``;
- **sliding back and forth** (any trial of the study): at each reversal the friction swings
  while the pressing hardly changes, so the normal reading's change against the tangential
  one's is ``a``.

The matrix that undoes them, ``[Fn, Ft]_true = M @ [Fn, Ft]_read``, is the inverse of
``[[1, a], [b, 1]]``: what ``[rig.calibration] matrix`` takes.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from evtribo.analysis.forces.align import align_forces
from evtribo.analysis.forces.crosstalk import ReversalSums, reversal_sums
from evtribo.analysis.forces.pieces import continuous_pieces, restrict
from evtribo.analysis.forces.timebase import sample_times
from evtribo.analysis.piece_observer import PieceState
from evtribo.analysis.settings import AnalysisSettings
from evtribo.analysis.trial import TrialMeta, analyze_signals
from evtribo.canlog.rig import Calibration
from evtribo.canlog.signals import TrialSignals
from evtribo.errors import AnalysisError
from evtribo.util.running import moving_average

__all__ = [
    "MAX_SE",
    "MAX_SLIDING_SHARE",
    "MIN_PRESS_RANGE",
    "SIGNIFICANT_SE",
    "CrossTalk",
    "crosstalk_matrix",
    "pressing_slope",
    "reversal_slope",
]

#: The press recording's normal force must span at least this share of its mean.
MIN_PRESS_RANGE = 0.5
#: A 0.1-s mean counts as pressing when the normal force is above this share of its 95th
#: percentile and the tangential reading within this share of the normal one.
PRESS_LOAD, PRESS_SHEAR = 0.2, 0.25
#: A press recording in which the tangential reading is beyond :data:`PRESS_SHEAR` of the
#: normal one for more than this share of the loaded time is of a finger sliding.
MAX_SLIDING_SHARE = 0.3
#: A share measured less precisely than this (its standard error) is not put into a matrix:
#: a term off by that much moves the other cell's reading by 1.5 % of this one's (3 % of
#: the friction at a friction coefficient of 0.5), as large as the cross-talk it corrects.
MAX_SE = 0.015
#: A share within this many standard errors of zero is no cross-talk.
SIGNIFICANT_SE = 2.0


@dataclass(frozen=True)
class CrossTalk:
    """The cross-talk found, and the matrix that undoes it.

    Attributes
    ----------
    a, a_se : float
        Share of the tangential force the normal cell reads (NaN: no sliding recording).
    b, b_se : float
        Share of the normal force the tangential cell reads (NaN: no press recording).
    reversals : int
        Reversals behind ``a``.
    press_s : float, s
        Pressing behind ``b``.
    """

    a: float
    a_se: float
    b: float
    b_se: float
    reversals: int
    press_s: float

    def verdict(self, term: str) -> str:
        """What the recordings tell of one share: ``"not measured"``, ``"imprecise"``
        (its standard error over :data:`MAX_SE`), ``"none"`` (within
        :data:`SIGNIFICANT_SE` standard errors of zero) or ``"found"``.

        Parameters
        ----------
        term : str
            ``"a"`` or ``"b"``.

        Returns
        -------
        str
        """
        value, se = (self.a, self.a_se) if term == "a" else (self.b, self.b_se)
        if np.isnan(value):
            return "not measured"
        if not se <= MAX_SE:
            return "imprecise"
        return "found" if abs(value) > SIGNIFICANT_SE * se else "none"

    @property
    def matrix(self) -> list[list[float]] | None:
        """``[rig.calibration] matrix``: the inverse of ``[[1, a], [b, 1]]``, each share
        taken as 0 unless it was found (:meth:`verdict`); None when neither was."""
        a = self.a if self.verdict("a") == "found" else 0.0
        b = self.b if self.verdict("b") == "found" else 0.0
        if a == 0.0 and b == 0.0:
            return None
        inv = np.linalg.inv(np.array([[1.0, a], [b, 1.0]]))
        return [[round(float(x), 6) for x in row] for row in inv]


def pressing_slope(signals: TrialSignals) -> tuple[float, float, float]:
    """``b`` from a recording of the finger pressing without sliding.

    Parameters
    ----------
    signals : TrialSignals
        The decoded recording.

    Returns
    -------
    b, b_se : float
    press_s : float, s
        The time found pressing.

    Raises
    ------
    AnalysisError
        No pressing found, a force that hardly varied, or a finger that slid (the
        tangential reading a friction coefficient's worth of the normal one).
    """
    fn, ft, m, rate_Hz = _tenths(signals)
    if fn.size < 10:
        raise AnalysisError("the recording is too short to calibrate from")
    floor = float(np.percentile(fn, 2))
    top = float(np.percentile(fn, 95)) - floor
    loaded = fn - floor > PRESS_LOAD * top
    pressing = loaded & (np.abs(ft - np.median(ft)) < PRESS_SHEAR * (fn - floor))
    if loaded.any():
        _refuse_sliding(np.abs(ft[loaded] - np.median(ft[loaded])) / (fn[loaded] - floor))
    if pressing.sum() < 20:
        raise AnalysisError("no pressing without sliding found: press with the finger "
                            "still, harder and lighter, after the tare stretch")
    x, y = fn[pressing], ft[pressing]
    if np.ptp(x) < MIN_PRESS_RANGE * np.mean(x - floor):
        raise AnalysisError(f"the pressing force spans only {np.ptp(x):.3f} N: press from a "
                            "light touch to about twice the usual force")
    slope, icpt = np.polyfit(x, y, 1)
    resid = y - (icpt + slope * x)
    # 0.1-s means of a slowly varying press are correlated: count a second as one value
    n_eff = max(3.0, pressing.sum() / 10.0)
    se = float(np.sqrt(np.sum(resid**2) / (x.size - 2) / np.sum((x - x.mean()) ** 2)
                       * x.size / n_eff))
    return float(slope), se, float(pressing.sum() * m / rate_Hz)


def _tenths(signals: TrialSignals) -> tuple[np.ndarray, np.ndarray, int, float]:
    """The forces' means over 0.1 s (the finite ones, N), piece by piece (a jump of the
    log's clock or a pause is no time to align over), the samples in each mean and the
    rate."""
    fn, ft, m, rate = [], [], 1, 0.0
    for lo, hi in continuous_pieces(signals):
        piece = restrict(signals, lo, hi)
        if min(len(piece.normal.t), len(piece.tangential.t)) < 2:
            continue
        tn = sample_times(piece.normal.t, piece.normal.counter, piece.normal.counter_period)
        tt = sample_times(piece.tangential.t, piece.tangential.counter,
                          piece.tangential.counter_period)
        try:
            f = align_forces(tn, np.asarray(piece.normal.value, float), tt,
                             np.asarray(piece.tangential.value, float))
        except AnalysisError:
            continue  # a piece the cells do not share
        rate = rate or f.rate_Hz
        m = max(1, round(0.1 * rate))
        fn.append(moving_average(f.normal, m, min_fraction=0.9)[::m])
        ft.append(moving_average(f.tangential, m, min_fraction=0.9)[::m])
    if not fn:
        raise AnalysisError("the recording is too short to calibrate from")
    n, t = np.concatenate(fn), np.concatenate(ft)
    ok = np.isfinite(n) & np.isfinite(t)
    return n[ok], t[ok], m, rate


def _refuse_sliding(ratio: np.ndarray) -> None:
    """Refuse a press recording whose tangential reading is, most of the loaded time, a
    friction coefficient's worth of the normal one: the finger slid."""
    if ratio.size == 0:
        return
    share = float(np.mean(ratio >= PRESS_SHEAR))
    if share > MAX_SLIDING_SHARE:
        raise AnalysisError(
            f"not a recording of the finger pressing without sliding: the tangential force "
            f"was over {100 * PRESS_SHEAR:.0f} % of the normal force in {100 * share:.0f} % "
            f"of the time the finger pressed (median {100 * float(np.median(ratio)):.0f} %: "
            "a friction coefficient's worth), so the finger slid; record the finger pressing "
            "still, harder and lighter, after the tare stretch (`evtribo simulate --study "
            "STUDY --press-only` rehearses one)")


def reversal_slope(trials: Sequence[tuple[TrialSignals, TrialMeta]],
                   settings: AnalysisSettings | None = None) -> ReversalSums:
    """The reversals of sliding recordings, pooled (``a`` is their slope).

    Parameters
    ----------
    trials : sequence of (TrialSignals, TrialMeta)
        Decoded recordings with the finger sliding back and forth, analysed without any
        cross-talk matrix.
    settings : AnalysisSettings, optional

    Returns
    -------
    ReversalSums
    """
    total = ReversalSums()
    for signals, meta in trials:
        states: list[PieceState] = []
        analyze_signals(signals, meta, settings=settings, calibration=Calibration(),
                        observe=states.append)
        for s in states:
            total = total + reversal_sums(s.forces.t, s.forces.normal, s.forces.tangential,
                                          s.windows)
    return total


def crosstalk_matrix(press: TrialSignals | None,
                     sliding: Sequence[tuple[TrialSignals, TrialMeta]],
                     settings: AnalysisSettings | None = None) -> CrossTalk:
    """The cross-talk of a rig from its calibration recordings.

    Parameters
    ----------
    press : TrialSignals or None
        A recording of the finger pressing without sliding.
    sliding : sequence of (TrialSignals, TrialMeta)
        Recordings of the finger sliding.
    settings : AnalysisSettings, optional

    Returns
    -------
    CrossTalk

    Raises
    ------
    AnalysisError
        Neither recording tells anything.
    """
    nan = float("nan")
    b, b_se, press_s = pressing_slope(press) if press is not None else (nan, nan, 0.0)
    sums = reversal_slope(sliding, settings) if sliding else ReversalSums()
    if np.isnan(b) and not sums.n >= 3:
        raise AnalysisError("no pressing and fewer than 3 reversals of the strokes: nothing "
                            "to calibrate from")
    return CrossTalk(sums.slope, sums.slope_se, b, b_se, sums.n, press_s)

