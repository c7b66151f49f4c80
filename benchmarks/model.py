"""Speed of the model where fitting needs it: the Maugis-Dugdale contact.

Every point of a voltage or frequency sweep has its own voltage, hence its own Maugis
parameter lambda. The baseline is the point-by-point solver (one bracketed root search per
point, after its own pull-off point: :func:`evtribo.model.maugis._solve`, what
``maugis_dugdale`` ran for every point before it was vectorised); the figure is
:func:`evtribo.model.maugis.md_dimensionless` on the same points, in the same run, with the
largest difference between the two. Run: ``python benchmarks/model.py [--points N]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from evtribo import model
from evtribo.model import maugis


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


if __name__ == "__main__":
    main()
