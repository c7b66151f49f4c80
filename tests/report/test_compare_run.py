from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from matplotlib.image import imread

from evtribo.cli import main
from evtribo.errors import OutputExistsError
from evtribo.figures.plots import (
    new_axes,
    plot_electrostatic_force,
    plot_friction_time,
    save_figure,
    trace_voltage,
)
from evtribo.fit.fit_csv import FIT_COLUMNS
from evtribo.fit.tables import read_results
from evtribo.model import TABLE_1, friction_force
from evtribo.report.compare import compare
from synthetic import TRUE_H_L, make_out


def test_compare_writes_fit_and_figures(compared_out):
    fit = pd.read_csv(compared_out / "fit.csv")
    assert tuple(fit.columns) == FIT_COLUMNS
    for _, row in fit.iterrows():
        truth = TRUE_H_L[row["subject"]]
        assert row["ci_low"] <= truth <= row["ci_high"]
    figs = sorted(p.name for p in (compared_out / "figures").iterdir())
    stems = ("electrostatic_force_all", "electrostatic_force_P01", "friction_normal_force_P01",
             "electrostatic_force_P02", "friction_normal_force_P02", "friction_time",
             "area_increase")
    # one file per figure and default format (svg, png), nothing else
    assert figs == sorted(f"{stem}.{fmt}" for stem in stems for fmt in ("png", "svg"))
    doc = json.loads((compared_out / "fit.json").read_text())
    assert [f["stem"] for f in doc["figures"]] == list(stems)
    first = doc["figures"][0]
    assert first["kind"] == "electrostatic_force_all" and first["subject"] is None
    assert set(first) == {"kind", "title", "stem", "subject", "caption", "section", "per",
                          "key", "dpi"}
    assert len(first["key"]) == 40 and first["dpi"] == 40.0  # what its files were drawn from
    # where the report places each, said in the record too (a report without its spec)
    assert (first["section"], first["per"]) == ("all", "study")
    by_stem = {f["stem"]: f for f in doc["figures"]}
    assert by_stem["electrostatic_force_P01"]["section"] == "subject"
    assert by_stem["electrostatic_force_P01"]["grid"][0].startswith("Electrostatic force")
    assert by_stem["area_increase"]["section"] == "predictions"
    assert doc["fit"] == ["h_L"]
    assert doc["subjects"]["P02"]["parameters"]["h_L"] == pytest.approx(
        fit.loc[fit["subject"] == "P02", "value"].item())
    for subject in TRUE_H_L:
        assert doc["subjects"][subject]["interval"] == {"method": "bootstrap",
                                                        "replicates": 200, "note": ""}
    # a synthetic result folder has no study: no trial checks, and a warning saying so
    kinds = [w["kind"] for w in doc["warnings"]]
    assert kinds[0] == "intervals-bootstrap" and kinds[-1] == "checks-study-gone"
    assert "electrostatic_bootstrap.csv" in doc["warnings"][0]["text"]
    assert "no check figures of the trials" in doc["warnings"][-1]["text"]
    assert "population-rule-unread" in kinds  # nor the study's [population] rule
    assert doc["notes"] == [w["text"] for w in doc["warnings"]]  # for older readers
    assert doc["fit_version"] == 2
    captions = {f["stem"]: f["caption"] for f in doc["figures"]}
    assert captions["friction_time"].startswith("Measured sine trial of P01")


def test_params_file_is_used(out_dir, tmp_path):
    params = tmp_path / "stiff.toml"
    params.write_text("E_star = 80e3  # Pa\n")
    default = compare(out_dir, dpi=30, formats=("png",))
    stiff = compare(out_dir, dpi=30, formats=("png",), params=params, force=True)
    doc = json.loads((out_dir / "fit.json").read_text())
    assert doc["fixed_parameters"]["E_star"] == 80e3
    assert doc["parameters_file"]["path"] == str(params)
    # a stiffer finger has a smaller contact: the same forces need a thinner gap
    for d, s in zip(default.fits, stiff.fits, strict=True):
        assert s["h_L"].value < 0.95 * d["h_L"].value
        assert s.params.E_star == 80e3


def test_refuses_to_overwrite(compared_out):
    before = (compared_out / "fit.csv").read_bytes()
    with pytest.raises(OutputExistsError):
        compare(compared_out, dpi=40)
    assert (compared_out / "fit.csv").read_bytes() == before


