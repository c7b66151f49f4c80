"""One subject's least-squares problem: its points, their weights and the model at them.

The free parameters are scaled so that the optimiser works on numbers near 1: a parameter
``p`` is ``start * x``, except the layers' resistances (:data:`LOG_PARAMETERS`, ``r_sc``
and ``r_g``), which span decades and are fitted in log space, ``p = start * exp(x)``, between
bounds that put the circuit's corner frequency a thousand times below the lowest and above
the highest drive frequency measured (beyond them the data cannot tell the value from 0 or
from infinity). Their start is the best of a grid over that range, since the paper's
default (infinite) gives no direction to follow.

Each point is the model at its own waveform, drive frequency, amplitude and mean normal
force ON (:func:`evtribo.fit.model_points.mean_electrostatic_force`): with finite
resistances the gap sees the effective amplitude of :mod:`evtribo.model.circuit`.
"""

from __future__ import annotations

import itertools
import logging
import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

# scipy.stats' distributions' functions are scipy.special's (the same numbers, without its import)
from scipy import optimize, special

from evtribo.errors import AnalysisError, ConfigError
from evtribo.fit.model_points import (
    ForceFunction,
    gap_amplitude_fixed,
    mean_electrostatic_force,
    mean_electrostatic_force_many,
    mean_friction_force,
)
from evtribo.model.circuit import layer_elastances
from evtribo.model.friction_law import LoadLaw
from evtribo.model.params import PARAMETER_BOUNDS, TABLE_1, ModelParameters
from evtribo.warning.collect import emitter

log = logging.getLogger(__name__)
emit = emitter(__name__)

__all__ = ["LOG_PARAMETERS", "Points", "Problem", "fit_points", "with_friction_law"]

_Z95 = float(special.ndtri(0.975))
#: Parameters fitted in log space (they span decades).
LOG_PARAMETERS: tuple[str, ...] = ("r_sc", "r_g")
#: How far beyond the measured frequencies a resistance's corner may go (a factor).
CORNER_MARGIN = 1e3
#: Values of a log-space parameter tried for its start.
START_GRID = 25


def _sigmas(rows: pd.DataFrame, subject: str) -> NDArray[np.float64]:
    width = (rows["electrostatic_force_ci_high_N"].to_numpy(float)
             - rows["electrostatic_force_ci_low_N"].to_numpy(float))
    sigma = width / (2.0 * _Z95)
    ok = np.isfinite(sigma) & (sigma > 0)
    if not ok.all():
        if ok.any():
            fill = float(np.median(sigma[ok]))
            emit("points-unweighted", subject=subject, points=int((~ok).sum()), sigma_N=fill)
        else:
            fill = 1.0
            emit("intervals-none", subject=subject)
        sigma = np.where(ok, sigma, fill)
    return sigma


