"""The population's estimates hold on noisy data: over simulated studies of 5 to 12
subjects whose cells carry errors of 1, 5 and 10 mN (weak subjects with cells near zero and
below it; population_cells.py, cells fed directly to the population step), the primary
rows' F_el at every amplitude and exponent are unbiased within 5 % and their 95 % intervals
hold the truth in 90-98 % of studies; no study's exponent is more than 1 from the truth
without a note in its checks. More runs, and the other kinds of population:
``python scripts/population_coverage.py`` (docs/population.md).

The intervals run slightly conservative: over 300 more such studies (seeds 105-404,
``scripts/population_coverage.py --cells --seeds 300 --first-seed 105``) they held the
truth in 97.3 +/- 0.9 % (exponent) and 97.3-98.0 % (F_el at each amplitude), at the top of
the 90-98 % asked. With 105 studies a share is known to about 1.5 %, so the upper end is
judged by the share's own 95 % interval (Wilson) reaching into 90-98 %; the lower end, the
side on which a reader is misled, by the share itself."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parents[1]))

from population_cells import AMPLITUDES
from population_coverage import Tally, cell_run

STUDIES = 105


@pytest.mark.slow
def test_population_forces_and_exponent_hold_on_noisy_cells():
    tally = Tally()
    for seed in range(STUDIES):
        cell_run(seed, tally)
    keys = ["exponent", *(f"F_el at {a:g} V" for a in AMPLITUDES)]
    assert {k: tally.counted[k] for k in keys} == dict.fromkeys(keys, STUDIES)
    for key in keys:
        assert abs(tally.bias(key)) <= 0.05, (key, tally.bias(key))
        assert 0.90 <= tally.rate(key) and _wilson_low(tally, key) <= 0.98, (
            key, tally.rate(key))
    assert 0.90 <= tally.rate("mu") and _wilson_low(tally, "mu") <= 0.98, tally.rate("mu")
    assert tally.silent == []


def _wilson_low(tally: Tally, key: str, z: float = 1.96) -> float:
    """The lower end of the Wilson 95 % interval of *key*'s share of intervals held."""
    n, p = tally.counted[key], tally.rate(key)
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return centre - half
