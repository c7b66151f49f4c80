"""Numbers no rig has: every model parameter and point option a user gives is either within
the bounds no fingertip, screen or rig reaches, and the model's numbers are finite there, or
refused with exit 2 naming the key; never an overflow."""

from __future__ import annotations

import json
import math

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from evtribo.cli import main
from evtribo.model import TABLE_1, ModelParameters
from evtribo.model.params import PARAMETER_BOUNDS

#: The quantities every accepted point must give as numbers (the Maugis-Dugdale ones are
#: n/a where that solution does not exist).
CORE = ("adhesion_stress_Pa", "surface_energy_J_m2", "contact_area_hertz_m2",
        "contact_area_m2", "area_increase_pct", "contact_radius_m", "electrostatic_force_N",
        "friction_force_N", "friction_force_off_N", "electrostatic_force_exponent")

_finite = st.floats(allow_nan=False, allow_infinity=False)
#: Any finite number, with the bounds' own values and their neighbours drawn often.
_edges = sorted({v for lo, hi in PARAMETER_BOUNDS.values() for v in (lo, hi)
                 if math.isfinite(v)})
_value = st.one_of(_finite, st.sampled_from(_edges),
                   st.sampled_from(_edges).map(lambda v: math.nextafter(v, math.inf)),
                   st.sampled_from(_edges).map(lambda v: math.nextafter(v, -math.inf)))


def _run(argv: list[str], capsys) -> tuple[int, str, str]:
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


@settings(max_examples=300, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(changes=st.dictionaries(st.sampled_from(ModelParameters.names()), _value,
                               min_size=1, max_size=3),
       force=st.one_of(st.none(), _finite), voltage=st.one_of(st.none(), _finite))
def test_any_number_is_refused_naming_its_key_or_gives_finite_numbers(changes, force,
                                                                      voltage, capsys):
    argv = ["model", "--json", *(f"--set={k}={v!r}" for k, v in changes.items())]
    argv += [] if force is None else [f"--normal-force={force!r}"]
    argv += [] if voltage is None else [f"--voltage={voltage!r}"]
    code, out, err = _run(argv, capsys)
    if code == 2:
        named = [*changes, "h_L", "--normal-force", "--voltage"]
        assert any(f"key '{k}'" in err for k in named), err
        assert "Traceback" not in err and "failed" not in err
        return
    assert code == 0, err
    assert err == ""  # no warning of an overflow either
    result = json.loads(out)
    for key in CORE:
        if key == "area_increase_pct" and result["normal_force_N"] == 0:
            continue  # no Hertz area without a load: no increase over it (n/a)
        assert isinstance(result[key], float) and math.isfinite(result[key]), (key, result)


def test_the_seed_paper_s_values_lie_within_the_bounds():
    for name, (low, high) in PARAMETER_BOUNDS.items():
        assert low <= getattr(TABLE_1, name) <= high, name


def test_a_radius_of_1e300_is_refused_naming_it(capsys):
    code, _, err = _run(["model", "--set", "R=1e300"], capsys)
    assert code == 2
    assert "evtribo model: error: key 'R': must be from 1e-09 to 10 m, got 1e+300" in err
