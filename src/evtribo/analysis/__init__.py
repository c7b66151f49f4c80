"""From forces to results: alignment, steady-sliding windows, estimates, spectra, power laws.

The layers, each a module of plain numpy functions:

- :mod:`~evtribo.analysis.settings`: the settings, their defaults and ``[analysis]``;
- :mod:`~evtribo.analysis.align`: the two load cells on one time grid, NaN in gaps;
- :mod:`~evtribo.analysis.excitation`, :mod:`~evtribo.analysis.conditions`: what the
  excitation was, and ON/OFF per grid point, with guard times at switches;
- :mod:`~evtribo.analysis.hum`: mains hum found and notched out;
- :mod:`~evtribo.analysis.tare`, :mod:`~evtribo.analysis.lifted`: the load cells'
  calibration, their zero offsets and drift from finger-lifted stretches and the friction
  loop;
- :mod:`~evtribo.analysis.windows`: steady-sliding windows found from the friction itself;
- :mod:`~evtribo.analysis.estimate`: friction coefficient, inferred electrostatic force and
  their bootstrap intervals (calibrated for the few windows a trial gives; the replicates
  are written to ``electrostatic_bootstrap.csv`` for ``evtribo compare``, see
  :mod:`~evtribo.analysis.pipeline`);
- :mod:`~evtribo.analysis.powerlaw`: ``F_el = k * U**n`` over amplitudes;
- :mod:`~evtribo.analysis.spectra`: the friction's dominant oscillation frequency.

Around them: :mod:`~evtribo.analysis.trial` analyses one decoded trial
(:class:`evtribo.signals.TrialSignals`, cut into continuous pieces by
:mod:`~evtribo.analysis.pieces`; a sine trial's extras in :mod:`~evtribo.analysis.sine`),
:mod:`~evtribo.analysis.workers` runs the trials of a study in worker processes,
:mod:`~evtribo.analysis.aggregate` turns all windows into the per-subject tables, and
:mod:`~evtribo.analysis.pipeline` (``analyze_study``) ties them together and writes the
result folder.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from evtribo.analysis.align import AlignedForces, align_forces
    from evtribo.analysis.conditions import condition_from_excitation, constant_condition
    from evtribo.analysis.estimate import (
        ElectrostaticEstimate,
        electrostatic_force,
        estimate_electrostatic,
        friction_coefficient,
    )
    from evtribo.analysis.powerlaw import PowerLawFit, fit_power_law
    from evtribo.analysis.spectra import dominant_frequency
    from evtribo.analysis.windows import find_windows

#: Where each name of this package lives: imported on first use, so that importing one
#: module of the package (``evtribo analyze`` of an unchanged study reads only
#: :mod:`evtribo.memo` and :mod:`.unchanged`) does not import numpy, pandas and scipy.
_HOMES = {
    "AlignedForces": "align", "align_forces": "align",
    "condition_from_excitation": "conditions", "constant_condition": "conditions",
    "ElectrostaticEstimate": "estimate", "electrostatic_force": "estimate",
    "estimate_electrostatic": "estimate", "friction_coefficient": "estimate",
    "PowerLawFit": "powerlaw", "fit_power_law": "powerlaw",
    "dominant_frequency": "spectra", "find_windows": "windows",
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
    "electrostatic_force",
    "estimate_electrostatic",
    "find_windows",
    "fit_power_law",
    "friction_coefficient",
]
