"""Steady-sliding windows, found from the tangential force itself.

No position sensor is needed (nor used, when the rig has one): the finger slides back and
forth, and the friction force's sign follows the sliding direction. On a uniform grid
(:mod:`evtribo.analysis.forces.align`):

1. both forces are smoothed with a centred moving average (``smooth_s``) of the samples
   present (NaN where more than a quarter of its span is missing);
2. a *stroke* is a run where the smoothed friction keeps one sign and stays above
   ``sign_fraction`` of the trial's sliding level (90th percentile of ``|F_t|``): reversals,
   rest and the start of the trial before sliding are outside every stroke;
3. each stroke is cut where the condition (ON/OFF, with guard times) changes;
4. inside each piece, steady sliding is where the friction-to-normal ratio ``|F_t|/F_n``
   is at least ``level_fraction`` of the piece's median ratio (this removes the stick phase
   and the start-up after a reversal, and any stick-slip event, without mistaking a change
   of normal force for one) and the normal force at least ``contact_fraction`` of the
   piece's median (the finger leaving the screen or touching down), eroded by half the
   smoothing length on both sides;
5. a hole in the data longer than half the smoothing span ends a steady run; runs shorter
   than ``min_window_s`` are dropped, longer than ``max_window_s`` split into equal parts
   (windows are the units the bootstrap resamples); with ``quantum_s``, every window lasts
   a whole number of quanta (whole periods of mains hum, or of a sine drive's friction
   oscillation), so that its mean holds no part-period of them.

Each window's forces are the means of the *unsmoothed* grid samples it spans, the
samples present only (shorter holes are skipped, never filled).
"""

from __future__ import annotations

import itertools
import logging
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pandas as pd

from evtribo.analysis.forces.conditions import EXCLUDED, ON
from evtribo.util.median import median
from evtribo.util.running import moving_average, running_count, true_runs, value_runs

log = logging.getLogger(__name__)

#: Columns of the table :func:`find_windows` returns.
WINDOW_COLUMNS = ("i_start", "i_stop", "t_start", "t_end", "condition", "direction",
                  "stroke", "stroke_s", "normal_force_N", "friction_force_N")

DEFAULT_SMOOTH_S = 0.1
DEFAULT_MIN_WINDOW_S = 0.2
DEFAULT_MAX_WINDOW_S = 1.0


def find_windows(
    t: npt.ArrayLike,
    normal: npt.ArrayLike,
    tangential: npt.ArrayLike,
    condition: npt.ArrayLike,
    *,
    smooth_s: float = DEFAULT_SMOOTH_S,
    sign_fraction: float = 0.25,
    level_fraction: float = 0.85,
    min_window_s: float = DEFAULT_MIN_WINDOW_S,
    max_window_s: float = DEFAULT_MAX_WINDOW_S,
    skip_start_s: float = 0.0,
    contact_fraction: float = 0.7,
    exclude: npt.ArrayLike | None = None,
    quantum_s: float | None = None,
) -> pd.DataFrame:
    """Steady-sliding windows of one trial, split by condition.

    Parameters
    ----------
    t : array_like of float, s
        Uniform grid times.
    normal, tangential : array_like of float, N
        Forces on the grid (NaN in gaps); the tangential force keeps its sign.
    condition : array_like of int
        ``ON``, ``OFF`` or ``EXCLUDED`` per grid point (:mod:`evtribo.analysis.forces.conditions`).
    smooth_s : float, s
        Moving-average span used to find strokes and steady parts (at least one or two
        periods of any oscillation the excitation causes).
    sign_fraction : float
        Friction below this fraction of the sliding level counts as a reversal or rest.
    level_fraction : float
        Steady sliding needs ``|F_t|/F_n`` at least this fraction of the piece's median.
    min_window_s, max_window_s : float, s
        Shortest window kept; longer steady runs are split into parts no longer than this.
    skip_start_s : float, s
        Time at the start of the grid never used.
    contact_fraction : float
        Steady sliding needs the normal force at least this fraction of the piece's median.
    exclude : array_like of bool, optional
        Grid points never used (e.g. where the finger was found lifted).
    quantum_s : float, s, optional
        Every window lasts a whole number of these (a steady run is trimmed about its
        middle to whole quanta, then split): with 0.1 s, a window's mean holds whole
        periods of 50 Hz and 60 Hz hum, which it then cancels; with a period of the
        friction's own oscillation (a sine drive's), whole periods of that.

    Returns
    -------
    pandas.DataFrame
        One row per window, columns :data:`WINDOW_COLUMNS`: grid indices ``i_start`` and
        ``i_stop`` (exclusive), ``t_start`` and ``t_end`` (s, grid clock), ``condition``
        (``"on"``/``"off"``), ``direction`` (sign of the friction), ``stroke`` (its stroke's
        number from the grid's start) and ``stroke_s`` (that stroke's duration between
        reversals, s), and the mean normal force and mean friction magnitude (N).
    """
    t = np.asarray(t, dtype=np.float64)
    cond = np.asarray(condition).astype(np.int64)
    if t.size < 3:
        return _empty()
    grid = _smoothed(t, normal, tangential, smooth_s)
    sliding = grid.usable & (t >= t[0] + skip_start_s)
    if exclude is not None:
        sliding &= ~np.asarray(exclude, dtype=bool)
    found = _stroke_code(grid, cond, sliding, sign_fraction)
    if found is None:
        return _empty()
    code, direction = found
    min_len = max(2, round(min_window_s / grid.dt))
    lengths = (min_len, max(min_len, round(max_window_s / grid.dt)),
               max(1, round(quantum_s / grid.dt)) if quantum_s else 1)
    rows = [row for a, b, v in value_runs(code) if v != 0 and b - a >= min_len
            for row in _piece_windows(t, grid, (a, b, v), lengths, level_fraction=level_fraction,
                                      contact_fraction=contact_fraction)]
    if not rows:
        return _empty()
    table = _with_strokes(pd.DataFrame.from_records(rows, columns=list(WINDOW_COLUMNS)),
                          direction, grid.dt)
    return with_means(table, grid.normal, grid.tangential)


