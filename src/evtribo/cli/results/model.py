"""``evtribo model``: the seed paper's model at one normal force and voltage, and its figures.

::

    evtribo model --normal-force 0.5 --voltage 140 --set h_L=3e-6 --json
    evtribo model --voltage 100 --frequency 50 --waveform square --set r_g=80 --json
    evtribo model --list
    evtribo model --figures out/figures [--force]
"""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

from evtribo import model
from evtribo.errors import ConfigError
from evtribo.model import ModelParameters
from evtribo.model.point import evaluate_point

# (JSON key, unit shown in the table, description)
_ROWS: tuple[tuple[str, str, str], ...] = (
    ("normal_force_N", "N", "external normal force F_ext"),
    ("voltage_V", "V", "applied voltage U (amplitude)"),
    ("gap_factor", "1", "gap's share |H| of the voltage at f (1: the paper)"),
    ("effective_voltage_V", "V", "effective amplitude U_eff the gap sees"),
    ("adhesion_stress_Pa", "Pa", "adhesion stress sigma_0 (eq. 8)"),
    ("surface_energy_J_m2", "J/m^2", "relative surface energy Delta-gamma (eq. 9)"),
    ("contact_area_hertz_m2", "m^2", "contact area, Hertz (voltage off)"),
    ("contact_area_m2", "m^2", "contact area, JKR (eq. 3)"),
    ("area_increase_pct", "%", "contact area increase, JKR over Hertz"),
    ("contact_radius_hertz_m", "m", "contact radius, Hertz"),
    ("contact_radius_m", "m", "contact radius, JKR"),
    ("electrostatic_force_N", "N", "electrostatic force F_el (eq. 11)"),
    ("friction_force_N", "N", "friction force, ON (eq. 5)"),
    ("friction_force_off_N", "N", "friction force, OFF (mu F_ext)"),
    ("adhesion_load_ratio", "1", "3 pi R Delta-gamma / (2 F_ext) (eqs. 12, 13)"),
    ("electrostatic_force_exponent", "1", "local exponent d ln F_el / d ln U"),
    ("maugis_parameter", "1", "Maugis parameter lambda"),
    ("md_contact_radius_m", "m", "contact radius a, Maugis-Dugdale"),
    ("md_cohesive_radius_m", "m", "cohesive-zone radius b = c, Maugis-Dugdale"),
    ("md_contact_area_m2", "m^2", "contact area pi a^2, Maugis-Dugdale"),
    ("md_electrostatic_force_N", "N", "sigma_0 pi b^2, Maugis-Dugdale"),
    ("md_friction_force_N", "N", "friction force, eq. (1) with Maugis-Dugdale b"),
)


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``evtribo model``."""
    parser = subparsers.add_parser(
        "model",
        help="the seed paper's friction model at one point; its figures",
        description="Evaluate the voltage-induced friction model of "
                    '"Voltage-Induced Friction with Application to Electrovibration", '
                    "Lubricants 2019, 7(12), 102, doi:10.3390/lubricants7120102 (Table 1 "
                    "parameters unless --set) at one external normal force and voltage "
                    "amplitude, or write Figures 5-7 of the paper and the Maugis-Dugdale "
                    "comparison.",
    )
    parser.add_argument("--normal-force", type=float, default=0.5, metavar="N",
                        help="external normal force F_ext in N (default 0.5)")
    parser.add_argument("--voltage", type=float, default=140.0, metavar="V",
                        help="voltage amplitude U in V (default 140)")
    parser.add_argument("--frequency", type=float, metavar="HZ",
                        help="frequency of the drive, Hz: the model is evaluated at the "
                             "amplitude the gap sees (the paper's model, with r_sc and r_g "
                             "finite, depends on it; without: the paper's high-frequency "
                             "limit)")
    parser.add_argument("--waveform", choices=("sine", "square"), default="square",
                        help="waveform of the drive with --frequency (default square; for a "
                             "sine, F_el and the friction are means over a period)")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                        dest="assignments",
                        help="set a model parameter, SI units (repeatable; --list gives "
                             "each one's unit and the values it may take: a value no "
                             "fingertip, screen or rig has is refused)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--list", action="store_true",
                        help="list the parameters: names, units, defaults, descriptions")
    parser.add_argument("--figures", metavar="DIR",
                        help="write Figures 5, 6, 7 and the Maugis-Dugdale figure as PNG "
                             "and SVG into DIR")
    parser.add_argument("--force", action="store_true",
                        help="overwrite existing figure files")
    parser.set_defaults(func=run)
    return parser


def _json_number(value: float) -> float | None:
    """A parameter for JSON: an infinite resistance (none) becomes null."""
    return value if math.isfinite(value) else None


#: The largest magnitude of each point option the model is evaluated at (far beyond a
#: fingertip's; beyond them its numbers overflow).
_HIGHEST = {"--normal-force": (1e6, "N"), "--voltage": (1e9, "V"),
            "--frequency": (1e15, "Hz")}


def _check_point(value: float, key: str, *, minimum: float | None = None) -> float:
    if not math.isfinite(value):
        raise ConfigError(f"must be finite, got {value!r}", key=key)
    if minimum is not None and value < minimum:
        raise ConfigError(f"must be >= {minimum:g}, got {value!r}", key=key)
    high, unit = _HIGHEST[key]
    if abs(value) > high:
        raise ConfigError(f"must be at most {high:g} {unit} in magnitude, got {value!r}",
                          key=key)
    return value


def _print_list(as_json: bool) -> None:
    info = ModelParameters.info()
    if as_json:
        print(json.dumps([{**row._asdict(), "default": _json_number(row.default)}
                          for row in info], indent=2))
        return
    print(f"{'name':<8} {'unit':<7} {'default':>10}  description (allowed)")
    for row in info:
        print(f"{row.name:<8} {row.unit:<7} {row.default:>10.4g}  {row.description} "
              f"({row.allowed})")


def _print_table(values: dict[str, float | None], params: ModelParameters) -> None:
    changed = {k: v for k, v in params.as_dict().items()
               if v != getattr(model.TABLE_1, k)}
    print("parameters: Table 1" + (" with " + ", ".join(f"{k}={v:g}" for k, v in
                                                      changed.items()) if changed else ""))
    for key, unit, description in _ROWS:
        if key in ("gap_factor", "effective_voltage_V") and "frequency_Hz" not in values:
            continue  # without a frequency: the paper's model, U as given
        value = values[key]
        shown = "n/a" if value is None else f"{value:.6g}"
        print(f"  {description:<48} {shown:>12} {unit}")


def run(args: argparse.Namespace) -> int:
    """Evaluate the model, list its parameters or write its figures; return 0."""
    params = model.TABLE_1.with_assignments(args.assignments)
    if args.list:
        _print_list(args.json)
        return 0
    normal_force = _check_point(args.normal_force, "--normal-force", minimum=0.0)
    voltage = _check_point(args.voltage, "--voltage")
    frequency = None
    if args.frequency is not None:
        frequency = _check_point(args.frequency, "--frequency")
        if frequency <= 0:
            raise ConfigError(f"must be > 0, got {frequency!r}", key="--frequency")
    result: dict[str, Any] = evaluate_point(normal_force, voltage, params,
                                            frequency=frequency, waveform=args.waveform)
    if frequency is not None:
        result.update(frequency_Hz=frequency, waveform=args.waveform)
    written: list[str] = []
    if args.figures is not None:
        from evtribo.figures.model_figures import save_model_figures

        written = [str(p) for p in save_model_figures(args.figures, force=args.force,
                                                      params=params)]
    if args.json:
        result["parameters"] = {k: _json_number(v) for k, v in params.as_dict().items()}
        if args.figures is not None:
            result["figures"] = written
        print(json.dumps(result, indent=2))
        return 0
    if frequency is not None:
        print(f"drive: {args.waveform} at {frequency:g} Hz")
    _print_table(result, params)
    for path in written:
        print(f"wrote {path}")
    return 0
