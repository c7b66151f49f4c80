"""The model's parameters: one frozen object, Table 1 of the seed paper by default.

Every field is in SI units and carries its unit and a description in the dataclass field
metadata, so the command line (``evtribo model --list``, ``--set NAME=VALUE``) and the fitting
code read names, units and defaults from one place.

>>> from evtribo.model import TABLE_1
>>> TABLE_1.with_values(h_L=3e-6).h_L
3e-06
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evtribo.errors import ConfigError
from evtribo.model.friction_law import LoadLaw

__all__ = ["MIN_GAP", "PARAMETER_BOUNDS", "TABLE_1", "ModelParameters", "ParameterInfo",
           "bounds_text"]


def _p(default: float, unit: str, description: str, rule: str,
       bounds: tuple[float, float]) -> Any:
    return field(default=default, metadata={"unit": unit, "description": description,
                                            "rule": rule, "bounds": bounds})


#: The narrowest air-equivalent gap the model takes, m: an atom's size (a thinner gap is no
#: capacitor's, and its stress would overflow).
MIN_GAP = 1e-10


# rule: "positive" (> 0), "nonnegative" (>= 0) or "resistance" (> 0, and inf for none)
@dataclass(frozen=True, slots=True)
class ModelParameters:
    """Material and geometrical parameters of the fingertip-screen contact (SI units).

    Defaults are Table 1 of the seed paper. Instances are immutable and validated on
    creation: a bad value raises :class:`evtribo.errors.ConfigError` (a ``ValueError``)
    whose ``key`` is the parameter's name.

    Attributes
    ----------
    mu : float
        Coulomb friction coefficient, dimensionless (> 0).
    R : float
        Radius of the parabolic fingertip profile, m.
    E_star : float
        Effective elastic modulus E* (eq. 4, 10), Pa.
    eps_sc, eps_i, eps_L : float
        Relative permittivities of stratum corneum, insulating layer and air gap.
    h_sc, h_i, h_L : float
        Thicknesses of stratum corneum, insulating layer and equivalent air gap, m.
    eps_0 : float
        Permittivity of free space, F/m (the paper's rounded 8.854e-12).
    r_sc, r_g : float
        Area-specific resistances of the stratum corneum and of the air gap (its leakage),
        Ohm m^2; infinite by default, the paper's perfect insulators (see
        :mod:`evtribo.model.circuit`: with finite values the force depends on the drive's
        frequency).
    m : float
        Exponent of the friction law ``F_t = mu W0 (W / W0)**m`` of the load ``W = F_ext +
        F_el`` (:meth:`friction`): 1 is the paper's Coulomb friction, a finger pad's is
        about 0.67-0.9 (Adams et al. 2013).
    W0 : float
        The load at which ``mu`` is the friction coefficient, N (no effect when ``m = 1``).
    """

    mu: float = _p(0.5, "1", "Coulomb friction coefficient", "positive", (0.0, 100.0))
    R: float = _p(0.01, "m", "radius of the parabolic fingertip profile", "positive",
                  (1e-9, 10.0))
    E_star: float = _p(40e3, "Pa", "equivalent effective elastic modulus E*", "positive",
                       (1.0, 1e12))
    eps_sc: float = _p(1650.0, "1", "relative permittivity of the stratum corneum", "positive",
                       (1.0, 1e6))
    eps_i: float = _p(3.35, "1", "relative permittivity of the screen's insulating layer",
                      "positive", (1.0, 1e6))
    eps_L: float = _p(1.0, "1", "relative permittivity of the equivalent air gap", "positive",
                      (1.0, 1e6))
    h_sc: float = _p(300e-6, "m", "thickness of the stratum corneum", "nonnegative",
                     (0.0, 0.1))
    h_i: float = _p(1e-6, "m", "thickness of the screen's insulating layer", "nonnegative",
                    (0.0, 0.1))
    h_L: float = _p(5e-6, "m", "thickness of the equivalent air gap", "nonnegative",
                    (0.0, 0.1))
    eps_0: float = _p(8.854e-12, "F/m", "permittivity of free space", "positive",
                      (8.854e-13, 8.854e-11))
    r_sc: float = _p(float("inf"), "Ohm m^2",
                     "area-specific resistance of the stratum corneum (inf: insulator)",
                     "resistance", (0.0, math.inf))
    r_g: float = _p(float("inf"), "Ohm m^2",
                    "area-specific leakage resistance of the air gap (inf: none)",
                    "resistance", (0.0, math.inf))
    m: float = _p(1.0, "1", "exponent of the friction law F_t = mu W0 (W/W0)^m of the load "
                  "W = F_ext + F_el (1: Coulomb)", "positive", (0.0, 2.0))
    W0: float = _p(0.5, "N", "load at which mu is the friction coefficient (m != 1)",
                   "positive", (1e-6, 1e6))

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            object.__setattr__(self, f.name, _checked(f, getattr(self, f.name)))
        self._check_gap()

    def _check_gap(self) -> None:
        if self.effective_gap <= 0:
            raise ConfigError("h_sc, h_i and h_L are all zero: the capacitor has no gap",
                              key="h_L")
        if self.effective_gap < MIN_GAP:
            raise ConfigError(f"the air-equivalent gap h_sc/eps_sc + h_L/eps_L + h_i/eps_i "
                              f"is {self.effective_gap:.3g} m, below an atom's size "
                              f"({MIN_GAP:g} m): no capacitor is that thin", key="h_L")

    # ------------------------------------------------------------------ derived values
    def friction(self, load: ArrayLike) -> NDArray[np.float64]:
        """The friction of a contact loaded by *load*, N: ``mu W0 (W / W0)**m`` (``mu W``
        when ``m = 1``, the paper's eq. 1; :class:`~evtribo.model.friction_law.LoadLaw`, no
        load below zero).

        Parameters
        ----------
        load : float or ndarray
            The contact's load ``W = F_ext + F_el``, N.

        Returns
        -------
        ndarray
            The friction force, N.
        """
        return self.load_law.friction(self.mu, load, floor=0.0)

    @property
    def load_law(self) -> LoadLaw:
        """The friction law of these parameters: ``m`` and ``W0``
        (:class:`~evtribo.model.friction_law.LoadLaw`)."""
        return LoadLaw(self.m, self.W0)

    def with_load_law(self, law: LoadLaw) -> ModelParameters:
        """A copy with the friction law *law* (its ``m`` and ``W0``).

        Parameters
        ----------
        law : LoadLaw

        Returns
        -------
        ModelParameters
        """
        return self.with_values(m=law.exponent, W0=law.load_ref_N)

    @property
    def effective_gap(self) -> float:
        """Air-equivalent dielectric thickness h_sc/eps_sc + h_L/eps_L + h_i/eps_i, m."""
        return self.h_sc / self.eps_sc + self.h_L / self.eps_L + self.h_i / self.eps_i

    # ------------------------------------------------------------------ names and edits
    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The parameter names, in Table 1 order."""
        return tuple(f.name for f in dataclasses.fields(cls))

    @classmethod
    def info(cls) -> tuple[ParameterInfo, ...]:
        """Name, unit, Table 1 default and description of every parameter."""
        defaults = cls()
        return tuple(ParameterInfo(f.name, f.metadata["unit"], float(getattr(defaults, f.name)),
                                   f.metadata["description"], bounds_text(f.name))
                     for f in dataclasses.fields(cls))

    def as_dict(self) -> dict[str, float]:
        """The parameters as a plain ``{name: value}`` dictionary (SI units)."""
        return {name: getattr(self, name) for name in self.names()}

    def with_values(self, values: Mapping[str, Any] | None = None, /,
                    **kwargs: Any) -> ModelParameters:
        """A copy with some parameters changed; unknown names raise ConfigError.

        Parameters
        ----------
        values : mapping, optional
            ``{name: value}`` in SI units.
        **kwargs
            More ``name=value`` pairs.
        """
        changes = {**(values or {}), **kwargs}
        fields = _FIELDS
        for name in changes:
            if name not in fields:
                raise ConfigError(
                    f"unknown model parameter; known: {', '.join(self.names())}", key=name)
        # the fields not changed were checked when this one was made: only the changed
        # ones are (a fitter's refits ask for thousands of copies)
        out = object.__new__(type(self))
        for name in fields:  # in the order made afresh (the first error the same)
            object.__setattr__(out, name, _checked(fields[name], changes[name])
                               if name in changes else getattr(self, name))
        out._check_gap()
        return out

    replace = with_values

    def with_assignments(self, assignments: Iterable[str]) -> ModelParameters:
        """A copy with ``"NAME=VALUE"`` strings applied (the command line's ``--set``).

        Raises
        ------
        ConfigError
            For a string without ``=``, an unknown name, a value that is not a number or
            an invalid value; ``key`` names the parameter.
        """
        changes: dict[str, float] = {}
        for text in assignments:
            name, sep, raw = text.partition("=")
            name = name.strip()
            if not sep or not name:
                raise ConfigError(f"expected NAME=VALUE, got {text!r}", key=name or text)
            if name not in self.names():
                raise ConfigError(
                    f"unknown model parameter; known: {', '.join(self.names())}", key=name)
            try:
                changes[name] = float(raw)
            except ValueError as err:
                raise ConfigError(f"expected a number, got {raw.strip()!r}", key=name) from err
        return self.with_values(changes)