def _with_strokes(table: pd.DataFrame, sign: npt.NDArray[np.int64], dt: float
                  ) -> pd.DataFrame:
    """*table* with each window's stroke (the runs of one sliding direction of *sign*,
    numbered from 0) and that stroke's duration, s."""
    number = np.full(sign.size, -1, dtype=np.int64)
    seconds = np.full(sign.size, np.nan)
    runs = [(a, b) for a, b, v in value_runs(sign) if v != 0]
    for k, (a, b) in enumerate(runs):
        number[a:b] = k
        seconds[a:b] = (b - a) * dt
    first = table.i_start.to_numpy(np.int64)
    return table.assign(stroke=number[first], stroke_s=seconds[first])


def _empty() -> pd.DataFrame:
    return pd.DataFrame({c: pd.Series(dtype=float) for c in WINDOW_COLUMNS})


@dataclass(frozen=True)
class _Grid:
    """A trial's forces on its grid, raw and smoothed, and the smoothing's span."""

    dt: float
    normal: npt.NDArray[np.float64]
    tangential: npt.NDArray[np.float64]
    normal_smooth: npt.NDArray[np.float64]
    tangential_smooth: npt.NDArray[np.float64]
    span: int
    """Samples of the moving average (odd)."""
    holes: npt.NDArray[np.intp]
    """Where a force is missing for longer than :attr:`half`: ``(start, stop)`` per row."""

    @property
    def half(self) -> int:
        """Half the span, in samples (rounded down)."""
        return self.span // 2

    @property
    def usable(self) -> npt.NDArray[np.bool_]:
        """Where both smoothed forces are known and the normal force pushes."""
        return (np.isfinite(self.tangential_smooth) & np.isfinite(self.normal_smooth)
                & (self.normal_smooth > 0))


