"""``evtribo model``: JSON, --set, --list, --figures, exit codes."""

import json
import math

import numpy as np
import pytest

from evtribo import model
from evtribo.cli import main
from evtribo.errors import OutputExistsError

REQUIRED = ("contact_area_m2", "contact_area_hertz_m2", "area_increase_pct",
            "adhesion_stress_Pa", "surface_energy_J_m2", "electrostatic_force_N",
            "friction_force_N")


def _json(capsys, *argv):
    assert main(["model", *argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_json_matches_the_library(capsys):
    out = _json(capsys, "--normal-force", "0.5", "--voltage", "140")
    for key in REQUIRED:
        assert isinstance(out[key], float)
    assert out["contact_area_m2"] == pytest.approx(model.contact_area_jkr(0.5, 140))
    assert out["friction_force_N"] == pytest.approx(model.friction_force(0.5, 140))
    assert out["electrostatic_force_N"] == pytest.approx(model.electrostatic_force(0.5, 140))
    assert out["md_cohesive_radius_m"] > out["md_contact_radius_m"] > 0
    assert out["maugis_parameter"] == pytest.approx(model.maugis_parameter(140))
    # an infinite resistance (the paper's insulators) is null in JSON
    assert out["parameters"] == {k: None if math.isinf(v) else v
                                 for k, v in model.TABLE_1.as_dict().items()}


def test_set_changes_the_result(capsys):
    base = _json(capsys)
    out = _json(capsys, "--set", "h_L=2.5e-6", "--set", "mu=0.3")
    assert out["parameters"]["h_L"] == 2.5e-6 and out["parameters"]["mu"] == 0.3
    params = model.TABLE_1.with_values(h_L=2.5e-6, mu=0.3)
    assert out["friction_force_N"] == pytest.approx(model.friction_force(0.5, 140, params))
    assert out["adhesion_stress_Pa"] > base["adhesion_stress_Pa"]


def test_voltage_off_gives_hertz(capsys):
    out = _json(capsys, "--voltage", "0")
    assert out["contact_area_m2"] == pytest.approx(out["contact_area_hertz_m2"])
    assert out["area_increase_pct"] == 0.0 and out["electrostatic_force_N"] == 0.0


@pytest.mark.parametrize(("arg", "key"), [
    ("nope=1", "nope"), ("mu=abc", "mu"), ("h_L=-1e-6", "h_L"), ("E_star=0", "E_star"),
    ("mu", "mu"),
])
def test_bad_set_is_exit_2_naming_the_key(capsys, arg, key):
    assert main(["model", "--set", arg, "--json"]) == 2
    captured = capsys.readouterr()
    assert f"'{key}'" in captured.err and "Traceback" not in captured.err
    assert captured.out == ""


def test_bad_point_is_exit_2(capsys):
    assert main(["model", "--normal-force", "-0.1"]) == 2
    assert "--normal-force" in capsys.readouterr().err


def test_list(capsys):
    assert main(["model", "--list"]) == 0
    text = capsys.readouterr().out
    for row in model.ModelParameters.info():
        assert row.name in text and row.description in text
    rows = _json(capsys, "--list")
    assert [r["name"] for r in rows] == list(model.ModelParameters.names())
    assert {r["name"]: r["unit"] for r in rows}["h_L"] == "m"


def test_table(capsys):
    assert main(["model", "--normal-force", "0.1", "--voltage", "150"]) == 0
    text = capsys.readouterr().out
    assert "contact area increase" in text and "13.1" in text


def test_figures_written_not_blank_and_not_overwritten(tmp_path, capsys):
    from matplotlib import image

    out = tmp_path / "new" / "figures"
    assert main(["model", "--figures", str(out)]) == 0
    names = {p.name for p in out.iterdir()}
    for stem in ("fig5_friction_time", "fig6_friction_vs_load", "fig7_area_increase",
                 "maugis_vs_jkr", "frequency"):
        assert {f"{stem}.png", f"{stem}.svg"} <= names
        pixels = image.imread(out / f"{stem}.png")
        assert pixels.shape[0] > 300 and np.var(pixels[..., :3]) > 1e-3
        assert "<svg" in (out / f"{stem}.svg").read_text()[:500]
    assert "wrote" in capsys.readouterr().out
    before = (out / "fig5_friction_time.png").stat().st_mtime_ns
    assert main(["model", "--figures", str(out)]) == 2
    assert "--force" in capsys.readouterr().err
    assert (out / "fig5_friction_time.png").stat().st_mtime_ns == before
    assert main(["model", "--figures", str(out), "--force", "--json"]) == 0
    assert len(json.loads(capsys.readouterr().out)["figures"]) == 10


def test_save_figures_raises_output_exists(tmp_path):
    from evtribo.figures.model_figures import save_model_figures as save_figures

    (tmp_path / "fig7_area_increase.svg").write_text("keep")
    with pytest.raises(OutputExistsError):
        save_figures(tmp_path)
    assert (tmp_path / "fig7_area_increase.svg").read_text() == "keep"
