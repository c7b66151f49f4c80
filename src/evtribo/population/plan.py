"""Sizing a study before recording it: what intervals and what power a design gives.

:func:`plan_study` takes a design (subjects, trials per amplitude, trial and phase lengths,
the friction's scatter between strokes, amplitudes) and what the researcher expects (the
population's F_el at the highest amplitude, its exponent, how much subjects differ, a
contrast between two conditions) and answers in two steps:

1. **The simulator** (:mod:`evtribo.acquisition.simulator`): a few pilot subjects, whose
   force at the highest amplitude is the one expected, record the designed trials on the
   simulated rig, with a person's strokes and a real rig's load cells, and ``evtribo
   analyze``'s pipeline analyses them: each amplitude's F_el interval, and the correlation of
   a subject's forces between amplitudes (its bootstrap replicates), as this design gives
   them. The friction's scatter between strokes is the sliding speed's (strokes' speeds spread
   over a factor of 3, ``mu ~ v^beta`` with beta chosen so that the strokes' friction scatters
   by the fraction asked; Adams et al. 2013 measured beta of 0.1-0.2).
2. **Studies at the cell level**: many studies of the design's subjects drawn from the
   expected population (``log k`` and ``n`` normal), each cell measured with the pilots'
   errors, each analysed as ``evtribo compare`` does (the nonlinear mixed model, its
   primary optimiser), and the contrast between two conditions (each subject's ratio drawn
   about the expected one) as population_contrasts.csv computes it.

The answer (:class:`Plan`): per number of subjects, the expected 95 % interval of a subject's
F_el at each amplitude (from the pilots), of the population's F_el at each amplitude and of its
exponent (medians over the studies), and the power to detect the contrast (the share of
studies whose interval of the ratio excludes 1), each with its Monte Carlo uncertainty.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import tempfile
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

# scipy.stats' distributions' functions are scipy.special's (the same numbers, without its import)
from scipy import optimize, special

from evtribo.errors import ConfigError
from evtribo.fit.model_points import mean_electrostatic_force
from evtribo.fit.tables import ResultTables
from evtribo.model.params import TABLE_1
from evtribo.population.contrasts import contrast
from evtribo.population.data import Collector, subject_data
from evtribo.population.nonlinear import nonlinear_data
from evtribo.population.nonlinear_fit import fit_nonlinear
from evtribo.warning.record import WarningRecord

log = logging.getLogger(__name__)

__all__ = ["Design", "Expected", "Pilot", "Plan", "pilot_errors", "plan_study"]

_Z95 = float(special.ndtri(0.975))
#: The ratio of the fastest to the slowest stroke's speed of the pilots (a person's).
SPEED_SPREAD = 3.0

Progress = Callable[[str], None]


@dataclass(frozen=True)
class Design:
    """A study's design.

    Attributes
    ----------
    subjects : tuple of int
        Numbers of subjects to compare (each at least 3).
    trials : int
        Trials per subject and amplitude.
    trial_s, on_s, off_s : float, s
        Each trial's length and its ON and OFF phases.
    stroke_scatter : float
        Relative standard deviation of the friction between strokes (0.02: 2 %).
    amplitudes : tuple of float, V
        The amplitudes each subject is measured at (square drive, 10 kHz).
    normal_force_N : float, N
        The force the subjects press with.
    """

    subjects: tuple[int, ...] = (8,)
    trials: int = 1
    trial_s: float = 20.0
    on_s: float = 2.0
    off_s: float = 2.0
    stroke_scatter: float = 0.02
    amplitudes: tuple[float, ...] = (60.0, 80.0, 100.0, 120.0, 140.0)
    normal_force_N: float = 0.5

    def __post_init__(self) -> None:
        checks: list[tuple[str, bool, str]] = [
            ("subjects", bool(self.subjects) and all(
                isinstance(n, int) and 3 <= n <= 200 for n in self.subjects),
             "numbers of subjects from 3 (a population's fewest) to 200"),
            ("trials", isinstance(self.trials, int) and 1 <= self.trials <= 20,
             "1 to 20 trials per amplitude"),
            ("trial-length", 2.0 <= self.trial_s <= 600.0, "2 to 600 s"),
            ("on-time", 0.2 <= self.on_s <= self.trial_s / 2, "0.2 s to half a trial"),
            ("off-time", 0.2 <= self.off_s <= self.trial_s / 2, "0.2 s to half a trial"),
            ("stroke-scatter", 0.0 <= self.stroke_scatter <= 0.3, "0 to 0.3 (30 %)"),
            ("amplitudes", len(self.amplitudes) >= 2 and all(
                0 < a <= 1000 for a in self.amplitudes) and len(set(self.amplitudes)) == len(
                    self.amplitudes), "two different amplitudes or more, each 0-1000 V"),
            ("normal-force", 0.05 <= self.normal_force_N <= 5.0, "0.05 to 5 N")]
        for key, ok, what in checks:
            if not ok:
                value = {"subjects": self.subjects, "trials": self.trials,
                         "trial-length": self.trial_s, "on-time": self.on_s,
                         "off-time": self.off_s, "stroke-scatter": self.stroke_scatter,
                         "amplitudes": self.amplitudes,
                         "normal-force": self.normal_force_N}[key]
                raise ConfigError(f"{value!r} is not allowed: {what}", key=f"--{key}")


@dataclass(frozen=True)
class Expected:
    """What the researcher expects of the population.

    Attributes
    ----------
    force_N : float, N
        The population's F_el (geometric mean) at the highest amplitude.
    exponent : float
        The population's exponent n of F_el = k U^n.
    spread : float
        Standard deviation of log F_el between subjects.
    exponent_spread : float
        Standard deviation of the subjects' exponents.
    contrast : float
        The ratio of F_el between two conditions to detect (paired within subjects).
    contrast_spread : float
        Standard deviation of the subjects' log ratio.
    """

    force_N: float = 0.1
    exponent: float = 2.0
    spread: float = 0.5
    exponent_spread: float = 0.15
    contrast: float = 1.25
    contrast_spread: float = 0.1

    def __post_init__(self) -> None:
        for key, value, lo, hi in (("force", self.force_N, 1e-4, 10.0),
                                   ("exponent", self.exponent, 0.5, 5.0),
                                   ("spread", self.spread, 0.0, 2.0),
                                   ("exponent-spread", self.exponent_spread, 0.0, 1.0),
                                   ("contrast", self.contrast, 1.01, 10.0),
                                   ("contrast-spread", self.contrast_spread, 0.0, 1.0)):
            if not (isinstance(value, int | float) and lo <= value <= hi):
                raise ConfigError(f"{value!r} is not allowed: from {lo:g} to {hi:g}",
                                  key=f"--{key}")


@dataclass(frozen=True)
class Pilot:
    """What the simulated pilots' trials gave: each amplitude's error of F_el.

    Attributes
    ----------
    amplitudes : ndarray, V
    error_N : ndarray, N
        The standard error of a subject's F_el at each amplitude (root mean square over the
        pilots: their 95 % intervals' half-widths over 1.96).
    correlation : float
        The mean correlation of a subject's forces between two amplitudes (its replicates).
    subjects : int
        Pilot subjects analysed.
    """

    amplitudes: NDArray[np.float64]
    error_N: NDArray[np.float64]
    correlation: float
    subjects: int


@dataclass
class Plan:
    """The expected intervals and power of each design.

    Attributes
    ----------
    pilot : Pilot
    table : DataFrame
        A row per number of subjects and quantity: ``subjects``, ``quantity``
        (``subject F_el``, ``population F_el``, ``exponent``, ``power``), ``amplitude_V``,
        ``value`` (the 95 % interval: a subject's F_el plus or minus this, N; the
        population's F_el times or divided by this factor; the exponent plus or minus this;
        for the power, the share of studies whose interval of the ratio excludes 1),
        ``mc_error`` (its Monte Carlo standard error) and ``runs``.
    notes : list of str
    """

    pilot: Pilot
    table: pd.DataFrame
    notes: list[str] = field(default_factory=list)


def _air_gap(force_N: float, normal_force_N: float, amplitude_V: float) -> float:
    """The air gap h_L whose model force (eq. 11, square drive) at *amplitude_V* and
    *normal_force_N* is *force_N*."""
    def excess(log_h: float) -> float:
        f = mean_electrostatic_force(normal_force_N, amplitude_V, "square",
                                     TABLE_1.with_values(h_L=math.exp(log_h)))
        return float(np.log(f)) - math.log(force_N)

    lo, hi = math.log(1e-9), math.log(1e-3)
    if excess(lo) < 0 or excess(hi) > 0:
        raise ConfigError(f"{force_N!r} N is not allowed: the seed paper's model gives "
                          f"{math.exp(excess(lo)) * force_N:.3g} N at most at "
                          f"{amplitude_V:g} V and {normal_force_N:g} N (its thinnest air gap)",
                          key="--force")
    return math.exp(float(optimize.brentq(excess, lo, hi, xtol=1e-10)))


def _pilot_subject(i: int, design: Design, h_l: float, seed: int) -> object:
    from evtribo.acquisition.simulator import SubjectParams
    from evtribo.acquisition.simulator.realism import human

    person = human(SubjectParams(name=f"P{i + 1:02d}", mu=0.5, h_L=h_l,
                                 normal_force_N=design.normal_force_N), seed=seed * 100 + i)
    beta = design.stroke_scatter * math.sqrt(12.0) / math.log(SPEED_SPREAD)
    return dataclasses.replace(person, speed_exponent=round(beta, 4),
                               speed_spread=SPEED_SPREAD if beta > 0 else 1.0)


def _record_pilots(root: Path, design: Design, expected: Expected, *, pilots: int,
                   seed: int, progress: Progress) -> None:
    """Write the pilots' trials into a study at *root* (the simulated rig)."""
    from evtribo.acquisition.simulator import TrialConfig, write_trial
    from evtribo.acquisition.simulator.realism import realistic_rig

    h_l = _air_gap(expected.force_N, design.normal_force_N, max(design.amplitudes))
    total = pilots * design.trials * len(design.amplitudes)
    done = 0
    for i in range(pilots):
        subject = _pilot_subject(i, design, h_l, seed)
        for t in range(design.trials):
            for j, amp in enumerate(design.amplitudes):
                done += 1
                progress(f"pilot: recording trial {done} of {total} on the simulated rig "
                         f"(subject {i + 1} of {pilots}, {amp:g} V)")
                cfg = TrialConfig(duration_s=design.trial_s, on_s=design.on_s,
                                  off_s=design.off_s, amplitude_V=amp,
                                  seed=seed * 100_003 + i * 1000 + t * 50 + j)
                write_trial(root, f"run-{t + 1:02d}-{j + 1:02d}", subject,  # type: ignore[arg-type]
                            realistic_rig(cfg), study_name="plan pilot")


