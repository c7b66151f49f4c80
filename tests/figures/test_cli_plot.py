"""``evtribo plot trial ...`` and ``evtribo plot LOG --dbc FILE SIGNAL...``: the figure in the
format its suffix names, an existing file kept, options anywhere among the words."""

from __future__ import annotations

import re
import struct
from pathlib import Path

import matplotlib.image as mpimg
import numpy as np
import pytest

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_study
from evtribo.cli import main


@pytest.fixture(scope="module")
def study(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("plot") / "study"
    simulate_study(root, [SubjectParams(name="P01")], amplitudes=(120.0,),
                   config=TrialConfig(duration_s=6.0), sine_trial=False, realistic=True)
    return root


def _png_dpi(path: Path) -> float:
    data = path.read_bytes()
    i = data.index(b"pHYs")
    ppx, _, unit = struct.unpack(">IIB", data[i + 4:i + 13])
    assert unit == 1  # metres
    return ppx * 0.0254


def test_plot_trial_writes_png_svg_and_pdf(study, tmp_path, capsys):
    for suffix in (".png", ".svg", ".pdf"):
        out = tmp_path / f"check{suffix}"
        assert main(["plot", "trial", str(study), "P01", "run-01", "-o", str(out)]) == 0
        printed = capsys.readouterr().out
        assert "Trial P01/run-01 (square 10000 Hz at 120 V)" in printed
        assert f"wrote {out}" in printed
    assert _png_dpi(tmp_path / "check.png") == pytest.approx(300, abs=1)
    pixels = np.asarray(mpimg.imread(tmp_path / "check.png"))[..., :3]
    assert pixels.std() > 0.05
    svg = (tmp_path / "check.svg").read_text()
    assert "<svg" in svg
    pdf = (tmp_path / "check.pdf").read_bytes()
    assert pdf.startswith(b"%PDF") and len(re.findall(rb"/Type\s*/Page\b", pdf)) == 1


def test_an_existing_figure_is_kept_without_force(study, tmp_path, capsys):
    out = tmp_path / "check.png"
    out.write_bytes(b"mine")
    argv = ["plot", "trial", str(study), "P01", "run-01", "-o", str(out)]
    assert main(argv) == 2
    assert main([*argv, "--force"]) == 2  # a file plot did not write: never replaced
    assert "is not a file evtribo wrote" in capsys.readouterr().err
    assert out.read_bytes() == b"mine"
    out.unlink()
    assert main(argv) == 0
    assert main(argv) == 2  # its own figure: kept without --force
    assert "exists; use --force to overwrite" in capsys.readouterr().err
    assert main([*argv, "--force"]) == 0
    assert out.read_bytes().startswith(b"\x89PNG")


def test_plot_signals_of_a_log_one_panel_per_unit(study, tmp_path, capsys):
    log = study / "P01" / "run-01.log"
    dbc = study / "rig" / "default.dbc"
    out = tmp_path / "signals.svg"
    # options among the words, a pattern, a qualified name
    assert main(["plot", str(log), "Fz", "--dbc", str(dbc), "Fx", "HvStatus.HvO*",
                 "FzTemp", "-o", str(out)]) == 0
    svg = out.read_text()
    # three panels: N (Fz and Fx), HvOn (no unit), FzTemp (degC)
    assert svg.count('id="axes_') == 3
    for label in ("FzCell.Fz", "FxCell.Fx", "HvOn", "FzTemp (degC)"):
        assert label in svg, label
    capsys.readouterr()


def test_signals_without_frames_are_named(study, tmp_path, capsys):
    log = study / "P01" / "run-01.log"
    dbc = study / "rig" / "default.dbc"
    out = tmp_path / "s.png"
    assert main(["plot", str(log), "--dbc", str(dbc), "Fz", "HvCmd.HvAmp", "-o",
                 str(out)]) == 0
    assert "no frames of HvCmd.HvAmp" in capsys.readouterr().err
    assert main(["plot", str(log), "--dbc", str(dbc), "HvCmd.*", "-o",
                 str(tmp_path / "t.png")]) == 2
    assert "no frame of HvCmd in the log: nothing to plot" in capsys.readouterr().err
    assert not (tmp_path / "t.png").exists()


def test_without_output_and_without_a_display_it_says_so(study, capsys, monkeypatch):
    import matplotlib.pyplot as plt

    monkeypatch.setattr(plt, "get_backend", lambda: "agg")  # as on a machine without one
    assert main(["plot", "trial", str(study), "P01", "run-01"]) == 2
    assert "no window can open here" in capsys.readouterr().err


def test_plot_trial_wants_its_three_names(study, tmp_path, capsys):
    assert main(["plot", "trial", str(study), "P01", "-o", str(tmp_path / "x.png")]) == 2
    assert "expected 'evtribo plot trial STUDY SUBJECT TRIAL'" in capsys.readouterr().err
