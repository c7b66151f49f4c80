"""Checks shared by the tests that compare an analysis with the simulator's truth."""

from __future__ import annotations


def fel_ok(measured: float, true: float) -> bool:
    """Whether an inferred electrostatic force matches the truth: within 5 %, or 3 mN for
    the smallest forces."""
    return abs(measured - true) <= max(0.05 * abs(true), 0.003)
