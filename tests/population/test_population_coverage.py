"""The population's 95 % intervals hold the truth in 90-98 % of simulated studies of 5 to
12 subjects (population_sim.py: power-law populations measured as a lab does, and
populations following the seed paper's eq. 11). More runs, per kind and size:
``python tests/population_coverage.py --seeds 300`` (docs/population.md)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))

from population_coverage import KINDS, Tally, check

SIZES = (5, 8, 12)
MIXED = ("power law, exponents spread 0.1", "the paper's model (eq. 11)")


@pytest.mark.slow
def test_intervals_cover_the_truth():
    """150 studies (of 5, 8 and 12 subjects in turn, half of each kind): the exponent's
    and every amplitude's F_el interval hold the population's value in 90-98 % of them,
    and few studies of these populations (which have no outlier) name one."""
    tally = Tally()
    for i, seed in enumerate(range(1000, 1150)):
        k, kind = SIZES[i % 3], MIXED[(i // 3) % 2]
        tables, truth = KINDS[kind](np.random.default_rng([seed, k]), k)
        check(tables, truth, tally)
    exponent, force = tally.rates()
    assert tally.exponent_runs == 150 and tally.force_runs == 750
    assert 0.90 <= exponent <= 0.98, exponent
    assert 0.90 <= force <= 0.98, force
    assert tally.named / tally.runs <= 0.10
