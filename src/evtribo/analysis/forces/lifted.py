"""Stretches with the finger off the screen, and the drift of the load cells' zeros between them.

With the finger lifted both load cells read their zero. :func:`find_lifted` finds such
stretches in a trial's forces (the tare stretch an operator records at the start, and any
lift-off) and measures each cell's zero there; :func:`offset_curve` follows the zero's drift
through the trial from them. The rest of the taring is in
:mod:`evtribo.analysis.forces.zero_offsets`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from evtribo.util.median import median
from evtribo.util.running import moving_average, true_runs

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
    """The grid's step, s (NaN with fewer than two points)."""
    return median(np.diff(t)) if t.size > 1 else float("nan")


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
    levels = _levels(fn_s, ft_s, ok, m)
    if levels is None:
        return []
    low = ok & (fn_s <= levels.floor_N + LIFT_FRACTION * levels.press_N)
    edge = round(EDGE_S / dt)
    out = []
    for a, b in true_runs(low):
        if (b - a - 2 * edge) * dt < min_s or not _left_quickly(fn_s, a, b, dt, levels):
            continue
        found = _measure(t, fn, ft, stretch=(a + edge, b - edge), m=m, dt=dt, levels=levels)
        if found is not None:
            out.append(found)
    return out


@dataclass(frozen=True)
class _Levels:
    """A trial's force levels, from its 0.1-s means, that tell a lifted finger."""

    floor_N: float
    """The normal force's floor (its 0.25th percentile)."""
    press_N: float
    """The pressing force above the floor (the normal force's 75th percentile less it)."""
    backward_N: float
    """The friction sliding one way (10th percentile while in contact)."""
    forward_N: float
    """The friction sliding the other way (90th percentile while in contact)."""
    lightest_N: float
    """The lightest normal force while sliding (1st percentile; -inf without sliding)."""

    @property
    def gap_N(self) -> float:
        """Between the two sliding levels."""
        return self.forward_N - self.backward_N


def _levels(fn_s: FloatArray, ft_s: FloatArray, ok: npt.NDArray[np.bool_], m: int
            ) -> _Levels | None:
    """The trial's levels (:class:`_Levels`); None when the forces cannot show a lifted
    finger (no pressing, too little contact, a load that hardly varies)."""
    # levels from the 0.1-s means taken every 10 ms (as good, and cheaper than every sample)
    step_10ms = slice(None, None, max(1, m // 10))
    fn_d, ft_d, ok_d = fn_s[step_10ms], ft_s[step_10ms], ok[step_10ms]
    if ok_d.sum() < 10:  # the usable means fall between the 10-ms samples
        return None
    floor = float(np.percentile(fn_d[ok_d], 0.25))
    press = float(np.percentile(fn_d[ok_d], 75)) - floor
    if not press > 0:
        return None
    contact = ok_d & (fn_d > floor + LIFT_FRACTION * press)
    if contact.sum() < 10:
        return None
    back, fwd = (float(v) for v in np.percentile(ft_d[contact], [10, 90]))
    gap = fwd - back
    if 0.5 * gap > MAX_MU * press:  # the floor is no lifted finger: the load hardly varies
        return None
    sliding = contact & ((ft_d > fwd - 0.3 * gap) | (ft_d < back + 0.3 * gap))
    lightest = float(np.percentile(fn_d[sliding], 1)) if sliding.any() else -np.inf
    return _Levels(floor, press, back, fwd, lightest)


def _left_quickly(fn_s: FloatArray, a: int, b: int, dt: float, levels: _Levels) -> bool:
    """Whether the finger left before ``[a, b)`` and came back after it within
    :data:`STEP_S` (the normal force at half the pressing force), on each side inside the
    trial."""
    step = round(STEP_S / dt)
    half = levels.floor_N + 0.5 * levels.press_N
    before, after = fn_s[max(a - step, 0):a], fn_s[b:b + step]
    inside_before = a - step >= 0 and np.isfinite(fn_s[a - step])
    inside_after = b + step <= fn_s.size and np.isfinite(fn_s[b + step - 1])
    return not ((inside_before and not np.nanmax(before) >= half)
                or (inside_after and not np.nanmax(after) >= half))


def _measure(t: FloatArray, fn: FloatArray, ft: FloatArray, *, stretch: tuple[int, int],
             m: int, dt: float, levels: _Levels) -> Lifted | None:
    """The lifted stretch ``[a2, b2)`` (edges trimmed) measured on whole blocks of *m*
    samples (0.1 s) about its middle; None when its levels or its stillness are not a
    lifted finger's."""
    a2, b2 = stretch
    length = (b2 - a2) // m * m or (b2 - a2)
    c0 = a2 + (b2 - a2 - length) // 2
    seg = slice(c0, c0 + length)
    seg_n, seg_t = fn[seg], ft[seg]
    good = np.isfinite(seg_n) & np.isfinite(seg_t)
    if good.sum() < 2 * m:
        return None
    level_n, level_t = float(np.mean(seg_n[good])), float(np.mean(seg_t[good]))
    gap = levels.gap_N
    if not (level_n <= levels.lightest_N - LIFT_FRACTION * levels.press_N
            and levels.backward_N + 0.2 * gap <= level_t <= levels.forward_N - 0.2 * gap):
        return None
    line_n, line_t = _block_line(t[seg], seg_n, m), _block_line(t[seg], seg_t, m)
    if not all(line.scatter <= max(QUIET * line.noise, 0.005 * levels.press_N)
               for line in (line_n, line_t)):
        return None
    k = int(good.sum())
    return Lifted(
        i_start=int(c0), i_stop=int(c0 + length), t_start=float(t[a2]),
        t_end=float(t[b2 - 1] + dt), normal_N=level_n, tangential_N=level_t,
        normal_se_N=float(np.std(seg_n[good]) / np.sqrt(k)),
        tangential_se_N=float(np.std(seg_t[good]) / np.sqrt(k)),
        normal_slope=line_n.slope, tangential_slope=line_t.slope,
        normal_slope_se=line_n.slope_se, tangential_slope_se=line_t.slope_se)


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
    Returns
    -------
    ndarray of float64
        The offset at each of *t*, N.
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


__all__ = ["EDGE_S", "HUM_FREE_S", "MIN_SLOPE_S", "Lifted", "find_lifted", "offset_curve"]
