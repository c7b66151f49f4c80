"""``friction_law = "power"``: the fitted exponent however uncertain, ``F_t = c W^m``.

The forces use the ``m`` the subject's OFF windows give (Amontons' ``m = 1`` only where they
give none, or one at or below zero), its uncertainty in their intervals: each bootstrap
replicate draws its own ``m``, and the exponent is an error source of its own in their
small-sample calibration.
"""

from __future__ import annotations

import numpy as np

from evtribo.analysis.friction.laws.amontons import amontons
from evtribo.analysis.friction.laws.choice import ChosenLaw
from evtribo.analysis.friction.laws.fit import FittedLaw
from evtribo.model.friction_law import LoadLaw

__all__ = ["Power", "power"]


def power(fitted: FittedLaw) -> ChosenLaw:
    """The power law at the fitted exponent.

    Parameters
    ----------
    fitted : FittedLaw
        What a subject's windows say of the law; its ``m`` is positive.

    Returns
    -------
    ChosenLaw
    """
    return ChosenLaw(fitted, LoadLaw(fitted.estimate, fitted.load_ref_N), "power",
                     draw_exponent=bool(np.isfinite(fitted.estimate_se)),
                     exponent_source=True)


class Power:
    """The fitted ``m`` for every subject whose windows give one."""

    name = "power"

    def choose(self, fitted: FittedLaw) -> ChosenLaw:
        """The power law where the windows give a positive ``m``, else Amontons'.

        Parameters
        ----------
        fitted : FittedLaw

        Returns
        -------
        ChosenLaw
        """
        if np.isfinite(fitted.estimate) and fitted.estimate > 0:
            return power(fitted)
        return amontons(fitted)