@dataclass(frozen=True)
class Points:
    """A subject's usable electrostatic points and the windows fitted with them.

    Attributes
    ----------
    fn, amp, freq, wave : ndarray
        Mean normal force ON (N), amplitude (V), drive frequency (Hz, NaN when unknown)
        and waveform of each point.
    measured, sigma : ndarray
        Inferred electrostatic force and its standard error, N.
    good : ndarray of bool
        Which of the subject's rows are the points.
    mu_measured : float
        Friction coefficient from the OFF windows.
    w_fn, w_ft, w_amp, w_wave, w_freq : ndarray
        The windows' normal and friction forces, amplitude (0 OFF), waveform and drive
        frequency (NaN unknown; empty unless ``mu`` is fitted).
    """

    fn: NDArray[np.float64]
    amp: NDArray[np.float64]
    freq: NDArray[np.float64]
    wave: NDArray[np.object_]
    measured: NDArray[np.float64]
    sigma: NDArray[np.float64]
    good: NDArray[np.bool_]
    mu_measured: float
    w_fn: NDArray[np.float64]
    w_ft: NDArray[np.float64]
    w_amp: NDArray[np.float64]
    w_wave: NDArray[np.object_]
    w_freq: NDArray[np.float64]

    @classmethod
    def of(cls, subject: str, rows: pd.DataFrame, windows: pd.DataFrame | None = None, *,
           use_windows: bool = False, need_frequency: bool = False) -> Points:
        """The rows' finite points with their weights, and the windows when *use_windows*.

        Parameters
        ----------
        subject : str
            The subject (for messages).
        rows : DataFrame
            The subject's rows of ``electrostatic.csv``.
        windows : DataFrame, optional
            The subject's rows of ``windows.csv``.
        use_windows : bool
            Whether ``mu`` is fitted (the windows then join the points).
        need_frequency : bool
            Whether the model needs each point's drive frequency (a finite resistance):
            points without one are left out.

        Returns
        -------
        Points
        """
        fn = rows["normal_force_on_N"].to_numpy(float)
        amp = rows["amplitude_V"].to_numpy(float)
        freq = (rows["frequency_Hz"].to_numpy(float) if "frequency_Hz" in rows.columns
                else np.full(len(rows), np.nan))
        wave = rows["waveform"].astype(str).to_numpy(object)
        measured = rows["electrostatic_force_N"].to_numpy(float)
        good = np.isfinite(fn) & np.isfinite(amp) & np.isfinite(measured) & (fn > 0)
        if need_frequency:
            if not np.any(np.isfinite(freq) & (freq > 0)):
                raise AnalysisError(f"subject {subject}: the layers' resistances need the "
                                    "points' drive frequency (electrostatic.csv's "
                                    "frequency_Hz), which none has")
            good &= np.isfinite(freq) & (freq > 0)
        if not good.all():
            emit("points-missing", subject=subject, points=int((~good).sum()))
        mus = rows["mu"].to_numpy(float)
        mu_measured = float(np.nanmean(mus)) if np.isfinite(mus).any() else math.nan
        empty = np.empty(0)
        w_fn, w_ft, w_amp, w_wave, w_freq = empty, empty, empty, np.empty(0, object), empty
        if use_windows:
            if windows is None or windows.empty:
                raise AnalysisError(f"subject {subject}: fitting mu needs its windows "
                                    "(windows.csv has none)")
            w_fn = windows["normal_force_N"].to_numpy(float)
            w_ft = windows["friction_force_N"].to_numpy(float)
            w_on = windows["condition"].astype(str).str.lower().to_numpy() == "on"
            w_amp = np.where(w_on, windows["amplitude_V"].to_numpy(float), 0.0)
            w_wave = windows["waveform"].astype(str).to_numpy(object)
            w_freq = (windows["frequency_Hz"].to_numpy(float)
                      if "frequency_Hz" in windows.columns else np.full(len(w_fn), np.nan))
            keep = np.isfinite(w_fn) & np.isfinite(w_ft) & np.isfinite(w_amp) & (w_fn > 0)
            if need_frequency:
                keep &= (w_amp == 0) | (np.isfinite(w_freq) & (w_freq > 0))
            w_fn, w_ft, w_amp = w_fn[keep], w_ft[keep], w_amp[keep]
            w_wave, w_freq = w_wave[keep], w_freq[keep]
        return cls(fn[good], amp[good], freq[good], wave[good], measured[good],
                   _sigmas(rows[good], subject), good, mu_measured, w_fn, w_ft, w_amp, w_wave,
                   w_freq)


def with_friction_law(base: ModelParameters, rows: pd.DataFrame) -> ModelParameters:
    """*base* with the subject's friction law as evtribo analyze measured it: ``m`` its
    ``friction_exponent`` (the one its forces were inferred with) and ``W0`` its ON
    windows' mean normal force (where its ``mu`` was taken); *base* as it is without them.

    Parameters
    ----------
    base : ModelParameters
    rows : DataFrame
        The subject's rows of ``electrostatic.csv``.

    Returns
    -------
    ModelParameters
    """
    if "friction_exponent" not in rows.columns:
        return base
    m = pd.to_numeric(rows["friction_exponent"], errors="coerce").to_numpy(float)
    fn = pd.to_numeric(rows["normal_force_on_N"], errors="coerce").to_numpy(float)
    m, fn = m[np.isfinite(m) & (m > 0)], fn[np.isfinite(fn) & (fn > 0)]
    if m.size == 0 or fn.size == 0:
        return base
    return base.with_load_law(LoadLaw(float(m[0]), float(np.mean(fn))))


