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

functions = (
    adhesion_stress,
    surface_energy,
    contact_radius_hertz,
    contact_area_hertz,
    contact_radius_jkr,
    contact_area_jkr,
    area_increase_pct,
    electrostatic_force,
    friction_force,
    adhesion_load_ratio,
    electrostatic_force_exponent,
    electrostatic_force_adhesive_limit,
    electrostatic_force_load_limit,
    maugis_parameter,
    contact_area_md,
    electrostatic_force_md,
    friction_force_md,
)

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
