"""The friction laws a subject's forces may be inferred with, by the name ``[analysis]
friction_law`` gives them.

Each subject's law is fitted from all its windows (:mod:`~evtribo.analysis.friction.laws.fit`:
``m`` of ``F_t = c W^m`` and the stroke pace's term), then a choice
(:class:`~evtribo.analysis.friction.laws.choice.FrictionLawChoice`) makes it the law its
forces use (:class:`~evtribo.analysis.friction.laws.choice.ChosenLaw`). The builtin choices,
in the order the documentation lists them: ``auto`` (:mod:`~evtribo.analysis.friction.laws.
auto`), ``amontons`` (:mod:`~evtribo.analysis.friction.laws.amontons`) and ``power``
(:mod:`~evtribo.analysis.friction.laws.power`). A lab adds its own in one module, registered
with :func:`register` or through the entry point group ``evtribo.friction_laws`` (the object
it names is a choice, or a class of one made without arguments): its ``name`` is then a
value of ``friction_law``. No law is told by its name anywhere but here.
"""

from __future__ import annotations

from evtribo.analysis.friction.laws.amontons import Amontons
from evtribo.analysis.friction.laws.auto import Auto
from evtribo.analysis.friction.laws.choice import ChosenLaw, FrictionLawChoice, at_exponent
from evtribo.analysis.friction.laws.fit import (
    RATE_SE,
    SENSITIVITY_EXPONENT,
    TOLD_WIDTH,
    FittedLaw,
    fit_subject_law,
    untold_note,
)
from evtribo.analysis.friction.laws.power import Power
from evtribo.util.plugins import Registry

__all__ = ["ENTRY_POINTS", "LAWS", "RATE_SE", "SENSITIVITY_EXPONENT", "TOLD_WIDTH",
           "ChosenLaw", "FittedLaw", "FrictionLawChoice", "at_exponent", "fit_subject_law",
           "law_choice", "register", "untold_note"]

#: The entry point group of plug-ins' friction laws.
ENTRY_POINTS = "evtribo.friction_laws"


def _choice(obj: object) -> FrictionLawChoice | None:
    """A choice of friction law, from a plug-in's object (a class is made into one)."""
    if isinstance(obj, type):
        try:
            obj = obj()
        except TypeError:
            return None
    if isinstance(obj, FrictionLawChoice) and isinstance(getattr(obj, "name", None), str):
        return obj
    return None


#: Every choice of ``[analysis] friction_law`` by name: the builtins (auto, amontons, power),
#: then the plug-ins'.
LAWS: Registry[FrictionLawChoice] = Registry(ENTRY_POINTS, "friction law", check=_choice,
                                             key=lambda entry, choice: choice.name)
for _builtin in (Auto(), Amontons(), Power()):
    LAWS.register(_builtin.name, _builtin)


def register(choice: FrictionLawChoice) -> None:
    """Add a choice of friction law under its ``name``.

    Parameters
    ----------
    choice : FrictionLawChoice

    Raises
    ------
    ValueError
        A name registered already, or an object that is no choice.
    """
    LAWS.register(str(getattr(choice, "name", "")), choice)


def law_choice(name: str) -> FrictionLawChoice:
    """The choice of friction law of a name.

    Parameters
    ----------
    name : str
        ``[analysis] friction_law``.

    Returns
    -------
    FrictionLawChoice

    Raises
    ------
    ValueError
        No law of that name (the message lists those there are).
    """
    try:
        return LAWS[name]
    except KeyError:
        raise ValueError(f"friction_law must be one of {', '.join(LAWS)}, got {name!r}"
                         ) from None
