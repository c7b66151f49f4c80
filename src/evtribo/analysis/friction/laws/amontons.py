"""``friction_law = "amontons"``: the friction proportional to the load, ``m = 1``.

The forces are ``F_t,on / mu - F_n,on``, the study format's. Where the presses tell ``m``
and its 95 % interval holds 1, ``m``'s uncertainty is in their intervals: a pad of
``m = 0.9`` may be taken for one of ``m = 1``, its forces then about a tenth low, inside the
interval.
"""

from __future__ import annotations

from evtribo.analysis.friction.laws.choice import ChosenLaw
from evtribo.analysis.friction.laws.fit import FittedLaw
from evtribo.model.friction_law import LoadLaw

__all__ = ["Amontons", "amontons"]


def amontons(fitted: FittedLaw, *, sensitivity: float | None = None) -> ChosenLaw:
    """Amontons' law for a subject's forces.

    Parameters
    ----------
    fitted : FittedLaw
        What its windows say of the law.
    sensitivity : float, optional
        The exponent of a sensitivity beside the forces.

    Returns
    -------
    ChosenLaw
        ``m = 1``; ``m``'s uncertainty drawn where its interval holds 1.
    """
    return ChosenLaw(fitted, LoadLaw(1.0, fitted.load_ref_N), "amontons",
                     draw_exponent=fitted.holds_amontons, sensitivity=sensitivity)


class Amontons:
    """``m = 1`` for every subject."""

    name = "amontons"

    def choose(self, fitted: FittedLaw) -> ChosenLaw:
        """Amontons' law (:func:`amontons`).

        Parameters
        ----------
        fitted : FittedLaw

        Returns
        -------
        ChosenLaw
        """
        return amontons(fitted)
