"""``friction_law = "auto"`` (the default): the fitted exponent where the presses tell it and
its interval excludes Amontons' 1, else ``m = 1``.

A friction that is Amontons' then gives the same forces as with ``m = 1`` (19 times in 20),
and the scatter of a fitted ``m`` about 1 (the pace of a person's strokes, which the stroke
rate follows only roughly, adds to it) does not move them; where the interval holds 1,
``m = 1`` is used with ``m``'s uncertainty in the intervals, and the interval is reported.
Where the presses do not tell ``m`` at all, the forces are Amontons' and a sensitivity at
``m = 0.75`` (:data:`~evtribo.analysis.friction.laws.fit.SENSITIVITY_EXPONENT`, the middle of
a finger pad's range) is shown beside them, with a warning saying so.
"""

from __future__ import annotations

from evtribo.analysis.friction.laws.amontons import amontons
from evtribo.analysis.friction.laws.choice import ChosenLaw
from evtribo.analysis.friction.laws.fit import SENSITIVITY_EXPONENT, FittedLaw
from evtribo.analysis.friction.laws.power import power

__all__ = ["Auto"]


class Auto:
    """The power law where the presses tell ``m`` apart from 1, else Amontons'."""

    name = "auto"

    def choose(self, fitted: FittedLaw) -> ChosenLaw:
        """The law of a subject's forces.

        Parameters
        ----------
        fitted : FittedLaw

        Returns
        -------
        ChosenLaw
            The power law where the presses tell a positive ``m`` whose interval excludes
            1; else Amontons', with the sensitivity at ``m = 0.75`` where the interval does
            not hold 1.
        """
        if fitted.told and fitted.estimate > 0 and not fitted.holds_amontons:
            return power(fitted)
        return amontons(fitted, sensitivity=None if fitted.holds_amontons
                        else SENSITIVITY_EXPONENT)
