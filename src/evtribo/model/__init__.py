"""The seed paper's voltage-induced friction model as pure, vectorised functions (SI units).

Modules, lowest first: :mod:`~evtribo.model.params` (Table 1 in one frozen object),
:mod:`~evtribo.model.electrostatics` (capacitor, eqs. 4, 6-10),
:mod:`~evtribo.model.contact` (Hertz, JKR eq. 3, DMT), :mod:`~evtribo.model.maugis`
(the full Maugis-Dugdale contact), :mod:`~evtribo.model.friction` (eqs. 1, 2, 5, 11-13 and
waveforms), :mod:`~evtribo.model.circuit` (the drive's frequency: the layers as a circuit,
an extension of the paper's model). :mod:`~evtribo.model.point` gives every quantity at one
operating point. The model's figures (Figures 5-7 and F_el against frequency) are drawn by
:mod:`evtribo.figures.model_figures`: this package computes, it neither plots nor writes.

Every function broadcasts over numpy arrays; ``voltage`` is the instantaneous or amplitude
value in V (only U^2 matters), ``normal_force`` the external normal force in N, and
``params`` a :class:`ModelParameters` (Table 1 by default).

``functions`` lists the public functions of ``(normal_force, voltage, params)`` (or a subset
of those arguments) whose results are non-negative; the tests sweep all of them and fitting
code reads their signatures.
"""

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from evtribo.model.circuit import (
        effective_voltage,
        electrostatic_force_drive,
        gap_factor,
        layer_elastances,
    )
    from evtribo.model.contact import (
        area_increase_pct,
        contact_area_hertz,
        contact_area_jkr,
        contact_radius_hertz,
        contact_radius_jkr,
        dmt_pulloff_force,
        dmt_radius,
        hertz_radius,
        jkr_pulloff_force,
        jkr_radius,
    )
    from evtribo.model.electrostatics import (
        adhesion_stress,
        attraction_force,
        capacitance,
        dugdale_range,
        effective_modulus,
        effective_modulus_soft,
        surface_energy,
    )
    from evtribo.model.friction import (
        adhesion_load_ratio,
        electrostatic_force,
        electrostatic_force_adhesive_limit,
        electrostatic_force_exponent,
        electrostatic_force_load_limit,
        friction_force,
        friction_force_dugdale,
        friction_time_series,
        sine_voltage,
        square_voltage,
    )
    from evtribo.model.maugis import (
        MaugisDugdale,
        contact_area_md,
        electrostatic_force_md,
        friction_force_md,
        maugis_dugdale,
        maugis_parameter,
        md_dimensionless,
        md_jkr_departure,
        md_pulloff_load,
    )
    from evtribo.model.params import TABLE_1, ModelParameters, ParameterInfo

#: Where each name of this package lives: imported on first use, so that importing one
#: module of the package (the friction law the analysis evaluates,
#: :mod:`evtribo.model.friction_law`) does not import the others (Maugis-Dugdale's scipy.optimize).
_HOMES = {
    "effective_voltage": "circuit",
    "electrostatic_force_drive": "circuit",
    "gap_factor": "circuit",
    "layer_elastances": "circuit",
    "area_increase_pct": "contact",
    "contact_area_hertz": "contact",
    "contact_area_jkr": "contact",
    "contact_radius_hertz": "contact",
    "contact_radius_jkr": "contact",
    "dmt_pulloff_force": "contact",
    "dmt_radius": "contact",
    "hertz_radius": "contact",
    "jkr_pulloff_force": "contact",
    "jkr_radius": "contact",
    "adhesion_stress": "electrostatics",
    "attraction_force": "electrostatics",
    "capacitance": "electrostatics",
    "dugdale_range": "electrostatics",
    "effective_modulus": "electrostatics",
    "effective_modulus_soft": "electrostatics",
    "surface_energy": "electrostatics",
    "adhesion_load_ratio": "friction",
    "electrostatic_force": "friction",
    "electrostatic_force_adhesive_limit": "friction",
    "electrostatic_force_exponent": "friction",
    "electrostatic_force_load_limit": "friction",
    "friction_force": "friction",
    "friction_force_dugdale": "friction",
    "friction_time_series": "friction",
    "sine_voltage": "friction",
    "square_voltage": "friction",
    "MaugisDugdale": "maugis",
    "contact_area_md": "maugis",
    "electrostatic_force_md": "maugis",
    "friction_force_md": "maugis",
    "maugis_dugdale": "maugis",
    "maugis_parameter": "maugis",
    "md_dimensionless": "maugis",
    "md_jkr_departure": "maugis",
    "md_pulloff_load": "maugis",
    "TABLE_1": "params",
    "ModelParameters": "params",
    "ParameterInfo": "params",
}

#: The names of :data:`functions`, in their order.
_FUNCTIONS = (
    "adhesion_stress", "surface_energy", "contact_radius_hertz", "contact_area_hertz",
    "contact_radius_jkr", "contact_area_jkr", "area_increase_pct", "electrostatic_force",
    "friction_force", "adhesion_load_ratio", "electrostatic_force_exponent",
    "electrostatic_force_adhesive_limit", "electrostatic_force_load_limit",
    "maugis_parameter", "contact_area_md", "electrostatic_force_md", "friction_force_md",
)


def __getattr__(name: str) -> Any:
    if name == "functions":
        value: Any = tuple(__getattr__(n) for n in _FUNCTIONS)
    elif name in _HOMES:
        value = getattr(importlib.import_module(f"{__name__}.{_HOMES[name]}"), name)
    else:
        try:
            value = importlib.import_module(f"{__name__}.{name}")  # a module of the package
        except ModuleNotFoundError:
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_HOMES, "functions"])


__all__ = [
    "TABLE_1",
    "MaugisDugdale",
    "ModelParameters",
    "ParameterInfo",
    "adhesion_load_ratio",
    "adhesion_stress",
    "area_increase_pct",
    "attraction_force",
    "capacitance",
    "contact_area_hertz",
    "contact_area_jkr",
    "contact_area_md",
    "contact_radius_hertz",
    "contact_radius_jkr",
    "dmt_pulloff_force",
    "dmt_radius",
    "dugdale_range",
    "effective_modulus",
    "effective_modulus_soft",
    "effective_voltage",
    "electrostatic_force",
    "electrostatic_force_adhesive_limit",
    "electrostatic_force_drive",
    "electrostatic_force_exponent",
    "electrostatic_force_load_limit",
    "electrostatic_force_md",
    "friction_force",
    "friction_force_dugdale",
    "friction_force_md",
    "friction_time_series",
    "functions",
    "gap_factor",
    "hertz_radius",
    "jkr_pulloff_force",
    "jkr_radius",
    "layer_elastances",
    "maugis_dugdale",
    "maugis_parameter",
    "md_dimensionless",
    "md_jkr_departure",
    "md_pulloff_load",
    "sine_voltage",
    "square_voltage",
    "surface_energy",
]