def _correlation(boot: pd.DataFrame | None) -> float:
    """The mean correlation between two amplitudes of a subject's replicates."""
    if boot is None or boot.empty:
        return 0.0
    values = []
    for _, g in boot.groupby("subject"):
        wide = g.pivot_table(index="replicate", columns="amplitude_V",
                             values="electrostatic_force_N").dropna()
        if wide.shape[1] >= 2 and len(wide) >= 10:
            c = np.corrcoef(wide.to_numpy(float), rowvar=False)
            values.append(float(np.nanmean(c[np.triu_indices_from(c, 1)])))
    return float(np.clip(np.mean(values), 0.0, 0.95)) if values else 0.0


@contextmanager
def _quiet(*names: str) -> Iterator[None]:
    """The analysis's warnings about the pilots' simulated trials (their load cells'
    offsets, drift...) kept from the console: they are the simulator's, not the user's."""
    loggers = [logging.getLogger(n) for n in names]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.ERROR)
    try:
        yield
    finally:
        for lg, level in zip(loggers, levels, strict=True):
            lg.setLevel(level)


def pilot_errors(design: Design, expected: Expected, *, pilots: int = 2, seed: int = 0,
                 progress: Progress | None = None) -> Pilot:
    """Record and analyse the design's trials of *pilots* simulated subjects.

    Parameters
    ----------
    design : Design
    expected : Expected
        Its ``force_N`` sets the pilots' force at the highest amplitude.
    pilots : int
        Pilot subjects.
    seed : int
    progress : callable, optional
        Told what is being done.

    Returns
    -------
    Pilot
        Each amplitude's standard error of a subject's F_el.
    """
    from evtribo.results.pipeline import compute_study

    say = progress or (lambda _: None)
    with tempfile.TemporaryDirectory(prefix="evtribo-plan-") as tmp:
        root = Path(tmp) / "pilot"
        _record_pilots(root, design, expected, pilots=pilots, seed=seed, progress=say)
        say("pilot: analysing its trials as evtribo analyze does")
        with _quiet("evtribo.results", "evtribo.analysis", "evtribo.canlog"):
            res = compute_study(root, jobs=1, cache_dir=Path(tmp) / "cache", reuse=False,
                                progress=lambda i, n: say(f"pilot: analysed {i} of {n} "
                                                          "trials"))
    es = res.electrostatic
    amps = np.array(sorted(design.amplitudes), dtype=float)
    errors = []
    for a in amps:
        at = es[np.isclose(es["amplitude_V"].to_numpy(float), a)]
        se = ((at["electrostatic_force_ci_high_N"] - at["electrostatic_force_ci_low_N"])
              / (2 * _Z95)).to_numpy(float)
        se = se[np.isfinite(se) & (se > 0)]
        if not se.size:
            raise ConfigError(f"the pilot's trials gave no electrostatic force at {a:g} V "
                              "(trials too short for their ON and OFF phases?)",
                              key="--trial-length")
        errors.append(float(np.sqrt(np.mean(se**2))))
    return Pilot(amps, np.array(errors), _correlation(res.bootstrap),
                 int(es["subject"].nunique()))


