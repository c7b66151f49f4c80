"""The population's 95 % intervals hold the truth in 90-98 % of simulated studies of 5 to
12 subjects (population_sim.py: power-law populations measured as a lab does, and
populations following the seed paper's eq. 11, whose subjects are fitted with the model for
h_L). More runs, per kind and size, with their binomial uncertainty:
``python scripts/population_coverage.py`` (docs/population.md)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

from population_coverage import Tally, run

SIZES = (5, 8, 12)
MIXED = ("power law, exponents spread 0.1", "the paper's model (eq. 11)")


@pytest.mark.slow
def test_intervals_cover_the_truth():
    """150 studies (of 5, 8 and 12 subjects in turn, half of each kind): the exponent's,
    every amplitude's F_el's and mu's intervals hold the population's value in 90-98 % of
    them, h_L's in 90-98 % of the 75 studies of the paper's model, and few studies of these
    populations (which have no outlier) name one."""
    tally = Tally()
    for i, seed in enumerate(range(1000, 1150)):
        run(MIXED[(i // 3) % 2], SIZES[i % 3], seed, tally)
    assert tally.counted == {"exponent": 150, "F_el": 750, "mu": 150, "h_L": 75,
                             **{f"F_el at {a} V": 150 for a in (60, 80, 100, 120, 140)}}
    for key in ("exponent", "F_el", "mu", "h_L"):
        assert 0.90 <= tally.rate(key) <= 0.98, (key, tally.rate(key))
    assert tally.named / tally.runs <= 0.10