class ParameterInfo(NamedTuple):
    """One row of ``evtribo model --list``: its name, unit, default, description and the
    values it may take (:func:`bounds_text`)."""

    name: str
    unit: str
    default: float
    description: str
    allowed: str = ""


def _checked(f: dataclasses.Field[Any], value: Any) -> float:
    """*value* as parameter *f*'s float, or ConfigError naming it: a real number (int, float,
    numpy scalars or 0-d arrays, not bool or str), finite (a resistance may be infinite),
    positive or not negative as its rule says."""
    if isinstance(value, (bool, np.bool_, str, bytes, complex)) or np.ndim(value) != 0:
        raise ConfigError(f"expected a number, got {value!r}", key=f.name)
    try:
        number = float(value)
    except (TypeError, ValueError) as err:
        raise ConfigError(f"expected a number, got {value!r}", key=f.name) from err
    rule = f.metadata["rule"]
    if not math.isfinite(number) and not (rule == "resistance" and number == math.inf):
        raise ConfigError(f"must be finite, got {number!r}", key=f.name)
    if rule in ("positive", "resistance") and number <= 0:
        raise ConfigError(f"must be > 0 ({f.metadata['unit']}), got {number!r}", key=f.name)
    if rule == "nonnegative" and number < 0:
        raise ConfigError(f"must be >= 0 ({f.metadata['unit']}), got {number!r}", key=f.name)
    low, high = f.metadata["bounds"]
    if (low > 0 and number < low) or number > high:
        raise ConfigError(f"must be {bounds_text(f.name)}, got {number!r}", key=f.name)
    return number


