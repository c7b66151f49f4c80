"""Where a window lies in its trial, beside its forces: its time, sliding direction, stroke
rate, stroke and trial; and the time polynomial the friction's models use."""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from numpy.polynomial import legendre

__all__ = ["MAX_DEGREE", "SPAN_PER_DEGREE_S", "WindowFacts", "cr2_residuals", "stack_facts",
           "time_basis"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

#: Highest degree of the time polynomial.
MAX_DEGREE = 3
#: Seconds of OFF windows' span per degree of the time polynomial.
SPAN_PER_DEGREE_S = 4.0
#: Sets of plain windows, numbered (:meth:`WindowFacts.plain`).
_PLAIN = itertools.count()


@dataclass(frozen=True)
class WindowFacts:
    """What locates windows in their trial, beside their forces (one value per window).

    Attributes
    ----------
    t_s : ndarray of float, s
        Middle of each window on its trial's clock (NaN: unknown).
    direction : ndarray of float
        Sliding direction, +1 / -1 (0: unknown).
    rate : ndarray of float
        Logarithm of the stroke's rate, ``-log(stroke duration / s)`` (NaN: unknown).
    cluster : ndarray of int
        Windows with the same number share a stroke: they are resampled together.
    stratum : ndarray of int
        The trial of each window (ON windows are averaged within a trial over both
        directions alike).
    """

    t_s: FloatArray
    direction: FloatArray
    rate: FloatArray
    cluster: IntArray
    stratum: IntArray

    @classmethod
    def plain(cls, n: int) -> WindowFacts:
        """*n* windows of which nothing is known but their forces, each its own stroke (no
        two sets of them share one: their strokes are numbered on from the last set's)."""
        start = next(_PLAIN) * (1 << 24)
        return cls(np.full(n, np.nan), np.zeros(n), np.full(n, np.nan),
                   -1 - start - np.arange(n, dtype=np.int64), np.zeros(n, dtype=np.int64))

    def take(self, sel: npt.NDArray[np.bool_] | npt.NDArray[np.intp]) -> WindowFacts:
        """The facts of the windows *sel* (a mask or indices)."""
        return WindowFacts(self.t_s[sel], self.direction[sel], self.rate[sel],
                           self.cluster[sel], self.stratum[sel])

    def __len__(self) -> int:
        return int(self.t_s.size)


def time_basis(t: FloatArray, lo: float, hi: float, degree: int) -> FloatArray:
    """Legendre polynomials 1..degree of *t* scaled from [lo, hi] to [-1, 1], continued as
    straight lines (value and slope at the end) beyond it.

    Parameters
    ----------
    t : ndarray of float, s
    lo, hi : float, s
        The span scaled to [-1, 1].
    degree : int

    Returns
    -------
    ndarray, shape (t.size, degree)
        One column per degree (NaN times give 0).
    """
    half = 0.5 * (hi - lo) if hi > lo else 1.0
    x = (np.asarray(t, dtype=np.float64) - 0.5 * (hi + lo)) / half
    x = np.where(np.isfinite(x), x, 0.0)
    edge = np.clip(x, -1.0, 1.0)
    out = []
    for k in range(1, degree + 1):
        c = np.zeros(k + 1)
        c[k] = 1.0
        slope = legendre.legval(edge, legendre.legder(c))
        out.append(legendre.legval(edge, c) + slope * (x - edge))
    return np.column_stack(out)


def stack_facts(parts: Sequence[WindowFacts]) -> WindowFacts:
    """Several sets of window facts as one, in order.

    Parameters
    ----------
    parts : sequence of WindowFacts

    Returns
    -------
    WindowFacts
    """
    return WindowFacts(*(np.concatenate([getattr(p, f) for p in parts])
                         for f in ("t_s", "direction", "rate", "cluster", "stratum")))


def cr2_residuals(q: FloatArray, resid: FloatArray, weight: FloatArray,
                  cluster: npt.ArrayLike) -> FloatArray:
    """Residuals of a weighted least-squares fit, scaled per cluster as the CR2 variance
    takes them (Bell & McCaffrey 2002): ``(I - H_gg)^(-1/2) e_g`` in the weighted metric,
    ``H_gg`` the block of the hat matrix of cluster ``g`` (HC2 when every cluster is one
    window). A wild cluster bootstrap that draws one weight per cluster then has the
    variance of the errors, not the smaller one of the residuals.

    Parameters
    ----------
    q : ndarray, shape (n, p)
        Orthonormal basis of the weighted design (``numpy.linalg.qr`` of ``X sqrt(w)``).
    resid : ndarray, shape (n,)
        The residuals ``y - X coef``.
    weight : ndarray, shape (n,)
        The fit's weights.
    cluster : array_like of int, shape (n,)
        Each window's cluster (its stroke).

    Returns
    -------
    ndarray, shape (n,)
        The scaled residuals (a cluster the fit holds exactly gets zeros).
    """
    sw = np.sqrt(weight)
    e = resid * sw
    out = np.zeros(e.size)
    _, which = np.unique(np.asarray(cluster), return_inverse=True)
    order = np.argsort(which, kind="stable")
    bounds = np.flatnonzero(np.diff(which[order])) + 1
    groups = np.split(order, bounds)
    by_size: dict[int, list[npt.NDArray[np.intp]]] = {}
    for g in groups:
        by_size.setdefault(g.size, []).append(g)
    for size, members in by_size.items():
        idx = np.array(members)  # (clusters, size)
        qg = q[idx]  # (clusters, size, p)
        m = np.eye(size) - qg @ np.swapaxes(qg, 1, 2)
        lam, vec = np.linalg.eigh(m)
        inv_sqrt = np.where(lam > 1e-3, 1.0 / np.sqrt(np.maximum(lam, 1e-3)), 0.0)
        root = (vec * inv_sqrt[:, None, :]) @ np.swapaxes(vec, 1, 2)
        out[idx] = np.einsum("gij,gj->gi", root, e[idx])
    return out / sw