def _smoothed(t: npt.NDArray[np.float64], normal: npt.ArrayLike, tangential: npt.ArrayLike,
              smooth_s: float) -> _Grid:
    """Step 1: both forces smoothed over *smooth_s* (NaN where more than a quarter of the
    span is missing)."""
    dt = median(np.diff(t))
    span = max(1, round(smooth_s / dt)) | 1
    fn = np.asarray(normal, dtype=np.float64)
    ft = np.asarray(tangential, dtype=np.float64)
    hole = ~(np.isfinite(fn) & np.isfinite(ft))
    runs = np.array(true_runs(hole) if hole.any() else [], dtype=np.intp).reshape(-1, 2)
    return _Grid(dt, fn, ft, moving_average(fn, span, min_fraction=0.75),
                 moving_average(ft, span, min_fraction=0.75), span,
                 runs[runs[:, 1] - runs[:, 0] > span // 2])


def _stroke_code(grid: _Grid, cond: npt.NDArray[np.int64], sliding: npt.NDArray[np.bool_],
                 sign_fraction: float
                 ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]] | None:
    """Steps 2 and 3: each grid point's piece, direction x condition (+-1 OFF, +-2 ON; 0
    outside strokes: reversals, rest, unusable points, the guard about a switch), and its
    sliding direction whatever the condition (0 outside strokes); None without sliding."""
    usable = sliding & (cond != EXCLUDED)
    if not usable.any():
        return None
    ft_s = grid.tangential_smooth
    level = float(np.percentile(np.abs(ft_s[usable]), 90))
    if not level > 0:
        return None
    label = np.where(ft_s > sign_fraction * level, 1, np.where(ft_s < -sign_fraction * level,
                                                                -1, 0))
    label[~sliding] = 0
    code = np.where(usable, label * (np.where(cond == ON, 2, 1)), 0).astype(np.int64)
    return code, label.astype(np.int64)


def _steady(grid: _Grid, a: int, b: int, *, level_fraction: float, contact_fraction: float
            ) -> npt.NDArray[np.bool_]:
    """Steps 4 and 5: the steady-sliding points of the piece ``[a, b)``: friction-to-normal
    ratio and normal force near the piece's medians, eroded by half the smoothing span,
    broken by holes longer than that."""
    fn_s = grid.normal_smooth[a:b]
    r = np.abs(grid.tangential_smooth[a:b]) / np.where(fn_s > 0, fn_s, np.nan)
    ok = r >= level_fraction * median(r)
    ok &= fn_s >= contact_fraction * median(fn_s)
    h = grid.half
    if h:  # erode by h samples on each side (outside the piece counts as not steady)
        okc = running_count(ok, initial=True)
        full = np.zeros(ok.size, dtype=bool)
        if ok.size > 2 * h:  # points h from either end: okc[i + h + 1] - okc[i - h]
            full[h:ok.size - h] = (okc[2 * h + 1:] - okc[:ok.size - 2 * h]) == grid.span
        ok = full
    # a hole in the data longer than half the smoothing span ends a steady run (the runs
    # of the whole grid, cut to the piece)
    first = int(np.searchsorted(grid.holes[:, 1], a, side="right"))
    for start, stop in grid.holes[first:]:
        if start >= b:
            break
        hs, he = max(int(start), a) - a, min(int(stop), b) - a
        if he - hs > h:
            ok[hs:he] = False
    return ok


def _piece_windows(t: npt.NDArray[np.float64], grid: _Grid, piece: tuple[int, int, int],
                   lengths: tuple[int, int, int], *, level_fraction: float,
                   contact_fraction: float) -> list[tuple[object, ...]]:
    """The windows of one piece ``(a, b, code)`` (rows of :data:`WINDOW_COLUMNS`, means
    still 0): its steady runs, each split by :func:`_split` with *lengths* (shortest,
    longest, quantum; in samples)."""
    a, b, v = piece
    ok = _steady(grid, a, b, level_fraction=level_fraction, contact_fraction=contact_fraction)
    return [(i0, i1, t[i0], t[i1 - 1] + grid.dt, "on" if abs(v) == 2 else "off",
             int(np.sign(v)), -1, float("nan"), 0.0, 0.0)
            for s, e in true_runs(ok) for i0, i1 in _split(a + s, a + e, *lengths)]


def _split(start: int, stop: int, min_len: int, max_len: int, q: int
           ) -> list[tuple[int, int]]:
    """Windows of a steady run ``[start, stop)``: a whole number of quanta of *q* samples
    (the run trimmed about its middle), split into parts of at most *max_len* samples (or
    one quantum, if longer) as equal as whole quanta allow, none shorter than *min_len*."""
    n_q = (stop - start) // q
    if n_q * q < min_len:
        return []
    first = start + ((stop - start) - n_q * q) // 2
    parts = max(1, min(n_q, math.ceil(n_q * q / max_len)))
    sizes = [n_q // parts + (k < n_q % parts) for k in range(parts)]
    edges = [first + q * e for e in itertools.accumulate(sizes, initial=0)]
    return [(a, b) for a, b in itertools.pairwise(edges) if b - a >= min_len]


def with_means(windows: pd.DataFrame, normal: npt.ArrayLike, tangential: npt.ArrayLike
               ) -> pd.DataFrame:
    """*windows* with ``normal_force_N`` and ``friction_force_N`` (the magnitude) the means
    of the samples present in each (``i_start`` to ``i_stop``) of the given forces.

    Parameters
    ----------
    windows : pandas.DataFrame
        Windows of :func:`find_windows` (their grid indices are used).
    normal, tangential : array_like of float, N
        Forces on the grid the windows index (NaN in gaps).
    Returns
    -------
    pandas.DataFrame
    """
    if windows.empty:
        return windows
    i0 = windows.i_start.to_numpy(np.int64)
    i1 = windows.i_stop.to_numpy(np.int64)
    means = []
    for force in (normal, tangential):
        x = np.asarray(force, dtype=np.float64)
        good = np.isfinite(x)
        total = np.zeros(x.size + 1)
        if good.all():  # the common case: the same sums, the counts the indices
            np.cumsum(x, out=total[1:])
            count = np.arange(x.size + 1)
        else:
            np.cumsum(np.where(good, x, 0.0), out=total[1:])
            count = running_count(good, initial=True)
        with np.errstate(invalid="ignore", divide="ignore"):
            means.append((total[i1] - total[i0]) / (count[i1] - count[i0]))
    return windows.assign(normal_force_N=means[0], friction_force_N=np.abs(means[1]))


__all__ = ["DEFAULT_MAX_WINDOW_S", "DEFAULT_MIN_WINDOW_S", "DEFAULT_SMOOTH_S", "WINDOW_COLUMNS",
           "find_windows", "with_means"]