def _resistance_range(name: str, base: ModelParameters,
                      freq: NDArray[np.float64]) -> tuple[float, float]:
    """The resistances whose corner lies within :data:`CORNER_MARGIN` of the measured
    frequencies, Ohm m^2 (the corner of a layer of capacitance c in series with the rest,
    C_rest: ``1 / (2 pi f (c + C_rest))``)."""
    s_sc, s_g, s_i = (float(s) for s in layer_elastances(base))
    own, rest = (s_g, s_sc + s_i) if name == "r_g" else (s_sc, s_g + s_i)
    cap = (1.0 / own if own > 0 else 0.0) + (1.0 / rest if rest > 0 else 0.0)
    f = freq[np.isfinite(freq) & (freq > 0)]
    if f.size == 0 or cap <= 0:
        raise AnalysisError(f"fitting {name} needs the drive frequency of the points "
                            "(electrostatic.csv's frequency_Hz has none)")
    lo = 1.0 / (2.0 * np.pi * float(f.max()) * CORNER_MARGIN * cap)
    hi = 1.0 / (2.0 * np.pi * float(f.min()) / CORNER_MARGIN * cap)
    return lo, hi


class Problem:
    """The least-squares problem of one subject, in scaled parameters.

    Parameters
    ----------
    subject : str
        The subject (for messages).
    names : tuple of str
        The parameters fitted.
    base : ModelParameters
        Starting values and the fixed parameters.
    pts : Points
        The points (and windows).
    use_windows : bool
        Whether the windows' friction joins the residuals (``mu`` fitted).
    force : callable, optional
        The contact's electrostatic force ``(normal_force, voltage, params) -> N``; the
        paper's eq. (11) by default.
    """

    def __init__(self, subject: str, names: tuple[str, ...], base: ModelParameters,
                 pts: Points, use_windows: bool = False, *,
                 force: ForceFunction | None = None) -> None:
        self.subject, self.names, self.base, self.pts = subject, names, base, pts
        self.use_windows, self.force = use_windows, force
        self.n_res = len(pts.measured) + (len(pts.w_fn) if use_windows else 0)
        if self.n_res < len(names) or len(pts.measured) == 0:
            raise AnalysisError(f"subject {subject}: {len(pts.measured)} usable point(s) "
                                f"for {len(names)} parameter(s) ({', '.join(names)})")
        self.is_log = np.array([n in LOG_PARAMETERS for n in names])
        start = np.array([getattr(base, n) for n in names], dtype=float)
        fallback = [getattr(TABLE_1, n) or 1e-6 for n in names]
        self.start = np.where((start > 0) & np.isfinite(start), start, fallback)
        # within the values the model takes (ModelParameters' bounds), scaled
        # (a resistance's, in log space, are set by _log_start)
        low, high = (np.array([PARAMETER_BOUNDS[n][k] for n in names]) for k in (0, 1))
        with np.errstate(invalid="ignore"):
            self.lower = np.maximum(np.array([0.0 if n.startswith("h_") else 1e-6
                                              for n in names]), low / self.start)
            self.upper = high / self.start
        self.x0 = np.where(self.is_log, 0.0, 1.0)
        self.w_sigma = 1.0
        if self.is_log.any():
            self._log_start(start)

    def _log_start(self, given: NDArray[np.float64]) -> None:
        """Bounds and start of the log-space parameters (the grid's best where not given)."""
        grids = []
        for i in np.flatnonzero(self.is_log):
            lo, hi = _resistance_range(self.names[i], self.base, self.pts.freq)
            self.start[i] = math.sqrt(lo * hi)
            half = math.log(hi / lo) / 2.0
            self.lower[i], self.upper[i] = -half, half
            if math.isfinite(given[i]) and given[i] > 0:
                grids.append([float(np.clip(math.log(given[i] / self.start[i]),
                                            -half * 0.999, half * 0.999))])
            else:
                grids.append(list(np.linspace(-half, half, START_GRID + 2)[1:-1]))
        best, best_cost = self.x0, math.inf
        for combo in itertools.product(*grids):
            x = self.x0.copy()
            x[self.is_log] = combo
            cost = float(np.sum(self.residuals(x) ** 2))
            if cost < best_cost:
                best, best_cost = x, cost
        self.x0 = best

    def to_values(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """The parameters' values at scaled *x* (any leading shape), SI units."""
        x = np.asarray(x, dtype=float)
        with np.errstate(over="ignore"):
            return np.asarray(self.start * np.where(self.is_log, np.exp(x), x), dtype=float)

    def derivative(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """d value / d x at *x* (the delta method's factors)."""
        return np.where(self.is_log, self.to_values(x), self.start)

    def magnitudes(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """How far a parameter may move before it is lost: its scaled value, and 1 (a
        factor e) in log space (see :func:`evtribo.fit.intervals.covariance`)."""
        return np.where(self.is_log, 1.0, np.abs(x))

    def params_at(self, x: NDArray[np.float64]) -> ModelParameters:
        """The model's parameters at the scaled values *x*.

        Parameters
        ----------
        x : ndarray
            Scaled values, one per fitted name.

        Returns
        -------
        ModelParameters
        """
        return self.base.with_values(dict(zip(self.names, self.to_values(x).tolist(),
                                              strict=True)))

    def model_at(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """The model's electrostatic force at the points, N.

        Parameters
        ----------
        x : ndarray
            Scaled values.

        Returns
        -------
        ndarray
        """
        p = self.pts
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            return mean_electrostatic_force(p.fn, p.amp, p.wave, self.params_at(x),
                                            frequency=p.freq, force=self.force)

    @property
    def side_by_side(self) -> bool:
        """Whether :meth:`model_many` gives :meth:`model_at`'s numbers: eq. (11)'s force
        (not a caller's, which may take one value at a time), and a gap whose amplitude
        does not depend on the parameters (no finite resistance, none fitted)."""
        return self.force is None and gap_amplitude_fixed(self.base, self.names)

    def model_many(self, xs: NDArray[np.float64]) -> NDArray[np.float64]:
        """:meth:`model_at` of each row of *xs*, evaluated at once (where
        :attr:`side_by_side`).

        Parameters
        ----------
        xs : ndarray, shape (K, n_parameters)
            Scaled values.

        Returns
        -------
        ndarray, shape (K, n_points)
            The forces, N; NaN in the rows whose parameters are not valid (where
            :meth:`model_at` raises :class:`~evtribo.errors.ConfigError`).
        """
        p = self.pts
        values = self.to_values(np.atleast_2d(np.asarray(xs, dtype=float)))
        valid = np.ones(len(values), dtype=bool)
        for k, row in enumerate(values):  # each row checked as model_at checks it
            try:
                self.base.with_values(dict(zip(self.names, row.tolist(), strict=True)))
            except ConfigError:
                valid[k] = False
        out = np.full((len(values), len(p.measured)), np.nan)
        if valid.any():
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                out[valid] = mean_electrostatic_force_many(
                    p.fn, p.amp, p.wave, self.base,
                    {n: values[valid, i] for i, n in enumerate(self.names)},
                    frequency=p.freq, force=self.force)
        return out

    def residuals(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """Weighted residuals of the points (and of the windows when they are fitted).

        Parameters
        ----------
        x : ndarray
            Scaled values.

        Returns
        -------
        ndarray
        """
        p = self.pts
        n = len(p.measured) + (len(p.w_fn) if self.use_windows else 0)
        try:  # an air gap run off to infinity (no force to see): the model has no value
            params = self.params_at(x)
        except ConfigError:
            return np.full(n, 1e6)
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            r = (p.measured - mean_electrostatic_force(p.fn, p.amp, p.wave, params,
                                                       frequency=p.freq, force=self.force)
                 ) / p.sigma
            if self.use_windows:
                rw = (p.w_ft - mean_friction_force(p.w_fn, p.w_amp, p.w_wave, params,
                                                   frequency=p.w_freq)) / self.w_sigma
                r = np.concatenate([r, rw])
        return np.nan_to_num(r, nan=1e6, posinf=1e6, neginf=-1e6)

    def profile_cost(self, i: int, xi: float, x: NDArray[np.float64]) -> float:
        """The least weighted sum of squares with parameter *i* held at scaled *xi* (the
        others refitted from *x*).

        Parameters
        ----------
        i : int
            The parameter held.
        xi : float
            Its scaled value.
        x : ndarray
            The solution (where the others start).

        Returns
        -------
        float
        """
        free = np.arange(len(self.names)) != i
        full = x.copy()
        full[i] = xi

        def resid(y: NDArray[np.float64]) -> NDArray[np.float64]:
            full[free] = y
            return self.residuals(full)

        if not free.any():
            return float(np.sum(resid(full[free]) ** 2))
        start = np.clip(x[free], self.lower[free], self.upper[free])
        res = optimize.least_squares(resid, start, jac="3-point", method="trf",
                                     bounds=(self.lower[free], self.upper[free]),
                                     xtol=1e-10, ftol=1e-10, max_nfev=500)
        return float(np.sum(res.fun**2))

    def _least_squares(self, x0: NDArray[np.float64]) -> optimize.OptimizeResult:
        res = optimize.least_squares(self.residuals, x0, jac="3-point",
                                     bounds=(self.lower, self.upper), method="trf",
                                     x_scale=1.0, xtol=1e-12, ftol=1e-12, gtol=1e-12,
                                     max_nfev=2000)
        if not res.success:
            raise AnalysisError(f"subject {self.subject}: the fit did not converge: "
                                f"{res.message}")
        return res

    def solve(self) -> optimize.OptimizeResult:
        """The solution; with windows, weighted by their own misfit and solved once more.

        Returns
        -------
        scipy.optimize.OptimizeResult
            ``least_squares``'s result (``x`` scaled, ``fun`` the weighted residuals).
        """
        res = self._least_squares(self.x0)
        if self.use_windows:
            rw = res.fun[len(self.pts.measured):] * self.w_sigma
            self.w_sigma = max(float(np.sqrt(np.mean(rw**2))), 1e-9)
            res = self._least_squares(res.x)
        return res


def fit_points(subject: str, rows: pd.DataFrame, names: tuple[str, ...],
               base: ModelParameters, *, force: ForceFunction | None = None,
               frequency: bool = True
               ) -> tuple[Problem, optimize.OptimizeResult]:
    """Fit *names* to one subject's electrostatic points (no windows, no intervals).

    Parameters
    ----------
    subject : str
        The subject (for messages).
    rows : DataFrame
        The subject's rows of ``electrostatic.csv``.
    names : tuple of str
        The parameters fitted.
    base : ModelParameters
        Starting values and the fixed parameters (``mu`` replaced by the measured one).
    force : callable, optional
        The contact's electrostatic force (eq. 11 by default).
    frequency : bool
        Whether points without a drive frequency are left out (needed with a finite or
        fitted resistance).

    Returns
    -------
    (Problem, OptimizeResult)
        The problem and its solution.
    """
    need = frequency and (any(n in LOG_PARAMETERS for n in names)
                          or not (math.isinf(base.r_sc) and math.isinf(base.r_g)))
    pts = Points.of(subject, rows.reset_index(drop=True), need_frequency=need)
    if pts.mu_measured > 0:
        base = base.with_values(mu=pts.mu_measured)
    base = with_friction_law(base, rows)
    problem = Problem(subject, names, base, pts, force=force)
    return problem, problem.solve()

