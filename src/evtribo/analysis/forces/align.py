"""The two load cells on one time base, without inventing data across gaps.

The normal and the tangential load cell are separate CAN nodes: each samples at its own rate,
on its own clock, with jitter, and frames get lost. Their samples are put on one uniform grid
by linear interpolation between neighbouring samples of each channel; a grid point that falls
inside a gap of either channel (two consecutive samples farther apart than a few nominal
periods) or outside the span both channels cover is NaN, never interpolated through.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from evtribo.errors import AnalysisError
from evtribo.util.median import median

log = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]

#: A pause longer than this many nominal sample periods is a gap (not interpolated through).
DEFAULT_MAX_GAP_PERIODS = 5.0


@dataclass(frozen=True)
class AlignedForces:
    """Normal and tangential force on a common uniform time grid.

    Attributes
    ----------
    t : ndarray of float64, s
        Grid times, on the clock of the input timestamps (uniform, step ``1 / rate_Hz``).
    normal : ndarray of float64, N
        Normal force; NaN inside gaps of the normal channel.
    tangential : ndarray of float64, N
        Tangential (friction) force with its sign; NaN inside gaps of the tangential channel.
    rate_Hz : float
        Grid rate, Hz.
    """

    t: FloatArray
    normal: FloatArray
    tangential: FloatArray
    rate_Hz: float

    @property
    def valid(self) -> npt.NDArray[np.bool_]:
        """True where both forces are known."""
        return np.isfinite(self.normal) & np.isfinite(self.tangential)


def _clean(t: npt.ArrayLike, value: npt.ArrayLike, name: str) -> tuple[FloatArray, FloatArray]:
    """Finite samples, sorted by time, with duplicate timestamps averaged."""
    t = np.asarray(t, dtype=np.float64).ravel()
    value = np.asarray(value, dtype=np.float64).ravel()
    if t.shape != value.shape:
        raise ValueError(f"{name}: {t.size} timestamps but {value.size} values")
    keep = np.isfinite(t) & np.isfinite(value)
    if not keep.all():
        t, value = t[keep], value[keep]
    step = np.diff(t)
    if step.size and (step < 0).any():
        order = np.argsort(t, kind="stable")
        t, value = t[order], value[order]
        step = np.diff(t)
    if step.size and not (step > 0).all():  # repeated times: one sample, their mean
        first = np.flatnonzero(np.concatenate(([True], step != 0)))
        t, value = t[first], _group_means(value, first)
    if t.size < 2:
        raise AnalysisError(f"the {name} channel has {t.size} usable sample(s); need at least 2")
    return t, value


def _group_means(value: FloatArray, first: npt.NDArray[np.intp]) -> FloatArray:
    """``np.add.reduceat(value, first) / counts``, the mean of each group of *value* that
    starts at an index of *first*, summing only the groups of more than one value (a time
    repeated is rare: most groups are one value, its own mean)."""
    counts = np.diff(np.append(first, value.size))
    out = value[first]
    many = np.flatnonzero(counts > 1)
    if many.size:  # each group's start and end, the last end left out when it is the end
        bounds = np.stack([first[many], first[many] + counts[many]], axis=1).ravel()
        sums = np.add.reduceat(value, bounds[:-1] if bounds[-1] == value.size else bounds)
        out[many] = sums[0::2] / counts[many]
    return out


def nominal_period(t: npt.ArrayLike) -> float:
    """The channel's nominal sample period: the median of its positive time steps.

    Parameters
    ----------
    t : array_like of float, s
        Sample times (sorted).

    Returns
    -------
    float
        Period in s (NaN with fewer than two distinct samples).
    """
    steps = np.diff(np.asarray(t, dtype=np.float64))
    steps = steps[steps > 0]
    return median(steps) if steps.size else float("nan")


def resample_channel(t_grid: FloatArray, t: FloatArray, value: FloatArray,
                     max_gap_s: float) -> FloatArray:
    """Linear interpolation of one channel onto *t_grid*, NaN inside gaps and outside its span.

    Parameters
    ----------
    t_grid : ndarray of float64, s
        Where to evaluate.
    t, value : ndarray of float64
        The channel's sorted sample times (s) and values.
    max_gap_s : float, s
        Consecutive samples farther apart than this enclose a gap.

    Returns
    -------
    ndarray of float64
        Values on the grid.
    """
    out = np.interp(t_grid, t, value)
    out[(t_grid < t[0]) | (t_grid > t[-1])] = np.nan
    # a grid point g with t[k] <= g < t[k + 1] lies in a gap when t[k + 1] - t[k] > max_gap_s;
    # the gaps are few: the grid points of each found from its ends, not the other way round
    gaps = np.flatnonzero(np.diff(t) > max_gap_s)
    if gaps.size:
        lo = np.searchsorted(t_grid, t[gaps], side="left")
        hi = np.searchsorted(t_grid, t[gaps + 1], side="left")
        inside = np.zeros(t_grid.size + 1, dtype=np.int64)
        np.add.at(inside, lo, 1)
        np.add.at(inside, hi, -1)
        out[np.cumsum(inside[:-1]) > 0] = np.nan
    return out


def align_forces(
    t_normal: npt.ArrayLike,
    normal: npt.ArrayLike,
    t_tangential: npt.ArrayLike,
    tangential: npt.ArrayLike,
    *,
    rate_Hz: float | None = None,
    max_gap_periods: float = DEFAULT_MAX_GAP_PERIODS,
) -> AlignedForces:
    """Put the two load cells on a common uniform time grid.

    Parameters
    ----------
    t_normal, normal : array_like of float
        Normal-force sample times (s) and values (N).
    t_tangential, tangential : array_like of float
        Tangential-force sample times (s) and values (N), on the same clock as ``t_normal``.
    rate_Hz : float, optional
        Grid rate, Hz. Default: the faster channel's nominal rate.
    max_gap_periods : float
        A pause longer than this many nominal periods of a channel is a gap: grid points
        inside it are NaN for that channel.

    Returns
    -------
    AlignedForces
        Both forces on the grid spanning the interval both channels cover.

    Raises
    ------
    AnalysisError
        A channel has fewer than two samples, or the channels do not overlap in time.
    """
    tn, fn = _clean(t_normal, normal, "normal-force")
    tt, ft = _clean(t_tangential, tangential, "tangential-force")
    pn, pt = nominal_period(tn), nominal_period(tt)
    if rate_Hz is None:
        rate_Hz = 1.0 / min(pn, pt)
    if not (np.isfinite(rate_Hz) and rate_Hz > 0):
        raise ValueError(f"rate_Hz must be a positive number, got {rate_Hz!r}")
    start, stop = max(tn[0], tt[0]), min(tn[-1], tt[-1])
    if stop <= start:
        raise AnalysisError("the normal and tangential load cells do not overlap in time "
                            f"(normal {tn[0]:.3f}..{tn[-1]:.3f} s, "
                            f"tangential {tt[0]:.3f}..{tt[-1]:.3f} s)")
    n = int(np.floor((stop - start) * rate_Hz + 1e-9)) + 1
    grid = start + np.arange(n) / rate_Hz
    normal_g = resample_channel(grid, tn, fn, max_gap_periods * pn)
    tangential_g = resample_channel(grid, tt, ft, max_gap_periods * pt)
    lost = np.count_nonzero(~(np.isfinite(normal_g) & np.isfinite(tangential_g)))
    if lost:
        log.debug("alignment: %d of %d grid points fall in gaps", lost, n)
    return AlignedForces(t=grid, normal=normal_g, tangential=tangential_g, rate_Hz=float(rate_Hz))


__all__ = ["DEFAULT_MAX_GAP_PERIODS", "AlignedForces", "align_forces", "nominal_period",
           "resample_channel"]
