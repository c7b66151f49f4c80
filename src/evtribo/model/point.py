"""Every quantity of the model at one operating point (``evtribo model``'s table)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from evtribo.model.circuit import effective_voltage, electrostatic_force_drive, gap_factor
from evtribo.model.contact import (
    area_increase_pct,
    contact_area_hertz,
    contact_area_jkr,
    contact_radius_hertz,
    contact_radius_jkr,
)
from evtribo.model.electrostatics import adhesion_stress, surface_energy
from evtribo.model.friction import (
    adhesion_load_ratio,
    electrostatic_force,
    electrostatic_force_exponent,
    friction_force,
)
from evtribo.model.maugis import friction_force_md, maugis_dugdale
from evtribo.model.params import TABLE_1, ModelParameters

__all__ = ["POINT_KEYS", "evaluate_point"]

#: The keys of :func:`evaluate_point`'s result, in its order.
POINT_KEYS: tuple[str, ...] = (
    "normal_force_N", "voltage_V", "gap_factor", "effective_voltage_V", "adhesion_stress_Pa",
    "surface_energy_J_m2", "contact_area_hertz_m2", "contact_area_m2", "area_increase_pct",
    "contact_radius_hertz_m", "contact_radius_m", "electrostatic_force_N", "friction_force_N",
    "friction_force_off_N", "adhesion_load_ratio", "electrostatic_force_exponent",
    "maugis_parameter", "md_contact_radius_m", "md_cohesive_radius_m", "md_contact_area_m2",
    "md_electrostatic_force_N", "md_friction_force_N")


def _finite(x: Any) -> float | None:
    value = float(x)
    return value if math.isfinite(value) else None


def evaluate_point(normal_force: float, voltage: float,
                   params: ModelParameters = TABLE_1, *, frequency: float | None = None,
                   waveform: str = "square") -> dict[str, float | None]:
    """Every quantity of the model at one point (non-finite values become ``None``).

    Parameters
    ----------
    normal_force : float, N
        The external normal force F_ext.
    voltage : float, V
        The drive's amplitude U.
    params : ModelParameters
        Table 1 by default.
    frequency : float, Hz, optional
        The drive's frequency: the voltage-dependent quantities are then those at the
        effective amplitude the gap sees (:func:`evtribo.model.effective_voltage`); without
        it, the paper's high-frequency limit.
    waveform : {"square", "sine"}
        The drive's waveform with *frequency*; for a sine the electrostatic and friction
        forces are their means over a period.

    Returns
    -------
    dict
        :data:`POINT_KEYS` to their values (SI units, as the keys name them).
    """
    f = normal_force
    if frequency is None:
        gain, u = 1.0, voltage
    else:
        u = float(effective_voltage(voltage, frequency, waveform, params))
        gain = float(abs(gap_factor(frequency, params)))
    md = maugis_dugdale(f, u, params)
    values = {
        "normal_force_N": f,
        "voltage_V": voltage,
        "gap_factor": gain,
        "effective_voltage_V": u,
        "adhesion_stress_Pa": adhesion_stress(u, params),
        "surface_energy_J_m2": surface_energy(u, params),
        "contact_area_hertz_m2": contact_area_hertz(f, params),
        "contact_area_m2": contact_area_jkr(f, u, params),
        "area_increase_pct": area_increase_pct(f, u, params),
        "contact_radius_hertz_m": contact_radius_hertz(f, params),
        "contact_radius_m": contact_radius_jkr(f, u, params),
        "electrostatic_force_N": electrostatic_force(f, u, params),
        "friction_force_N": friction_force(f, u, params),
        "friction_force_off_N": friction_force(f, 0.0, params),
        "adhesion_load_ratio": adhesion_load_ratio(f, u, params),
        "electrostatic_force_exponent": electrostatic_force_exponent(f, u, params),
        "maugis_parameter": md.lam,
        "md_contact_radius_m": md.a,
        "md_cohesive_radius_m": md.c,
        "md_contact_area_m2": np.pi * np.asarray(md.a) ** 2,
        "md_electrostatic_force_N": adhesion_stress(u, params) * np.pi
        * np.asarray(md.c) ** 2,
        "md_friction_force_N": friction_force_md(f, u, params),
    }
    if frequency is not None and waveform == "sine":
        fel = float(electrostatic_force_drive(f, voltage, frequency, "sine", params))
        values["electrostatic_force_N"] = fel
        values["friction_force_N"] = float(params.friction(f + fel))
    return {key: _finite(value) for key, value in values.items()}