def _cells(rng: np.random.Generator, force: NDArray[np.float64], pilot: Pilot
           ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One subject's measured forces and their reported covariance (an estimated standard
    error, ten degrees of freedom; the pilots' correlation)."""
    m = force.size
    corr = pilot.correlation + (1.0 - pilot.correlation) * np.eye(m)
    y = force + rng.multivariate_normal(np.zeros(m), corr * np.outer(pilot.error_N,
                                                                     pilot.error_N))
    se = pilot.error_N * np.sqrt(rng.chisquare(10, m) / 10)
    return y, corr * np.outer(se, se)


Cells = list[tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]]


def _one_study(rng: np.random.Generator, k: int, expected: Expected, pilot: Pilot
               ) -> tuple[Cells, ResultTables]:
    """*k* subjects' cells in condition A (for the mixed model) and the tables of A and B
    (for the contrast)."""
    x = np.log(pilot.amplitudes / pilot.amplitudes.max())
    log_k = math.log(expected.force_N) + expected.spread * rng.standard_normal(k)
    n_i = expected.exponent + expected.exponent_spread * rng.standard_normal(k)
    ratio = np.exp(math.log(expected.contrast) + expected.contrast_spread
                   * rng.standard_normal(k))
    cells: Cells = []
    rows = []
    for i in range(k):
        force = np.exp(log_k[i] + n_i[i] * x)
        for freq, f in ((10_000.0, force), (100.0, force * ratio[i])):
            y, cov = _cells(rng, f, pilot)
            if freq == 10_000.0:
                cells.append((np.asarray(np.log(pilot.amplitudes), dtype=float), y, cov))
            se = np.sqrt(np.diag(cov))
            rows += [{"subject": f"S{i + 1:02d}", "waveform": "square", "frequency_Hz": freq,
                      "amplitude_V": a, "mu": 0.5, "normal_force_on_N": 0.5,
                      "electrostatic_force_N": v, "electrostatic_force_ci_low_N": v - _Z95 * e,
                      "electrostatic_force_ci_high_N": v + _Z95 * e}
                     for a, v, e in zip(pilot.amplitudes, y, se, strict=True)]
    tables = ResultTables(out=Path("."), electrostatic=pd.DataFrame(rows),
                          windows=pd.DataFrame(), exponents=pd.DataFrame(),
                          trials=pd.DataFrame(columns=["subject", "trial"]))
    return cells, tables