def bounds_text(name: str) -> str:
    """What parameter *name* may be, in words: ``from 1e-09 to 10 m`` (the bounds no
    fingertip, screen or rig reaches; beyond them the model's numbers would overflow).

    Parameters
    ----------
    name : str
        A parameter of :class:`ModelParameters`.

    Returns
    -------
    str
    """
    f = _FIELDS[name]
    unit = "" if f.metadata["unit"] == "1" else f" {f.metadata['unit']}"
    low, high = f.metadata["bounds"]
    if f.metadata["rule"] == "resistance":
        return f"> 0{unit}, or inf"
    first = f"from {low:g}" if low > 0 else "> 0" if f.metadata["rule"] == "positive" \
        else "from 0"
    return f"{first} to {high:g}{unit}" if low > 0 or first == "from 0" else \
        f"{first} and at most {high:g}{unit}"


#: The parameters' fields by name.
_FIELDS: dict[str, dataclasses.Field[Any]] = {f.name: f for f in
                                              dataclasses.fields(ModelParameters)}
#: Each parameter's bounds ``(low, high)`` in SI units: the values the model takes lie
#: within them (0 low: > 0 or >= 0 as the parameter's rule says; see :func:`bounds_text`).
PARAMETER_BOUNDS: dict[str, tuple[float, float]] = {
    name: f.metadata["bounds"] for name, f in _FIELDS.items()}


TABLE_1 = ModelParameters()
"""Table 1 of the seed paper (mu = 0.5, R = 1 cm, E* = 40 kPa, h_L = 5 um, ...)."""
