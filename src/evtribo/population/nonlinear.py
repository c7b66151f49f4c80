"""The power law across subjects on the linear scale: a nonlinear mixed-effects model.

Each subject i has its own power law, and each of its cells (its electrostatic force at an
amplitude, with the covariance ``C_i`` its intervals and bootstrap replicates give) is that
law plus the cell's error::

    F_ij = exp(b_i1 + b_i2 (ln U_j - c)) + e_ij,    e_i ~ N(0, phi C_i)
    b_i = beta + L v_i,                              v_i ~ N(0, I)

``beta = (a, n)``: the population's log force at ``U = exp(c)`` and its exponent; ``G = L L'``
the between-subject covariance of ``(log k_i, n_i)`` (random intercepts and exponents, or
intercepts only); ``phi`` a common scale of the cells' errors, estimated when the subjects'
cells leave residual degrees of freedom (1 when the intervals are right; intervals use
``max(phi, 1)``). Cells near or below zero count as any other: the errors are on the force,
not on its logarithm.

The likelihood integrates each subject's random effects by adaptive Gauss-Hermite quadrature
about their conditional mode (Pinheiro and Bates 1995; with one node, the Laplace
approximation), the mode found by penalised Gauss-Newton steps for all subjects at once. The
variance parameters are estimated by an approximate REML (the log-determinant of the fixed
effects' information, linearised at the modes, added to the deviance, as nlme does), which
removes most of maximum likelihood's downward bias of the between-subject variance with few
subjects. The deviance is minimised with several of scipy's optimisers from the same start
(:func:`~evtribo.population.nonlinear_fit.fit_nonlinear`): the best is kept, and the others'
disagreement is reported.

Inference: the fixed effects' covariance is the inverse of their information linearised at the
modes (phi at least 1); the 95 % intervals use Student's t with Satterthwaite's degrees of
freedom from the covariance of the variance parameters (twice the inverse Hessian of the
deviance).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

log = logging.getLogger(__name__)

__all__ = ["NonlinearData", "nonlinear_data", "subject_fits"]

Array = NDArray[np.float64]

#: Largest exponent of a cell's modelled force (exp(40) N: no overflow, a sure misfit).
_MAX_LOG = 40.0


@dataclass(frozen=True)
class NonlinearData:
    """Every subject's cells of one condition, padded to a common number of cells.

    Attributes
    ----------
    subjects : tuple of str
    x : ndarray, shape (k, m)
        ``ln U - c`` of each cell (0 where padded).
    y : ndarray, shape (k, m)
        Each cell's force, N (0 where padded).
    w : ndarray, shape (k, m, m)
        The inverse Cholesky factor of each subject's cell covariance, 1/N (zero rows and
        columns where padded): ``w @ (y - f)`` are independent standard normal errors.
    n_cells : ndarray of int, shape (k,)
    logdet_c : ndarray, shape (k,)
        ``log det C_i`` (N²).
    prec : ndarray, shape (k, m, m)
        Each subject's precision ``C_i^-1 = w'w``, 1/N² (zero where padded).
    log_u0 : float
        The centre c of the log amplitudes.
    """

    subjects: tuple[str, ...]
    x: Array
    y: Array
    w: Array
    n_cells: NDArray[np.int64]
    logdet_c: Array
    log_u0: float
    prec: Array = field(repr=False, default_factory=lambda: np.zeros((0, 0, 0)))
    cells: tuple[tuple[Array, Array, Array], ...] = field(repr=False, default=())

    @property
    def k(self) -> int:
        """Subjects."""
        return len(self.subjects)

    def without(self, subject: str) -> NonlinearData:
        """The same data without *subject* (its centre kept)."""
        keep = [i for i, s in enumerate(self.subjects) if s != subject]
        return nonlinear_data([self.subjects[i] for i in keep],
                              [self.cells[i] for i in keep], log_u0=self.log_u0)


def nonlinear_data(subjects: Sequence[str], cells: Sequence[tuple[Array, Array, Array]], *,
                   log_u0: float | None = None) -> NonlinearData:
    """Pad the subjects' cells into arrays.

    Parameters
    ----------
    subjects : sequence of str
    cells : sequence of (ndarray, ndarray, ndarray)
        Per subject: ln U (V), the forces (N) and their covariance (N²).
    log_u0 : float, optional
        The centre of the log amplitudes (default: the mean over all cells).

    Returns
    -------
    NonlinearData
    """
    k = len(cells)
    m = max(c[0].size for c in cells)
    c0 = float(np.mean(np.concatenate([c[0] for c in cells]))) if log_u0 is None else log_u0
    x, y = np.zeros((k, m)), np.zeros((k, m))
    w = np.zeros((k, m, m))
    logdet = np.zeros(k)
    n = np.zeros(k, dtype=np.int64)
    for i, (lu, f, cov) in enumerate(cells):
        j = lu.size
        n[i] = j
        x[i, :j], y[i, :j] = lu - c0, f
        chol = np.linalg.cholesky(cov)
        w[i, :j, :j] = np.linalg.inv(chol)
        logdet[i] = 2.0 * float(np.sum(np.log(np.diag(chol))))
    return NonlinearData(tuple(subjects), x, y, w, n, logdet, c0, np.swapaxes(w, 1, 2) @ w,
                         tuple((np.asarray(a, float), np.asarray(b, float),
                                np.asarray(c, float)) for a, b, c in cells))


@dataclass(frozen=True)
class _Spec:
    """What is estimated: random exponents (q = 2) or intercepts only, phi or not, REML,
    quadrature nodes per random effect."""

    q: int
    fit_phi: bool
    reml: bool = True
    nodes: int = 1

    @property
    def n_params(self) -> int:
        return 2 + self.q * (self.q + 1) // 2 + int(self.fit_phi)


def _unpack(p: Array, spec: _Spec) -> tuple[Array, Array, float]:
    """beta, the loadings L (2 x q) and phi from the parameter vector."""
    beta = p[:2]
    if spec.q == 2:
        load = np.array([[p[2], 0.0], [p[3], p[4]]])
    else:
        load = np.array([[p[2]], [0.0]])
    phi = math.exp(float(p[-1])) if spec.fit_phi else 1.0
    return beta, load, phi


def _state(data: NonlinearData, beta: Array, load: Array, phi: float, v: Array
           ) -> tuple[Array, Array, Array, Array]:
    """At the random effects *v* (k x q), per subject: the penalised objective ``v'v +
    r'C^-1 r / phi`` (r = y - f), the gradient ``J'C^-1 r / phi`` of its second term in b
    (k x 2), the Gauss-Newton information ``J'C^-1 J / phi`` (k x 2 x 2, J the Jacobian of
    the forces in b) and the residuals' curvature ``sum_j (C^-1 r)_j f_j X_j X_j' / phi``
    (k x 2 x 2)."""
    b = beta + v @ load.T
    f = np.exp(np.minimum(b[:, :1] + b[:, 1:] * data.x, _MAX_LOG))
    cols = np.empty((*data.x.shape, 4))
    cols[..., 0] = data.y - f
    cols[..., 1] = f
    cols[..., 2] = f * data.x
    cols[..., 3] = cols[..., 2] * data.x
    # every product the state needs, in one: cols' C^-1 cols (k x 4 x 4)
    m = np.swapaxes(cols, 1, 2) @ (data.prec @ cols[..., :3]) / phi
    obj = np.sum(v * v, axis=1) + m[:, 0, 0]
    grad = m[:, 1:3, 0]
    info = m[:, 1:3, 1:3]
    curv = np.empty_like(info)
    curv[:, 0, 0], curv[:, 0, 1] = grad[:, 0], grad[:, 1]
    curv[:, 1, 0] = grad[:, 1]
    curv[:, 1, 1] = m[:, 3, 0]
    return obj, grad, info, curv


def _hessian(load: Array, state: tuple[Array, ...]) -> tuple[Array, Array]:
    """Half the Hessian of the penalised objective in v, and Gauss-Newton's ``I + L'J'C^-1
    JL / phi``; the Hessian is Gauss-Newton's where the exact one is not positive-definite
    (far from the mode)."""
    _, _, info, curv = state
    q = load.shape[1]
    gn = np.eye(q) + load.T @ info @ load
    exact = gn - load.T @ curv @ load
    if q == 1:
        ok = exact[:, 0, 0] > 1e-8
    else:
        ok = (exact[:, 0, 0] > 1e-8) & (
            exact[:, 0, 0] * exact[:, 1, 1] - exact[:, 0, 1] * exact[:, 1, 0] > 1e-8)
    return np.where(ok[:, None, None], exact, gn), gn


def _solve(h: Array, g: Array) -> Array:
    """``h^-1 g`` for stacks of 1 x 1 or 2 x 2 matrices."""
    if h.shape[1] == 1:
        return g / h[:, 0, :]
    det = h[:, 0, 0] * h[:, 1, 1] - h[:, 0, 1] * h[:, 1, 0]
    return np.stack([h[:, 1, 1] * g[:, 0] - h[:, 0, 1] * g[:, 1],
                     h[:, 0, 0] * g[:, 1] - h[:, 1, 0] * g[:, 0]], axis=1) / det[:, None]


def _modes(data: NonlinearData, beta: Array, load: Array, phi: float, v: Array, *,
           tol: float = 1e-10) -> tuple[Array, tuple[Array, ...], Array, Array]:
    """Each subject's conditional mode of v (penalised Newton steps with step halving),
    with the state there, the Hessian and Gauss-Newton's."""
    state = _state(data, beta, load, phi, v)
    for _ in range(100):
        h, gn = _hessian(load, state)
        step = _solve(h, state[1] @ load - v)
        # converged to where the deviance's terms (log det H too, which is not stationary
        # at the mode) move by less than about *tol*: at 1e-10 the finite differences of
        # the optimisers and of the Hessian see no noise
        if float(np.max(np.abs(step))) < tol:
            break
        t = np.ones((len(v), 1))
        for _ in range(40):
            new = _state(data, beta, load, phi, v + t * step)
            worse = ~(new[0] <= state[0] + 1e-12 * (1.0 + state[0]))
            if not worse.any():
                break
            t[worse] /= 2.0
        v, state = v + t * step, new
    return v, state, h, gn