def _contrast_found(tables: ResultTables) -> bool | None:
    """Whether the interval of the ratio B/A excludes 1 (None: no contrast estimated)."""
    notes: list[WarningRecord] = []  # simulated cells left out: nobody to tell
    subjects = [s for s in (subject_data(tables, n, notes) for n in tables.subjects) if s]
    rows = Collector()
    contrast(rows, subjects, ("square", 10_000.0), ("square", 100.0))
    ratio = [r for r in rows.contrasts if r["quantity"] == "electrostatic_force_N"]
    if not ratio:
        return None
    return bool(ratio[0]["ci_high"] < 1.0 or ratio[0]["ci_low"] > 1.0)


def _median_row(k: int, quantity: str, amp: float, values: Sequence[float]) -> dict[str, object]:
    v = np.asarray(values, dtype=float)
    v = v[~np.isnan(v)]  # an infinite interval counts (as the widest)
    fin = v[np.isfinite(v)]
    mc = 1.2533 * float(np.std(fin, ddof=1)) / math.sqrt(v.size) if fin.size > 1 else math.nan
    return {"subjects": k, "quantity": quantity, "amplitude_V": amp,
            "value": float(np.median(v)) if v.size else math.nan, "mc_error": mc,
            "runs": int(v.size)}


def _design_rows(k: int, expected: Expected, pilot: Pilot, *, runs: int,
                 rng: np.random.Generator, say: Progress) -> list[dict[str, object]]:
    """The rows of one number of subjects: *runs* studies at the cell level."""
    widths: dict[float, list[float]] = {float(a): [] for a in pilot.amplitudes}
    exponent: list[float] = []
    found: list[bool] = []
    for r in range(runs):
        say(f"{k} subjects: study {r + 1} of {runs} at the cell level")
        cells, tables = _one_study(rng, k, expected, pilot)
        try:
            fit = fit_nonlinear(nonlinear_data([f"S{i}" for i in range(k)], cells),
                                random_slopes=pilot.amplitudes.size >= 3,
                                optimisers=("L-BFGS-B",))
        except np.linalg.LinAlgError:
            continue
        for a, width in widths.items():
            lo, hi = fit.at(math.log(a)).interval()
            width.append(math.exp(min((hi - lo) / 2.0, 50.0)))  # e^50: no interval
        lo, hi = fit.estimate([0.0, 1.0]).interval()
        exponent.append((hi - lo) / 2.0)
        got = _contrast_found(tables)
        if got is not None:
            found.append(got)
    rows = [{"subjects": k, "quantity": "subject F_el", "amplitude_V": float(a),
             "value": _Z95 * float(e), "mc_error": math.nan, "runs": pilot.subjects}
            for a, e in zip(pilot.amplitudes, pilot.error_N, strict=True)]
    rows += [_median_row(k, "population F_el", a, w) for a, w in widths.items()]
    rows.append(_median_row(k, "exponent", math.nan, exponent))
    p = float(np.mean(found)) if found else math.nan
    rows.append({"subjects": k, "quantity": "power", "amplitude_V": math.nan, "value": p,
                 "mc_error": math.sqrt(p * (1 - p) / len(found)) if found else math.nan,
                 "runs": len(found)})
    return rows