def test_without_sine_trace_no_friction_time_figure(out_dir):
    (out_dir / "sine_trace.csv").unlink()
    result = compare(out_dir, dpi=30, formats=("png",))
    [said] = [n for n in result.notes if n.kind == "sine-trace-none"]
    assert "sine_trace.csv" in said.text
    doc = json.loads((out_dir / "fit.json").read_text())
    assert said.as_json() in doc["warnings"]
    assert "friction_time" not in {f["kind"] for f in doc["figures"]}
    assert not (out_dir / "figures" / "friction_time.png").exists()
    ax = plot_friction_time(None, TABLE_1)  # the model alone, when asked for: no text over it
    assert not ax.texts and all("model" in t.get_text() or "normal" in t.get_text()
                                for t in ax.get_legend().get_texts())
    again = compare(out_dir, dpi=30, formats=("png",), force=True, fit="h_L,mu")
    assert {e.name for e in again.fits[0].estimates} == {"h_L", "mu"}
    # mu is fitted with the windows, which have no replicates: the Jacobian, said so
    assert all(f.interval_method == "jacobian" for f in again.fits)
    assert any("mu is fitted with the windows" in n.text for n in again.notes
               if n.kind == "intervals-jacobian")


def test_without_bootstrap_file_falls_back_to_the_jacobian(tmp_path):
    folder = make_out(tmp_path / "out", bootstrap=False, sine_trace=False)
    result = compare(folder, dpi=30, formats=("png",))
    doc = json.loads((folder / "fit.json").read_text())
    for subject, truth in TRUE_H_L.items():
        assert doc["subjects"][subject]["interval"]["method"] == "jacobian"
        est = doc["subjects"][subject]["estimates"]["h_L"]
        assert est["ci_low"] <= truth <= est["ci_high"]
    assert [n.kind for n in result.notes if n.kind.startswith(("bootstrap", "intervals"))] \
        == ["bootstrap-missing"]


def _pixel_variance(path) -> float:
    img = imread(path)
    return float(np.var(img[..., :3]))


def test_figure_is_not_blank(out_dir, tmp_path):
    tables = read_results(out_dir)
    rows = tables.electrostatic[tables.electrostatic["subject"] == "P01"]
    ax = plot_electrostatic_force(rows, TABLE_1.with_values(h_L=3e-6), subject="P01")
    assert ax.get_xscale() == "log" and "(V)" in ax.get_xlabel() and "(mN)" in ax.get_ylabel()
    (png,) = save_figure(ax.figure, tmp_path, "fel", dpi=40, formats=("png",))
    assert _pixel_variance(png) > 1e-3
    # a figure with nothing drawn is uniform: the measure can tell
    empty = new_axes()
    empty.set_axis_off()
    (blank,) = save_figure(empty.figure, tmp_path, "blank", dpi=40, formats=("png",))
    assert _pixel_variance(blank) == 0.0


def test_plot_draws_on_given_axes(out_dir):
    tables = read_results(out_dir)
    ax = new_axes()
    rows = tables.electrostatic[tables.electrostatic["subject"] == "P02"]
    assert plot_electrostatic_force(rows, TABLE_1, ax=ax) is ax
    assert len(ax.lines) >= 2


def test_cli_exit_codes(out_dir, tmp_path, capsys):
    assert main(["compare", str(tmp_path / "missing")]) == 2
    assert "missing" in capsys.readouterr().err
    assert main(["compare", str(out_dir), "--fit", "h_L,nonsense"]) == 2
    assert "nonsense" in capsys.readouterr().err
    bad = tmp_path / "p.toml"
    bad.write_text("E_star = 'soft'\n")
    assert main(["compare", str(out_dir), "--params", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "p.toml" in err and "E_star" in err
    assert not (out_dir / "fit.csv").exists()
    assert main(["compare", str(out_dir), "--dpi", "30"]) == 0
    assert "P01: h_L" in capsys.readouterr().out
    assert main(["compare", str(out_dir), "--dpi", "30"]) == 2
    assert "--force" in capsys.readouterr().err


def test_trace_voltage_phase_from_friction():
    # a trace that only reports the drive's amplitude and frequency: the phase that best
    # explains the friction is found, modulo pi
    p = TABLE_1.with_values(h_L=3e-6)
    t = np.arange(0.0, 0.2, 5e-4)
    true_u = 140.0 * np.sin(2 * np.pi * 10.0 * t + 1.0)
    fn = np.full_like(t, 0.5)
    trace = pd.DataFrame({"time_s": t, "normal_force_N": fn,
                          "friction_force_N": friction_force(fn, true_u, p),
                          "amplitude_V": 140.0, "frequency_Hz": 10.0})
    u = trace_voltage(trace, p)
    np.testing.assert_allclose(np.abs(u), np.abs(true_u), atol=0.03 * 140)
    assert np.array_equal(trace_voltage(trace.assign(voltage_V=true_u), p), true_u)


def test_compare_says_what_it_is_doing(out_dir, capsys):
    said: list[str] = []
    compare(out_dir, dpi=30, formats=("png",), progress=said.append)
    assert said[0].startswith("fitting h_L to each of 2 subjects")
    assert "drawing the figures of the fit" in said