def _nodes(q: int, nodes: int) -> tuple[Array, Array]:
    """Gauss-Hermite nodes (for the standard normal) and weights on a q-dimensional grid."""
    z, w = np.polynomial.hermite_e.hermegauss(nodes)
    w = w / w.sum()
    grid = np.stack(np.meshgrid(*([z] * q), indexing="ij"), axis=-1).reshape(-1, q)
    weight = np.prod(np.stack(np.meshgrid(*([w] * q), indexing="ij"), axis=-1).reshape(-1, q),
                     axis=1)
    return grid, weight


def _integral(data: NonlinearData, beta: Array, load: Array, phi: float, v: Array, *,
              obj: Array, h: Array, nodes: int) -> Array:
    """-2 log of each subject's integral over its random effects, without the constants of
    its cells: ``log det H + O(v)`` (Laplace), refined by adaptive Gauss-Hermite
    quadrature with *nodes* per random effect."""
    logdet_h = np.linalg.slogdet(h)[1]
    if nodes <= 1:
        return logdet_h + obj
    q = v.shape[1]
    grid, weight = _nodes(q, nodes)
    chol = np.linalg.cholesky(h)  # H = R'R with R = chol'
    # v at each node: v + R^-1 t, for every subject (k x g x q)
    shift = np.linalg.solve(np.swapaxes(chol, 1, 2)[:, None], grid[None, :, :, None])[..., 0]
    at = v[:, None, :] + shift
    k, g = at.shape[:2]
    rep = NonlinearData(data.subjects, np.repeat(data.x, g, axis=0),
                        np.repeat(data.y, g, axis=0), data.w, data.n_cells, data.logdet_c,
                        data.log_u0, np.repeat(data.prec, g, axis=0))
    o = _state(rep, beta, load, phi, at.reshape(k * g, q))[0].reshape(k, g)
    expo = -0.5 * (o - np.sum(grid * grid, axis=1)[None, :]) + np.log(weight)[None, :]
    top = np.max(expo, axis=1, keepdims=True)
    return logdet_h - 2.0 * (top[:, 0] + np.log(np.sum(np.exp(expo - top), axis=1)))