def plan_study(design: Design, expected: Expected, *, runs: int = 40, pilots: int = 2,
               seed: int = 0, progress: Progress | None = None) -> Plan:
    """The expected intervals and power of *design* (see the module's notes).

    Parameters
    ----------
    design : Design
    expected : Expected
    runs : int
        Simulated studies per number of subjects (10 to 2000).
    pilots : int
        Pilot subjects recorded on the simulated rig (1 to 10).
    seed : int
    progress : callable, optional
        Told what is being done, step by step.

    Returns
    -------
    Plan

    Raises
    ------
    ConfigError
        *runs* or *pilots* out of range, or a force the seed paper's model cannot give.
    """
    if not (isinstance(runs, int) and 10 <= runs <= 2000):
        raise ConfigError(f"{runs!r} is not allowed: 10 to 2000 studies", key="--runs")
    if not (isinstance(pilots, int) and 1 <= pilots <= 10):
        raise ConfigError(f"{pilots!r} is not allowed: 1 to 10 pilot subjects",
                          key="--pilots")
    say = progress or (lambda _: None)
    _air_gap(expected.force_N, design.normal_force_N, max(design.amplitudes))  # at once
    pilot = pilot_errors(design, expected, pilots=pilots, seed=seed, progress=say)
    rng = np.random.default_rng([seed, 3636])
    rows: list[dict[str, object]] = []
    for k in design.subjects:
        rows += _design_rows(k, expected, pilot, runs=runs, rng=rng, say=say)
    notes = [f"A subject's F_el error at each amplitude from {pilot.subjects} pilot "
             "subject(s) recorded and analysed on the simulated rig (correlation between "
             f"amplitudes {pilot.correlation:.2f}); {runs} studies per number of subjects "
             "at the cell level, each fitted with the mixed model's primary optimiser; the "
             f"contrast {expected.contrast:g} between two conditions as "
             "population_contrasts.csv computes it (paired, log F_el of positive cells)."]
    table = pd.DataFrame(rows, columns=["subjects", "quantity", "amplitude_V", "value",
                                        "mc_error", "runs"])
    fitted = table[table["quantity"] == "population F_el"].groupby("subjects")["runs"].min()
    notes += [f"With {k} subjects the mixed model gave no fit in {runs - int(n)} of {runs} "
              "studies (forces near or below their errors); the intervals and the power are "
              f"over the {int(n)} it fitted: longer trials or more subjects would help."
              for k, n in fitted.items() if n < runs]
    return Plan(pilot, table, notes)
