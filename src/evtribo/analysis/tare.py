"""Load-cell zero offsets: known from calibration, measured with the finger lifted, or taken out
of the friction loop.

Strain-gauge cells read tens of mN at rest and drift by several mN over a trial. Left in, a
normal-force offset ``d`` biases the electrostatic force by about ``d / F_n`` of itself, and
a tangential offset adds to the friction in one sliding direction and subtracts in the
other. The forces are corrected in three steps (``[analysis] tare``, default ``"auto"``):

1. **calibration** (``[rig.calibration]``): the known offsets are subtracted and the
   cross-talk matrix applied, ``[Fn, Ft] = matrix @ ([Fn, Ft]_measured - offsets)``.
2. **lifted**: wherever the finger is off the screen (the tare stretch at the start of a
   trial, a lift-off) both cells read their zero. :func:`find_lifted` finds such stretches:
   the normal force at its floor, well apart from the pressing force, both forces quiet (no
   sliding). Each gives both cells' offsets there (means over a whole number of 0.1 s, which
   averages 50 and 60 Hz hum out); between stretches the zero is interpolated linearly, and
   beyond the first and last it follows the nearest segment's slope. With one stretch only
   (the tare stretch at the start), the zero follows the drift rate measured within it (a
   line through its 0.1-s means) when it lasts at least :data:`MIN_SLOPE_S`, and is held
   otherwise. (A drift rate measured over a second or two is uncertain, about 0.07 mN/s
   for cells with 1 mN of noise at 1 kHz, but a zero that drifts by several mN over a
   trial is the rule; holding it would leave all of that drift in.)
3. **friction-loop**: the tangential force of a stroke is ``d * |F| + offset`` with ``d`` the
   sliding direction; forward and backward strokes under the same condition tell the
   offset apart from the friction. :func:`friction_loop_offset` fits, over the trial's
   steady-sliding windows, ``F_t = d * (a_g * F_n + b_g) + offset(t)`` by least squares
   (per condition ``g``, OFF or an ON group, a slope and an intercept: friction need not be
   proportional to the load, so only the contrast of the two directions within a
   condition tells the offset; ``offset(t)`` piecewise linear, with as many knots as the
   strokes support), and the offset is subtracted: each
   window's friction is then in effect the half-difference of the loop, whatever offset
   remained. This needs strokes in both directions. After a lifted taring, which measures
   the zero directly and far more precisely, the loop's offset is applied only where it is
   significant (beyond three standard errors). The normal cell's offset cannot come from
   strokes: without a lifted stretch or a calibration it is unknown, and the analysis says
   so.

``"auto"`` runs the three steps in turn (each on what the previous left); ``"lifted"``,
``"friction-loop"`` and ``"calibration"`` run only that one (after the calibration's
offsets when they are given); ``"none"`` leaves the forces as decoded, save for the
calibration's matrix. What was removed is reported in the cells' own units.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import pandas as pd

from evtribo.analysis.align import AlignedForces
from evtribo.analysis.windows import moving_average, true_runs
from evtribo.rig import Calibration

log = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]

#: Span over which forces are averaged to find lifted stretches: a whole number of periods
#: of both 50 Hz and 60 Hz hum, s.
HUM_FREE_S = 0.1
#: Trimmed from each end of a lifted stretch (the finger leaving or touching), beyond the
#: half-span of the 0.1-s average that found it, s.
EDGE_S = 0.05
#: A lifted stretch's normal force lies within this fraction of the pressing force above
#: the floor.
LIFT_FRACTION = 0.1
#: A finger leaves the screen and comes back within this time, s.
STEP_S = 0.3
#: With the finger lifted, the forces' 0.1-s means stray from a line by at most this many
#: times what the load cells' own noise gives them.
QUIET = 10.0
#: Largest friction coefficient of a finger: a friction larger than this many times the
#: pressing force above the floor means the floor is a lighter press, not a lifted finger.
MAX_MU = 3.0
#: A lifted stretch this long gives the drift rate a single stretch is extrapolated with, s.
MIN_SLOPE_S = 1.0
#: Time per knot of the friction loop's offset curve, s.
LOOP_KNOT_S = 5.0


@dataclass(frozen=True)
class Lifted:
    """A stretch with the finger off the screen.

    Attributes
    ----------
    i_start, i_stop : int
        Grid indices of the part used (exclusive stop).
    t_start, t_end : float, s
        Grid times of the whole stretch, transitions trimmed.
    normal_N, tangential_N : float, N
        Mean reading of each cell there.
    normal_se_N, tangential_se_N : float, N
        Standard errors of those means.
    normal_slope, tangential_slope : float, N/s
        Drift rate of each cell's zero within the stretch (a line through its 0.1-s means;
        NaN when it is shorter than three of them).
    normal_slope_se, tangential_slope_se : float, N/s
        Their standard errors.
    """

    i_start: int
    i_stop: int
    t_start: float
    t_end: float
    normal_N: float
    tangential_N: float
    normal_se_N: float
    tangential_se_N: float
    normal_slope: float = float("nan")
    tangential_slope: float = float("nan")
    normal_slope_se: float = float("nan")
    tangential_slope_se: float = float("nan")

    def slope(self, cell: str) -> float:
        """The drift rate of *cell* (``"normal"``/``"tangential"``) when the stretch is long
        enough to measure it (:data:`MIN_SLOPE_S`), else 0, N/s."""
        rate = getattr(self, f"{cell}_slope")
        long_enough = self.t_end - self.t_start >= MIN_SLOPE_S
        return float(rate) if long_enough and np.isfinite(rate) else 0.0

    @property
    def t_mid(self) -> float:
        """Middle of the stretch, s."""
        return 0.5 * (self.t_start + self.t_end)


def _span(t: FloatArray) -> float:
    return float(np.median(np.diff(t))) if t.size > 1 else float("nan")


@dataclass(frozen=True)
class _Line:
    """A line through the 0.1-s block means of a stretch of one force."""

    slope: float  # N/s
    slope_se: float  # N/s
    scatter: float  # N, standard deviation of the block means about the line
    noise: float  # N, what white noise of the samples' own size gives to a block mean


def _block_line(t: FloatArray, x: FloatArray, m: int) -> _Line:
    """Fit a line to the means of blocks of *m* samples (NaNs where there are fewer than
    three blocks)."""
    k = x.size // m
    steps = np.diff(x[np.isfinite(x)])
    noise = float(np.std(steps) / np.sqrt(2 * m)) if steps.size > 2 else float("nan")
    nan = float("nan")
    if k < 2:
        return _Line(nan, nan, nan, noise)
    tb = t[:k * m].reshape(k, m).mean(axis=1)
    xb = np.nanmean(x[:k * m].reshape(k, m), axis=1)
    good = np.isfinite(xb)
    tb, xb = tb[good], xb[good]
    if xb.size < 3:
        return _Line(nan, nan, float(np.ptp(xb)) if xb.size else nan, noise)
    tc = tb - tb.mean()
    slope = float(tc @ (xb - xb.mean()) / (tc @ tc))
    resid = xb - xb.mean() - slope * tc
    scatter = float(np.sqrt(resid @ resid / (xb.size - 2)))
    return _Line(slope, scatter / float(np.sqrt(tc @ tc)), scatter, noise)


def find_lifted(t: npt.ArrayLike, normal: npt.ArrayLike, tangential: npt.ArrayLike, *,
                min_s: float = 0.2) -> list[Lifted]:
    """Stretches of a trial where the finger is off the screen.

    A stretch counts when, over at least *min_s* (after trimming :data:`EDGE_S` at each
    end of the 0.1-s averaged forces):

    - the normal force lies at its floor: within :data:`LIFT_FRACTION` of the pressing force
      (its 75th percentile less the floor) above the floor (its 0.25th percentile);
    - both forces are as quiet as the load cells alone: their 0.1-s means stray from a line
      by no more than :data:`QUIET` times what the samples' own noise gives (a finger on
      the screen is never that still, whatever it does);
    - the floor is a finger off the screen, not a lighter press: the friction while sliding
      is at most :data:`MAX_MU` times the pressing force above the floor, and the normal
      force while sliding stays clear above the stretch's level (its 1st percentile at
      least :data:`LIFT_FRACTION` of the pressing force above it);
    - the tangential force is no friction: it lies between the forward and the backward
      sliding levels (10th and 90th percentiles), away from both by a fifth of their gap;
    - the finger left and came back as fingers do, quickly: within :data:`STEP_S` of the
      stretch (on each side that is inside the trial) the normal force is back to half the
      pressing force (a lighter press that slowly wanders to the floor is no lift).

    Parameters
    ----------
    t : array_like of float, s
        Uniform grid.
    normal, tangential : array_like of float, N
        The forces on the grid (NaN in gaps), any zero offsets still in them.
    min_s : float, s
        Shortest stretch kept.

    Returns
    -------
    list of Lifted
        In time order; empty when the finger never left.
    """
    t = np.asarray(t, dtype=np.float64)
    fn = np.asarray(normal, dtype=np.float64)
    ft = np.asarray(tangential, dtype=np.float64)
    dt = _span(t)
    if not (t.size > 10 and dt > 0):
        return []
    m = max(1, round(HUM_FREE_S / dt))
    fn_s = moving_average(fn, m, min_fraction=0.9)
    ft_s = moving_average(ft, m, min_fraction=0.9)
    ok = np.isfinite(fn_s) & np.isfinite(ft_s)
    if ok.sum() < 10:
        return []
    # levels from the 0.1-s means taken every 10 ms (as good, and cheaper than every sample)
    step_10ms = slice(None, None, max(1, m // 10))
    fn_d, ft_d, ok_d = fn_s[step_10ms], ft_s[step_10ms], ok[step_10ms]
    floor = float(np.percentile(fn_d[ok_d], 0.25))
    span = float(np.percentile(fn_d[ok_d], 75)) - floor
    if not span > 0:
        return []
    contact = ok_d & (fn_d > floor + LIFT_FRACTION * span)
    if contact.sum() < 10:
        return []
    back, fwd = (float(v) for v in np.percentile(ft_d[contact], [10, 90]))
    gap = fwd - back
    if 0.5 * gap > MAX_MU * span:  # the floor is no lifted finger: the load hardly varies
        return []
    mid_band = (back + 0.2 * gap, fwd - 0.2 * gap)
    sliding = contact & ((ft_d > fwd - 0.3 * gap) | (ft_d < back + 0.3 * gap))
    lightest = float(np.percentile(fn_d[sliding], 1)) if sliding.any() else -np.inf
    low = ok & (fn_s <= floor + LIFT_FRACTION * span)
    edge = round(EDGE_S / dt)
    step = round(STEP_S / dt)
    half = floor + 0.5 * span
    out = []
    for a, b in true_runs(low):
        a2, b2 = a + edge, b - edge
        if (b2 - a2) * dt < min_s:
            continue
        before, after = fn_s[max(a - step, 0):a], fn_s[b:b + step]
        inside_before = a - step >= 0 and np.isfinite(fn_s[a - step])
        inside_after = b + step <= fn_s.size and np.isfinite(fn_s[b + step - 1])
        if (inside_before and not np.nanmax(before) >= half) \
                or (inside_after and not np.nanmax(after) >= half):
            continue
        length = (b2 - a2) // m * m or (b2 - a2)
        c0 = a2 + (b2 - a2 - length) // 2
        seg = slice(c0, c0 + length)
        seg_n, seg_t = fn[seg], ft[seg]
        good = np.isfinite(seg_n) & np.isfinite(seg_t)
        if good.sum() < 2 * m:
            continue
        level_n, level_t = float(np.mean(seg_n[good])), float(np.mean(seg_t[good]))
        if not (level_n <= lightest - LIFT_FRACTION * span
                and mid_band[0] <= level_t <= mid_band[1]):
            continue
        line_n, line_t = _block_line(t[seg], seg_n, m), _block_line(t[seg], seg_t, m)
        if not all(line.scatter <= max(QUIET * line.noise, 0.005 * span)
                   for line in (line_n, line_t)):
            continue
        k = int(good.sum())
        out.append(Lifted(
            i_start=int(c0), i_stop=int(c0 + length), t_start=float(t[a2]),
            t_end=float(t[b2 - 1] + dt), normal_N=level_n, tangential_N=level_t,
            normal_se_N=float(np.std(seg_n[good]) / np.sqrt(k)),
            tangential_se_N=float(np.std(seg_t[good]) / np.sqrt(k)),
            normal_slope=line_n.slope, tangential_slope=line_t.slope,
            normal_slope_se=line_n.slope_se, tangential_slope_se=line_t.slope_se))
    return out


def offset_curve(t: npt.ArrayLike, at: Sequence[float], values: Sequence[float], *,
                 slope: float = 0.0) -> FloatArray:
    """A zero that drifts: linear between the points ``(at, values)``, following the nearest
    segment's slope beyond them (with one point: the line of the given *slope*).

    Parameters
    ----------
    t : array_like of float, s
        Where to evaluate.
    at, values : sequence of float
        Times (s, increasing) and offsets (N) measured there.
    slope : float, N/s
        Drift rate through a single point.
    """
    t = np.asarray(t, dtype=np.float64)
    x = np.asarray(at, dtype=np.float64)
    y = np.asarray(values, dtype=np.float64)
    if x.size == 1:
        return y[0] + slope * (t - x[0])
    out = np.interp(t, x, y)
    lo, hi = t < x[0], t > x[-1]
    out[lo] = y[0] + (t[lo] - x[0]) * (y[1] - y[0]) / (x[1] - x[0])
    out[hi] = y[-1] + (t[hi] - x[-1]) * (y[-1] - y[-2]) / (x[-1] - x[-2])
    return out


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
                         windows: pd.DataFrame, groups: npt.ArrayLike, *,
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
        Steady-sliding windows (:func:`evtribo.analysis.windows.find_windows`: ``i_start``,
        ``i_stop``, ``direction``).
    groups : array_like
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


def calibrate(aligned: AlignedForces, calibration: Calibration | None,
              warn: Callable[[str], None]) -> Tared:
    """Step 1: the calibration's offsets and matrix (and the normal force's sign)."""
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
        warn("the normal force is negative: its sign is flipped (compression counted "
             "positive)")
        fn = -fn
    n = aligned.t.size
    return Tared(forces=AlignedForces(aligned.t, fn, ft, aligned.rate_Hz), methods=methods,
                 normal_known=cal.normal_offset_N is not None, flipped=flipped,
                 residual=np.zeros((2, n)))


def tare_lifted(tared: Tared, *, min_s: float) -> Tared:
    """Step 2: offsets from the finger-lifted stretches, interpolated between them."""
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
    """Step 3: subtract the friction loop's tangential offset."""
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
    None for a cell nothing was removed from."""
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


__all__ = ["EDGE_S", "HUM_FREE_S", "Lifted", "LoopFit", "Tared", "calibrate", "find_lifted",
           "friction_loop_offset", "offset_curve", "removed_offsets", "tare_lifted",
           "tare_loop"]