def _information(info: Array, load: Array, gn: Array) -> Array:
    """The fixed effects' information linearised at the modes: the sum over subjects of
    ``J'(phi C + J G J')^-1 J`` = ``I_b - I_b L (I + L'I_b L)^-1 L' I_b`` with ``I_b =
    J'C^-1 J / phi``."""
    il = info @ load
    inv = np.linalg.inv(gn)
    return np.asarray(np.sum(info - il @ inv @ np.swapaxes(il, 1, 2), axis=0), dtype=float)


class _Objective:
    """The (restricted) deviance as a function of the parameter vector, its random effects'
    modes kept from one call to the next as the next call's start."""

    def __init__(self, data: NonlinearData, spec: _Spec) -> None:
        self.data, self.spec = data, spec
        self.v = np.zeros((data.k, spec.q))
        self.evaluations = 0
        #: How closely the modes are found (coarser for the optimisers without gradients).
        self.tol = 1e-10

    def pieces(self, p: Array) -> tuple[float, Array, Array, Array, float]:
        """Deviance, modes, the Hessians H at them, the information of beta and phi."""
        beta, load, phi = _unpack(np.asarray(p, float), self.spec)
        start = self.v if np.all(np.isfinite(self.v)) else np.zeros_like(self.v)
        v, state, h, gn = _modes(self.data, beta, load, phi, start, tol=self.tol)
        terms = _integral(self.data, beta, load, phi, v, obj=state[0], h=h,
                          nodes=self.spec.nodes)
        d = self.data
        dev = float(np.sum(d.n_cells * math.log(2.0 * math.pi * phi) + d.logdet_c + terms))
        info = _information(state[2], load, gn)
        if self.spec.reml:
            sign, logdet = np.linalg.slogdet(info)
            dev = dev + float(logdet) if sign > 0 else math.inf
        return dev, v, h, info, phi

    def __call__(self, p: Array) -> float:
        self.evaluations += 1
        try:
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                dev, v, *_ = self.pieces(p)
        except np.linalg.LinAlgError:
            return 1e300
        if not math.isfinite(dev):
            return 1e300
        if np.all(np.isfinite(v)):
            self.v = v
        return dev


