"""The derived quantities the result tables, the report and the console share, each defined
once.

- :func:`friction_increase_pct`: the relative friction increase ``100 F_el / F_n,ON``
  (population_subjects.csv's and population.csv's ``friction_increase_pct``, the report's
  key results, its Tables of the population), with :data:`FRICTION_INCREASE_DEFINITION`,
  its words, and :data:`FRICTION_INCREASE_HEADING`, its name in every table.

The raw ratio of the friction ON to the friction OFF is no relative friction increase: the
subject pressed differently ON and OFF (F_n,ON is not F_n,OFF), and that ratio moves with
the press as much as with the voltage. evtribo does not report it.
"""

from __future__ import annotations

from typing import Any, overload

import numpy as np
from numpy.typing import NDArray

__all__ = ["FRICTION_INCREASE_DEFINITION", "FRICTION_INCREASE_HEADING",
           "friction_increase_pct"]

#: The relative friction increase, as the docs and the report's captions state it (word for
#: word: ``tests/test_docs.py`` checks them).
FRICTION_INCREASE_DEFINITION = (
    "relative friction increase = 100 F_el/F_n,ON, in %: the inferred electrostatic force "
    "over the mean normal force of the same ON windows, the friction the voltage adds at "
    "the same press (with Coulomb friction, F_t = μ (F_n + F_el))")
#: Its name in every table's heading.
FRICTION_INCREASE_HEADING = "relative friction increase F_el/F_n,ON (%)"


@overload
def friction_increase_pct(force_N: float, normal_on_N: float) -> float: ...


@overload
def friction_increase_pct(force_N: Any, normal_on_N: Any) -> NDArray[np.float64]: ...


def friction_increase_pct(force_N: Any, normal_on_N: Any) -> Any:
    """The relative friction increase of a cell, %: ``100 F_el / F_n,ON``.

    Parameters
    ----------
    force_N : float or array-like, N
        The electrostatic force F_el (or a bound of its interval).
    normal_on_N : float or array-like, N
        The mean normal force of the same ON windows.

    Returns
    -------
    float or ndarray, %
        ``(100 / F_n,ON) · F_el`` (in that order: population_subjects.csv's numbers bit for
        bit), NaN where F_n,ON is not above zero or either is missing; a float for two
        scalars.
    """
    fn = np.asarray(normal_on_N, dtype=float)
    force = np.asarray(force_N, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(fn > 0, 100.0 / np.where(fn > 0, fn, 1.0), np.nan)
    out = scale * force
    return float(out) if out.ndim == 0 else out
