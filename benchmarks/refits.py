"""A subject's bootstrap refits side by side against one by one.

Each subject: five square-wave amplitudes and one sine, six ON windows each against one OFF
reference, through the real estimator with 200 bootstrap replicates (what ``analyze``
writes to ``electrostatic_bootstrap.csv``); the model's parameters fitted as ``compare
--fit NAMES`` fits them. The baseline is :func:`evtribo.fit.intervals.refit_replicates`
refitting the replicates with the model evaluated one row after the other (no ``many``),
in the same run, on the same replicates; the figure is the same call with the model
evaluated for every replicate at once (``many=Problem.model_many``), and the refits are
checked to be the same numbers.

Measured on 2 idle cores, 8 subjects of 200 replicates (best of 3): h_L, 0.44 s side by
side against 1.67 s one by one (3.8x; 0.48 s against 1.67 s, 3.5x, once the one-by-one
refits ran in the same loop, evaluating the model a row at a time); h_L and E_star, whose
refits take many more steps, 6.87 s against 47.5 s (6.9x, before that); the same refits,
bit for bit, each time.

Run: ``python benchmarks/refits.py [--subjects N] [--fit NAMES] [--repeat N]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pandas as pd

from evtribo.analysis.friction.estimate import estimate_electrostatic
from evtribo.fit.intervals import refit_replicates
from evtribo.fit.problem import Points, Problem
from evtribo.model import TABLE_1, electrostatic_force

AMPS = np.array([60.0, 80.0, 100.0, 120.0, 140.0])


def subject(seed: int, names: tuple[str, ...]) -> tuple[Problem, np.ndarray]:
    """One subject's fitting problem at its solution, and its 200 replicates."""
    rng = np.random.default_rng(seed)
    h_l, mu, n = rng.uniform(3e-6, 9e-6), rng.uniform(0.35, 0.6), 6
    p = TABLE_1.with_values(h_L=h_l, mu=mu)
    amps = np.r_[AMPS, 140.0]
    fn_off = rng.uniform(0.35, 0.65, n * amps.size)
    ft_off = mu * fn_off * (1 + rng.normal(0, 0.02, fn_off.size))
    fn_on = rng.uniform(0.35, 0.65, (amps.size, n))
    fel = electrostatic_force(fn_on, amps[:, None], p)
    fel[-1] /= 2.0  # the sine's mean force, about half the square's
    ft_on = mu * (fn_on + fel) * (1 + rng.normal(0, 0.02, fn_on.shape))
    e = estimate_electrostatic([fn_off], [ft_off], fn_on.ravel(), ft_on.ravel(),
                               np.zeros(fn_on.size, int), np.repeat(np.arange(amps.size), n),
                               n_boot=200, seed=seed)
    groups = np.asarray(e.groups, dtype=int)
    rows = pd.DataFrame({"subject": "S",
                         "waveform": np.where(groups == AMPS.size, "sine", "square"),
                         "amplitude_V": amps[groups], "mu": e.mu,
                         "normal_force_on_N": e.normal_on_N,
                         "electrostatic_force_N": e.force_N,
                         "electrostatic_force_ci_low_N": e.ci_low_N,
                         "electrostatic_force_ci_high_N": e.ci_high_N})
    problem = Problem(f"S{seed}", names, TABLE_1, Points.of("S", rows))
    from scipy import optimize  # the fit's own solution: the refits' start

    res = optimize.least_squares(problem.residuals, problem.x0, bounds=(problem.lower,
                                                                       problem.upper))
    problem.x0 = res.x
    return problem, np.asarray(e.replicates_N, dtype=float)


def refits(problems: list[tuple[Problem, np.ndarray]], side_by_side: bool
           ) -> tuple[float, list[np.ndarray]]:
    """Seconds to refit every subject's replicates, and the refits."""
    t = time.perf_counter()
    out = [refit_replicates(p.model_at, p.x0, reps, p.pts.sigma, p.lower, upper=p.upper,
                            many=p.model_many if side_by_side and p.side_by_side else None)
           for p, reps in problems]
    return time.perf_counter() - t, out


def main() -> None:
    """Print both timings, their ratio and whether the refits agree."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--subjects", type=int, default=8)
    parser.add_argument("--fit", default="h_L")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    names = tuple(n.strip() for n in args.fit.split(","))
    problems = [subject(k, names) for k in range(args.subjects)]
    each, side = [], []
    for _ in range(args.repeat):
        t_each, r_each = refits(problems, side_by_side=False)
        t_side, r_side = refits(problems, side_by_side=True)
        each.append(t_each)
        side.append(t_side)
    same = all(np.array_equal(a, b) for a, b in zip(r_each, r_side, strict=True))
    n_reps = sum(len(r) for _, r in problems)
    print(f"{args.subjects} subjects, {n_reps} replicates, fitting {', '.join(names)}; "
          f"baseline: one by one, same run, best of {args.repeat}")
    print(f"  one by one    {min(each):.2f} s")
    print(f"  side by side  {min(side):.2f} s: {min(each) / min(side):.1f}x faster; "
          f"the same refits: {'yes, bit for bit' if same else 'NO'}")


if __name__ == "__main__":
    main()
