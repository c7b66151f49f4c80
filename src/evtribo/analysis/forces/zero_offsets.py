"""Load-cell zero offsets: known from calibration, measured with the finger lifted, or taken out
of the friction loop.

Strain-gauge cells read tens of mN at rest and drift by several mN over a trial. Left in, a
normal-force offset ``d`` biases the electrostatic force by about ``d / F_n`` of itself, and
a tangential offset adds to the friction in one sliding direction and subtracts in the
other. The forces are corrected in three steps (``[analysis] tare``, default ``"auto"``):

1. **calibration** (``[rig.calibration]``): the known offsets are subtracted and the
   cross-talk matrix applied, ``[Fn, Ft] = matrix @ ([Fn, Ft]_measured - offsets)``.
2. **lifted**: wherever the finger is off the screen (the tare stretch at the start of a
   trial, a lift-off) both cells read their zero. :func:`~evtribo.analysis.forces.lifted.
   find_lifted` finds such stretches (the normal force at its floor, well apart from the
   pressing force; both forces as quiet as the cells alone; no friction; a finger that
   left and came back quickly). Each gives both cells' offsets there (means over a whole
   number of 0.1 s, which averages 50 and 60 Hz hum out); between stretches the zero is
   interpolated linearly, and beyond the first and last it follows the nearest segment's
   slope. With one stretch only (the tare stretch at the start), the zero follows the
   drift rate measured within it (a line through its 0.1-s means) when it lasts at least
   ``MIN_SLOPE_S``, and is held otherwise. (A drift rate measured over a second or two is
   uncertain, about 0.07 mN/s for cells with 1 mN of noise at 1 kHz, but a zero that
   drifts by several mN over a trial is the rule; holding it would leave all of that
   drift in.)
3. **friction-loop**: the tangential force of a stroke is ``d * |F| + offset`` with ``d``
   the sliding direction; forward and backward strokes under the same condition tell the
   offset apart from the friction. :func:`friction_loop_offset` fits, over the trial's
   steady-sliding windows, ``F_t = d * (a_g * F_n + b_g) + offset(t)`` by least squares
   (per condition ``g``, OFF or an ON group, a slope and an intercept: friction need not
   be proportional to the load, so only the contrast of the two directions within a
   condition tells the offset; ``offset(t)`` piecewise linear, with as many knots as the
   strokes support), and the offset is subtracted from the tangential force: each
   window's friction is then in effect the half-difference of the loop, whatever offset
   remained. This needs strokes in both directions under one condition. After a lifted
   taring, which measures the zero directly and far more precisely, the loop is not
   applied: a finger's friction differs between forward and backward strokes (posture,
   the ridges' direction; Pasumarty et al. 2011), and the loop cannot tell that from an
   offset; the estimate compares each direction with its own (:mod:`evtribo.analysis.
   friction.reference`). The normal cell's offset cannot come from strokes: without a lifted
   stretch or a calibration it is unknown, and the analysis says so.

``"auto"`` runs the three steps in turn (each on what the previous left); ``"lifted"``,
``"friction-loop"`` and ``"calibration"`` run only that one (after the calibration's
offsets when they are given); ``"none"`` leaves the forces as decoded, save for the
calibration's matrix. What was removed is reported in the cells' own units.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import pandas as pd

from evtribo.analysis.forces.align import AlignedForces
from evtribo.analysis.forces.lifted import (
    EDGE_S,
    HUM_FREE_S,
    MIN_SLOPE_S,
    Lifted,
    find_lifted,
    offset_curve,
)
from evtribo.canlog.rig import Calibration
from evtribo.warning.collect import emitter

log = logging.getLogger(__name__)
emit = emitter(__name__)

FloatArray = npt.NDArray[np.float64]

#: Time per knot of the friction loop's offset curve, s.
LOOP_KNOT_S = 5.0


@dataclass(frozen=True)
class LoopFit:
    """The tangential offset the friction loop shows.

    Attributes
    ----------
    knots_s : ndarray, s
        Knots of the piecewise-linear offset (one: a constant).
    offset_N : ndarray, N
        The offset at the knots.
    offset_se_N : ndarray, N
        Standard errors of ``offset_N`` (from the fit's residuals).
    windows : int
        Windows the fit used (of both directions).
    rms_N : float, N
        Root-mean-square residual of the fit.
    """

    knots_s: FloatArray
    offset_N: FloatArray
    offset_se_N: FloatArray
    windows: int
    rms_N: float

    @property
    def significant(self) -> bool:
        """Whether the offset stands beyond three standard errors anywhere."""
        se = np.where(np.isfinite(self.offset_se_N), self.offset_se_N, np.inf)
        return bool(np.any(np.abs(self.offset_N) > 3 * se))

    def __call__(self, t: npt.ArrayLike) -> FloatArray:
        """The offset at times *t* (held beyond the knots), N."""
        t = np.asarray(t, dtype=np.float64)
        if self.knots_s.size == 1:
            return np.full(t.shape, float(self.offset_N[0]))
        return np.interp(t, self.knots_s, self.offset_N)


def _hats(x: FloatArray, knots: FloatArray) -> FloatArray:
    """Piecewise-linear interpolation basis at *x* (one column per knot)."""
    if knots.size == 1:
        return np.ones((x.size, 1))
    eye = np.eye(knots.size)
    return np.column_stack([np.interp(x, knots, eye[k]) for k in range(knots.size)])


def friction_loop_offset(t: npt.ArrayLike, normal: npt.ArrayLike, tangential: npt.ArrayLike,
                         windows: pd.DataFrame, groups: Sequence[object], *,
                         max_knots: int | None = None) -> LoopFit | None:
    """Fit the tangential offset from forward and backward strokes.

    Model, per window ``i`` (means over its samples): ``F_t,i = d_i * (a[g_i] * F_n,i +
    b[g_i]) + offset(t_i)``, where ``d_i`` is the sliding direction (the sign of the
    friction), ``g_i`` the window's group (OFF, or an ON group) and ``offset`` is piecewise
    linear in time. The offset is only found where a group has windows in both
    directions.

    Parameters
    ----------
    t : array_like of float, s
        Grid times.
    normal, tangential : array_like of float, N
        Forces on the grid (tangential with its sign).
    windows : pandas.DataFrame
        Steady-sliding windows (:func:`evtribo.analysis.friction.windows.find_windows`: ``i_start``,
        ``i_stop``, ``direction``).
    groups : sequence
        Each window's group: None (or NaN) for OFF, any hashable label for an ON group
        (e.g. its amplitude).
    max_knots : int, optional
        Most knots of the offset curve (default: one per :data:`LOOP_KNOT_S`).

    Returns
    -------
    LoopFit or None
        None without at least two windows in each direction.
    """
    t = np.asarray(t, dtype=np.float64)
    fn = np.asarray(normal, dtype=np.float64)
    ft = np.asarray(tangential, dtype=np.float64)
    if windows.empty:
        return None
    i0 = windows.i_start.to_numpy(int)
    i1 = windows.i_stop.to_numpy(int)
    d = windows.direction.to_numpy(float)
    y = np.array([np.nanmean(ft[a:b]) for a, b in zip(i0, i1, strict=True)])
    x = np.array([np.nanmean(fn[a:b]) for a, b in zip(i0, i1, strict=True)])
    c = np.array([np.mean(t[a:b]) for a, b in zip(i0, i1, strict=True)])
    keep = np.isfinite(y) & np.isfinite(x)
    n_pos, n_neg = int(np.sum(keep & (d > 0))), int(np.sum(keep & (d < 0)))
    if min(n_pos, n_neg) < 2:
        return None
    raw = pd.Series(list(groups), dtype=object)
    labels = raw.where(pd.notna(raw), None).to_numpy()
    y, x, c, d, labels = y[keep], x[keep], c[keep], d[keep], labels[keep]
    cols = []
    for h in [None, *sorted({g for g in labels if g is not None}, key=str)]:
        member = np.array([g == h if h is not None else g is None for g in labels], float)
        if member.any():
            cols += [d * x * member, d * member]
    span = float(c.max() - c.min())
    k = 1 + int(span // LOOP_KNOT_S)
    k = min(k, 1 + min(n_pos, n_neg) // 2, max_knots or k)
    while k >= 1:
        knots = np.linspace(c.min(), c.max(), k) if k > 1 else np.array([c.mean()])
        design = np.column_stack([*cols, _hats(c, knots)])
        n, p = design.shape
        if n >= p + 1 and np.linalg.matrix_rank(design) == p:
            coef, *_ = np.linalg.lstsq(design, y, rcond=None)
            resid = y - design @ coef
            s2 = float(resid @ resid) / (n - p)
            cov = s2 * np.linalg.inv(design.T @ design)
            se = np.sqrt(np.clip(np.diag(cov)[len(cols):], 0.0, None))
            return LoopFit(knots_s=knots, offset_N=coef[len(cols):], offset_se_N=se,
                           windows=int(n), rms_N=float(np.sqrt(np.mean(resid**2))))
        k -= 1
    return None


@dataclass
class Tared:
    """The forces with the offsets removed, and what was removed.

    Attributes
    ----------
    forces : AlignedForces
        Calibrated and tared forces.
    lifted : list of Lifted
        The finger-lifted stretches found (in the calibrated forces).
    methods : list of str
        What was applied, in order: ``calibration``, ``lifted``, ``friction-loop``.
    normal_known : bool
        Whether the normal cell's zero was known (from the calibration or a lifted stretch).
    flipped : bool
        The normal force was negated (the cell counts compression negative).
    residual : ndarray, shape (2, n)
        The offsets removed after the calibration, per grid point, in calibrated units.
    """

    forces: AlignedForces
    lifted: list[Lifted] = field(default_factory=list)
    methods: list[str] = field(default_factory=list)
    normal_known: bool = False
    flipped: bool = False
    residual: FloatArray | None = None


def calibrate(aligned: AlignedForces, calibration: Calibration | None) -> Tared:
    """Step 1: the calibration's offsets and matrix (and the normal force's sign, flipped
    where it is negative: said, ``sign-flipped``).

    Parameters
    ----------
    aligned : AlignedForces
        The forces on their grid, as decoded.
    calibration : Calibration or None
        The rig's ``[rig.calibration]``.

    Returns
    -------
    Tared
    """
    cal = calibration or Calibration()
    fn, ft = aligned.normal.copy(), aligned.tangential.copy()
    methods = []
    if cal.normal_offset_N is not None or cal.tangential_offset_N is not None:
        fn -= cal.normal_offset_N or 0.0
        ft -= cal.tangential_offset_N or 0.0
        methods.append("calibration")
    if cal.matrix is not None:
        (a, b), (c, d) = cal.matrix
        fn, ft = a * fn + b * ft, c * fn + d * ft
    flipped = bool(np.nanmedian(fn) < 0)
    if flipped:
        emit("sign-flipped")
        fn = -fn
    n = aligned.t.size
    return Tared(forces=AlignedForces(aligned.t, fn, ft, aligned.rate_Hz), methods=methods,
                 normal_known=cal.normal_offset_N is not None, flipped=flipped,
                 residual=np.zeros((2, n)))


def tare_lifted(tared: Tared, *, min_s: float) -> Tared:
    """Step 2: offsets from the finger-lifted stretches, interpolated between them.

    Parameters
    ----------
    tared : Tared
        The calibrated forces.
    min_s : float
        Shortest finger-lifted stretch used, s.

    Returns
    -------
    Tared
    """
    f = tared.forces
    lifted = find_lifted(f.t, f.normal, f.tangential, min_s=min_s)
    if not lifted:
        return tared
    at = [s.t_mid for s in lifted]
    off_n = offset_curve(f.t, at, [s.normal_N for s in lifted], slope=lifted[0].slope("normal"))
    off_t = offset_curve(f.t, at, [s.tangential_N for s in lifted],
                         slope=lifted[0].slope("tangential"))
    assert tared.residual is not None
    return Tared(forces=AlignedForces(f.t, f.normal - off_n, f.tangential - off_t, f.rate_Hz),
                 lifted=lifted, methods=[*tared.methods, "lifted"], normal_known=True,
                 flipped=tared.flipped, residual=tared.residual + np.vstack([off_n, off_t]))


def tare_loop(tared: Tared, loop: LoopFit) -> Tared:
    """Step 3: subtract the friction loop's tangential offset.

    Parameters
    ----------
    tared : Tared
        The forces tared so far.
    loop : LoopFit
        The friction loop's fit.

    Returns
    -------
    Tared
    """
    f = tared.forces
    off_t = loop(f.t)
    assert tared.residual is not None
    residual = tared.residual.copy()
    residual[1] += off_t
    return Tared(forces=AlignedForces(f.t, f.normal, f.tangential - off_t, f.rate_Hz),
                 lifted=tared.lifted, methods=[*tared.methods, "friction-loop"],
                 normal_known=tared.normal_known, flipped=tared.flipped, residual=residual)


def removed_offsets(tared: Tared, calibration: Calibration | None
                    ) -> tuple[float | None, float | None]:
    """Mean offsets removed from each cell over the trial, in the cell's own units (N);
    None for a cell nothing was removed from.

    Parameters
    ----------
    tared : Tared
        The tared forces.
    calibration : Calibration or None
        The calibration they were tared with.

    Returns
    -------
    (float or None, float or None)
        Normal and tangential, N.
    """
    cal = calibration or Calibration()
    res = np.zeros(2) if tared.residual is None else np.nanmean(tared.residual, axis=1)
    if tared.flipped:
        res = np.array([-res[0], res[1]])
    if cal.matrix is not None:  # residuals are in calibrated units: back to the cells'
        res = np.linalg.solve(np.asarray(cal.matrix), res)
    n_removed = tared.normal_known or "lifted" in tared.methods
    t_removed = cal.tangential_offset_N is not None or bool(
        {"lifted", "friction-loop"} & set(tared.methods))
    normal = (cal.normal_offset_N or 0.0) + float(res[0]) if n_removed else None
    tangential = (cal.tangential_offset_N or 0.0) + float(res[1]) if t_removed else None
    return normal, tangential


__all__ = ["EDGE_S", "HUM_FREE_S", "MIN_SLOPE_S", "Lifted", "LoopFit", "Tared", "calibrate",
           "find_lifted", "friction_loop_offset", "offset_curve", "removed_offsets",
           "tare_lifted", "tare_loop"]
