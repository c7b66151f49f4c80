"""Speed of the model where fitting needs it: the Maugis-Dugdale contact, and a sweep fit.

Every point of a voltage or frequency sweep has its own voltage, hence its own Maugis
parameter lambda. The baseline is the point-by-point solver (one bracketed root search per
point, after its own pull-off point: :func:`evtribo.model.maugis._solve`, what
``maugis_dugdale`` ran for every point before it was vectorised); the figure is
:func:`evtribo.model.maugis.md_dimensionless` on the same points, in the same run, with the
largest difference between the two.

The sweep fit: one subject's ``electrostatic.csv`` rows of a square-wave sweep at 100 V over
eight frequencies from 20 Hz to 10 kHz and five amplitudes (40 points, made with a leaky gap,
2 % noise), fitted for ``h_L`` and ``r_g`` (``compare --fit h_L,r_g``) with and without 200
bootstrap refits, and the four candidate models (``compare --models``); the baseline is the
paper's one-parameter fit (``h_L``) of the same rows in the same run.

Run: ``python benchmarks/model.py [--points N]``.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np
import pandas as pd

from evtribo import model
from evtribo.fit.fit import fit_subject
from evtribo.fit.model_points import mean_electrostatic_force
from evtribo.fit.models import CANDIDATES, fit_models
from evtribo.model import maugis

SWEEP_HZ = (20.0, 50.0, 100.0, 200.0, 500.0, 1000.0, 3000.0, 10000.0)
SWEEP_V = (40.0, 70.0, 100.0, 140.0, 200.0)


def _sweep_rows(rng: np.random.Generator) -> pd.DataFrame:
    """40 points of a leaky gap (corner about 100 Hz) with 2 % noise."""
    p = model.TABLE_1.with_values(h_L=5e-6, mu=0.5, r_g=80.0)
    f, u = (a.ravel() for a in np.meshgrid(SWEEP_HZ, SWEEP_V))
    fn = 0.5 * np.exp(0.05 * rng.standard_normal(f.size))
    meas = mean_electrostatic_force(fn, u, "square", p, frequency=f) * np.exp(
        0.02 * rng.standard_normal(f.size))
    return pd.DataFrame({"subject": "P01", "waveform": "square", "frequency_Hz": f,
                         "amplitude_V": u, "mu": 0.5, "normal_force_on_N": fn,
                         "electrostatic_force_N": meas,
                         "electrostatic_force_ci_low_N": meas * (1 - 1.96 * 0.02),
                         "electrostatic_force_ci_high_N": meas * (1 + 1.96 * 0.02)})


def _timed(func: Callable[[], object], repeat: int = 3) -> float:
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        func()
        best = min(best, time.perf_counter() - t)
    return float(best)


def sweep_fit(rng: np.random.Generator) -> None:
    """Print the time of the sweep fits against the paper's one-parameter fit."""
    rows = _sweep_rows(rng)
    reps = rows["electrostatic_force_N"].to_numpy() * np.exp(
        0.02 * rng.standard_normal((200, len(rows))))
    base = _timed(lambda: fit_subject("P01", rows, fit=("h_L",)))
    circ = _timed(lambda: fit_subject("P01", rows, fit=("h_L", "r_g")))
    boot = _timed(lambda: fit_subject("P01", rows, fit=("h_L", "r_g"), replicates=reps), 1)
    models = _timed(lambda: fit_models(rows, tuple(CANDIDATES)), 1)
    print(f"Sweep fit, one subject, {len(rows)} points (8 frequencies x 5 amplitudes):")
    print(f"  h_L alone, paper's model  {1e3 * base:8.1f} ms (baseline)")
    print(f"  h_L and r_g               {1e3 * circ:8.1f} ms ({circ / base:.1f}x)")
    print(f"  h_L and r_g, 200 refits   {1e3 * boot:8.1f} ms ({boot / base:.1f}x)")
    print(f"  the four models           {1e3 * models:8.1f} ms ({models / base:.1f}x)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=10_000, help="points (10000)")
    parser.add_argument("--baseline-points", type=int, default=1_000,
                        help="points timed point by point (1000; scaled)")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    n = args.points
    force = rng.uniform(0.1, 2.0, n)
    voltage = rng.uniform(10.0, 200.0, n)  # every point its own lambda
    dg = np.asarray(model.surface_energy(voltage))
    lam = np.asarray(model.maugis_parameter(voltage))
    load = force / (np.pi * dg * model.TABLE_1.R)

    t = time.perf_counter()
    a_v, _m = maugis.md_dimensionless(load, lam)
    vec = (time.perf_counter() - t) / n
    k = min(args.baseline_points, n)
    maugis._pulloff.cache_clear()
    t = time.perf_counter()
    ref = np.array([maugis._solve(float(p), float(v)) for p, v in zip(load[:k], lam[:k],
                                                                      strict=True)])
    point = (time.perf_counter() - t) / k
    diff = float(np.nanmax(np.abs(np.asarray(a_v)[:k] / ref[:, 0] - 1)))
    print(f"Maugis-Dugdale, {n:,} points with distinct lambda:")
    print(f"  vectorised      {1e6 * vec:8.2f} us a point ({vec * n:.3f} s)")
    print(f"  point by point  {1e6 * point:8.2f} us a point (baseline, {k:,} points timed)")
    print(f"  speed-up {point / vec:.0f}x; largest relative difference of a: {diff:.1e}")
    t = time.perf_counter()
    model.maugis_dugdale(force, voltage)
    full = (time.perf_counter() - t) / n
    print(f"  maugis_dugdale (SI units, same points): {1e6 * full:.2f} us a point")
    sweep_fit(rng)


if __name__ == "__main__":
    main()