def _start(data: NonlinearData, spec: _Spec) -> Array:
    """A start: the population's line fitted to every cell without random effects, the
    subjects' spread from their own fits (less what their errors explain; 0.5 in log k and
    0.2 in n where they say nothing), phi 1."""
    from scipy import optimize

    def resid(beta: Array) -> Array:
        f = np.exp(np.minimum(beta[0] + beta[1] * data.x, _MAX_LOG))
        return np.einsum("kij,kj->ki", data.w, data.y - f).ravel()

    mask = np.arange(data.x.shape[1])[None, :] < data.n_cells[:, None]
    pos = data.y[mask & (data.y > 0)]
    a0 = math.log(float(np.median(pos))) if pos.size else math.log(1e-3)
    res = optimize.least_squares(resid, np.array([a0, 2.0]), method="lm", max_nfev=200)
    beta = res.x if np.all(np.isfinite(res.x)) and abs(res.x[1]) < 20 else np.array([a0, 2.0])
    sd = np.array([0.5, 0.2])
    own, cov, ok = subject_fits(data, np.tile(beta, (data.k, 1)))
    if ok.sum() >= 3:
        spread = np.var(own[ok], axis=0, ddof=1) - np.mean(
            np.diagonal(cov[ok], axis1=1, axis2=2), axis=0)
        sd = np.sqrt(np.clip(spread, [0.05**2, 0.02**2], [3.0**2, 1.0**2]))
    load = [sd[0], 0.0, sd[1]] if spec.q == 2 else [sd[0]]
    return np.array([*beta, *load, *([0.0] if spec.fit_phi else [])], dtype=float)


def subject_fits(data: NonlinearData, start: Array) -> tuple[Array, Array, NDArray[np.bool_]]:
    """Each subject's own power law on the linear scale, ``(log F at exp(c), n)``, weighted
    by its cells' covariance (Gauss-Newton from *start*), with its covariance.

    Parameters
    ----------
    data : NonlinearData
    start : ndarray, shape (k, 2)
        Where each subject's fit starts (the mixed model's modes).

    Returns
    -------
    (ndarray, ndarray, ndarray of bool)
        Shapes (k, 2), (k, 2, 2), (k,): the estimates, their covariance, and whether the
        fit is determined (two amplitudes or more, converged, a level above 1e-9 N and an
        exponent within +/- 15).
    """
    b = np.array(start, dtype=float)
    zero = np.zeros((data.k, 2))
    eye = np.eye(2)
    done = np.zeros(data.k, dtype=bool)
    state = _state(data, b, eye, 1.0, zero)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        for _ in range(200):
            step = _solve(state[2] + 1e-12 * eye, state[1])
            done = np.max(np.abs(step), axis=1) < 1e-9
            if done.all() or not np.all(np.isfinite(step)):
                break
            t = np.ones((data.k, 1))
            for _ in range(40):
                new = _state(data, b + t * step, eye, 1.0, zero)
                worse = ~(new[0] <= state[0] + 1e-12 * (1.0 + state[0]))
                if not worse.any():
                    break
                t[worse] /= 2.0
            b, state = b + t * step, new
        info = state[2]
        det = info[:, 0, 0] * info[:, 1, 1] - info[:, 0, 1] ** 2
        cov = np.full((data.k, 2, 2), np.nan)
        ok = det > 1e-12 * np.maximum(info[:, 0, 0] * info[:, 1, 1], 1e-300)
        cov[ok] = np.linalg.inv(info[ok])
    amps = np.array([np.unique(np.round(data.x[i, :n], 9)).size
                     for i, n in enumerate(data.n_cells)])
    good = (ok & done & (amps >= 2) & np.all(np.isfinite(b), axis=1)
            & (b[:, 0] > math.log(1e-9)) & (np.abs(b[:, 1]) < 15.0))
    return b, cov, good
