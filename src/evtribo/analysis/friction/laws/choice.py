"""What a choice of friction law is: :class:`FrictionLawChoice` takes a subject's fitted law
and gives the :class:`ChosenLaw` its forces are inferred with.

A choice is one value of ``[analysis] friction_law`` (:mod:`evtribo.analysis.friction.laws`
registers them by name). It sees what the subject's windows say of the law
(:class:`~evtribo.analysis.friction.laws.fit.FittedLaw`: ``m`` and its interval, whether
the presses tell it) and decides the law of the forces (:class:`~evtribo.model.friction_law.
LoadLaw`), whether ``m``'s uncertainty goes into their intervals, and whether a sensitivity
at another exponent is to be shown beside them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from evtribo.analysis.friction.laws.fit import FittedLaw
from evtribo.model.friction_law import LoadLaw

__all__ = ["ChosenLaw", "FrictionLawChoice", "at_exponent"]


@dataclass(frozen=True)
class ChosenLaw:
    """The friction law a subject's forces are inferred with.

    Attributes
    ----------
    fitted : FittedLaw
        What the subject's windows say of the law (``m``, its interval, the stroke
        rate's term, ``W_0``).
    law : LoadLaw
        The law of the forces: its ``m`` and ``W_0`` (the fitted one's).
    label : str
        electrostatic.csv's ``friction_law`` (``amontons``, ``power``).
    draw_exponent : bool
        Whether ``m``'s uncertainty (the fitted standard error) is in the forces'
        intervals: each bootstrap replicate draws its own ``m`` about :attr:`law`'s; and
        whether electrostatic.csv shows ``m``'s interval.
    exponent_source : bool
        Whether those draws are an error source of their own in the small-sample
        calibration of the intervals (where the forces use the fitted ``m``).
    sensitivity : float or None
        The exponent of a sensitivity to show beside the forces (electrostatic.csv's
        ``m075`` columns, with a warning saying why); None: none.
    """

    fitted: FittedLaw
    law: LoadLaw
    label: str
    draw_exponent: bool = False
    exponent_source: bool = False
    sensitivity: float | None = None

    @property
    def exponent(self) -> float:
        """``m`` of the forces."""
        return self.law.exponent

    @property
    def shown_interval(self) -> tuple[float, float]:
        """The interval of ``m`` electrostatic.csv shows: the fitted one where the forces
        carry ``m``'s uncertainty, else none (NaN)."""
        return self.fitted.interval if self.draw_exponent else (float("nan"), float("nan"))


@runtime_checkable
class FrictionLawChoice(Protocol):
    """One value of ``[analysis] friction_law``: how a subject's forces take its law.

    Attributes
    ----------
    name : str
        The setting's value (``auto``).
    """

    name: str

    def choose(self, fitted: FittedLaw) -> ChosenLaw:
        """The law of a subject's forces.

        Parameters
        ----------
        fitted : FittedLaw
            What its windows say of the law.

        Returns
        -------
        ChosenLaw
        """
        ...  # pragma: no cover - a protocol


def at_exponent(fitted: FittedLaw, exponent: float) -> ChosenLaw:
    """The law at a given exponent, its uncertainty left out: a sensitivity's.

    Parameters
    ----------
    fitted : FittedLaw
        The subject's fitted law (its stroke rate's term and ``W_0`` are kept).
    exponent : float
        ``m``.

    Returns
    -------
    ChosenLaw
        Labelled ``amontons`` at ``m = 1``, else ``power``.
    """
    return ChosenLaw(fitted, LoadLaw(float(exponent), fitted.load_ref_N),
                     "amontons" if exponent == 1 else "power")
