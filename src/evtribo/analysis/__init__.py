"""From forces to results: alignment, steady-sliding windows, estimates, spectra, power laws.

The layers, each a module of plain numpy functions:

- :mod:`~evtribo.analysis.settings`: the settings, their defaults and ``[analysis]``;
- :mod:`~evtribo.analysis.forces.align`: the two load cells on one time grid, NaN in gaps;
- :mod:`~evtribo.analysis.forces.excitation`, :mod:`~evtribo.analysis.forces.conditions`: what the
  excitation was, and ON/OFF per grid point, with guard times at switches;
- :mod:`~evtribo.analysis.forces.hum`: mains hum found and notched out;
- :mod:`~evtribo.analysis.forces.zero_offsets`, :mod:`~evtribo.analysis.forces.lifted`: the
  load cells' calibration, their zero offsets and drift from finger-lifted stretches and the
  friction loop (a trial's taring and the windows it gives:
  :mod:`~evtribo.analysis.tared_windows`);
- :mod:`~evtribo.analysis.friction.windows`: steady-sliding windows found from the friction itself;
- :mod:`~evtribo.analysis.friction.estimate`: friction coefficient, inferred electrostatic force and
  their bootstrap intervals (calibrated for the few windows a trial gives; the replicates
  are written to ``electrostatic_bootstrap.csv`` for ``evtribo compare``, see
  :mod:`~evtribo.results.pipeline`);
- :mod:`~evtribo.analysis.friction.powerlaw`: ``F_el = k * U**n`` over amplitudes;
- :mod:`~evtribo.analysis.forces.spectra`: the friction's dominant oscillation frequency.

Around them: :mod:`~evtribo.analysis.trial` analyses one decoded trial
(:class:`evtribo.canlog.signals.TrialSignals`, cut into continuous pieces by
:mod:`~evtribo.analysis.forces.pieces`; a sine trial's extras in
:mod:`~evtribo.analysis.friction.sine`),
:mod:`~evtribo.results.workers` runs the trials of a study in worker processes,
:mod:`~evtribo.results.aggregate` turns all windows into the per-subject tables, and
:mod:`~evtribo.results.pipeline` (``analyze_study``) ties them together and writes the
result folder.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from evtribo.analysis.forces.align import AlignedForces, align_forces
    from evtribo.analysis.forces.conditions import condition_from_excitation, constant_condition
    from evtribo.analysis.forces.spectra import dominant_frequency
    from evtribo.analysis.friction.estimate import (
        ElectrostaticEstimate,
        estimate_electrostatic,
        friction_coefficient,
        mean_inferred_force,
    )
    from evtribo.analysis.friction.powerlaw import PowerLawFit, fit_power_law
    from evtribo.analysis.friction.windows import find_windows

#: Where each name of this package lives: imported on first use, so that importing one
#: module of the package (``evtribo analyze`` of an unchanged study reads only
#: :mod:`evtribo.store.memo` and :mod:`.unchanged`) does not import numpy, pandas and scipy.
_HOMES = {
    "AlignedForces": "forces.align", "align_forces": "forces.align",
    "condition_from_excitation": "forces.conditions", "constant_condition": "forces.conditions",
    "ElectrostaticEstimate": "friction.estimate", "mean_inferred_force": "friction.estimate",
    "estimate_electrostatic": "friction.estimate", "friction_coefficient": "friction.estimate",
    "PowerLawFit": "friction.powerlaw", "fit_power_law": "friction.powerlaw",
    "dominant_frequency": "forces.spectra", "find_windows": "friction.windows",
}


def __getattr__(name: str) -> Any:
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{home}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_HOMES])


__all__ = [
    "AlignedForces",
    "ElectrostaticEstimate",
    "PowerLawFit",
    "align_forces",
    "condition_from_excitation",
    "constant_condition",
    "dominant_frequency",
    "estimate_electrostatic",
    "find_windows",
    "fit_power_law",
    "friction_coefficient",
    "mean_inferred_force",
]
