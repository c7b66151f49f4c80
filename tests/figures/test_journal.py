"""What a journal's figure editor checks in compare's figures: no text under 5 pt, μ and F
both italic, every legend in the same place (above the plot), data apart from the model in
the legends, model lines only where something was measured, colours that stand out on white,
the friction-versus-load axes zoomed to the data, a measured force not in a model's line
style, and a force axis labelled from 0."""

from __future__ import annotations

import io
import re
from pathlib import Path

import matplotlib as mpl
import numpy as np
import pandas as pd
import pytest
from matplotlib.colors import to_rgb

from evtribo.figures.registry import FigureContext, planned
from evtribo.figures.style import MIN_TEXT_PT, journal_style
from evtribo.fit.fit import fit_study
from evtribo.fit.tables import read_results
from evtribo.model import TABLE_1
from legends import legend_entries, unexplained
from synthetic import make_out

_NONE = ("None", "none", "", " ")


@pytest.fixture(scope="module")
def figures(tmp_path_factory) -> dict[str, object]:
    """compare's figures of two subjects, square at five amplitudes and a sine at one."""
    folder = make_out(tmp_path_factory.mktemp("journal") / "out", bootstrap=False)
    elec = pd.read_csv(folder / "electrostatic.csv")
    sine = elec[elec["amplitude_V"] == 140.0].copy()
    sine["waveform"] = "sine"
    for col in ("electrostatic_force_N", "electrostatic_force_ci_low_N",
                "electrostatic_force_ci_high_N"):
        sine[col] = sine[col] / 2.0
    pd.concat([elec, sine]).to_csv(folder / "electrostatic.csv", index=False)
    tables = read_results(folder)
    fits = fit_study(tables, TABLE_1, ("h_L",))
    with journal_style():
        figures = {f.stem: f.drawing.draw().figure
                   for f in planned(FigureContext(tables, fits=fits), "fits")}
    for fig in figures.values():
        fig.canvas.draw()
    return figures


def _svg_sizes(fig) -> list[float]:
    """The font sizes of an SVG written as compare writes it (text as text), pt."""
    buf = io.BytesIO()
    with mpl.rc_context({"svg.fonttype": "none"}):
        fig.savefig(buf, format="svg")
    return [float(x) for x in re.findall(rb"font-size: ?([0-9.]+)px", buf.getvalue())]


def test_no_text_under_five_points_and_greek_in_italic(figures):
    for stem, fig in figures.items():
        sizes = _svg_sizes(fig)
        assert sizes and min(sizes) >= MIN_TEXT_PT >= 5.0, (stem, min(sizes))
        texts = [t.get_text() for ax in fig.axes for t in ax.texts]
        texts += [t for ax in fig.axes for t, _ in legend_entries(ax)]
        texts += [ax.get_xlabel() for ax in fig.axes] + [ax.get_ylabel() for ax in fig.axes]
        for text in texts:  # μ as F: math italic, never the upright letter
            assert "μ" not in text, (stem, text)
            assert not re.search(r"(?<!\$)\bF_[a-z]", text.replace("$F_", "")), (stem, text)


def test_every_legend_sits_above_its_plot(figures):
    for stem, fig in figures.items():
        ax = fig.axes[0]
        legend = ax.get_legend()
        assert legend is not None, stem
        assert legend.get_window_extent().y0 >= ax.get_window_extent().y1 - 1, stem


def test_friction_against_load_zoomed_to_the_windows_with_the_model_only_over_them(figures):
    ax = figures["friction_normal_force_P01"].axes[0]
    points = [ln for ln in ax.lines if ln.get_linestyle() in _NONE]
    lines = [ln for ln in ax.lines if ln.get_linestyle() not in _NONE]
    x_points = np.concatenate([np.asarray(p.get_xdata(), float) for p in points])
    assert ax.get_xlim()[0] > 0.5 * x_points.min()  # not from the origin
    span = x_points.max() - x_points.min()
    assert np.ptp(ax.get_xlim()) < 1.5 * span
    for line in lines:  # each model line within its own windows' normal forces
        colour = to_rgb(line.get_color())
        own = np.concatenate([np.asarray(p.get_xdata(), float) for p in points
                              if to_rgb(p.get_color()) == colour])
        x = np.asarray(line.get_xdata(), float)
        assert own.min() - 1e-9 <= x.min() and x.max() <= own.max() + 1e-9
    # the legend: points (a marker, no line) apart from the model (a line, no marker)
    for label, arts in legend_entries(ax):
        (art,) = arts
        marker, line = art.get_marker() not in _NONE, art.get_linestyle() not in _NONE
        assert marker != line, label
        assert label.startswith("model") == line, label
    assert unexplained(ax) == ([], [])


def _luminance(colour) -> float:
    c = np.asarray(to_rgb(colour))
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return float(lin @ [0.2126, 0.7152, 0.0722])


def test_every_drive_s_colour_stands_out_on_white_and_rises_in_grey_with_the_voltage(figures):
    ax = figures["friction_normal_force_P01"].axes[0]
    on = sorted(((label, arts[0]) for label, arts in legend_entries(ax)
                 if label.startswith("ON ")), key=lambda e: float(e[0].split()[1]))
    assert len(on) == 5
    levels = []
    for label, art in on:
        lum = _luminance(art.get_color())
        assert 1.05 / (lum + 0.05) >= 3.0, label  # WCAG's 3:1 for graphics
        levels.append(lum)
    assert levels == sorted(levels)  # greyscale keeps the order of the amplitudes


def test_the_force_figure_has_no_guide_on_the_model_and_its_legend_parts_apart(figures):
    ax = figures["electrostatic_force_P01"].axes[0]
    assert not [ln for ln in ax.lines if ln.get_linestyle() == ":"]
    labels = [label for label, _ in legend_entries(ax)]
    assert {"measured, square", "measured, sine"} <= set(labels)
    assert sum(label.startswith("model, ") for label in labels) == 2
    for label, (art,) in legend_entries(ax):
        assert (art.get_marker() not in _NONE) == label.startswith("measured"), label
    assert unexplained(ax) == ([], [])


def test_a_drive_measured_at_one_amplitude_gets_its_model_only_there(figures):
    ax = figures["electrostatic_force_all"].axes[0]
    curves = [ln for ln in ax.lines if len(ln.get_xdata()) > 10]
    assert len(curves) == 4  # two subjects, square and sine
    sine = [ln for ln in curves if ln.get_alpha() == 0.6]
    assert len(sine) == 2
    for line in sine:  # the sine was measured at 140 V alone
        x = np.asarray(line.get_xdata(), float)
        assert x.min() == pytest.approx(140.0 / 1.15) and x.max() == pytest.approx(140 * 1.15)


def test_friction_in_time_draws_the_measured_force_as_measured_and_labels_zero(figures):
    ax = figures["friction_time"].axes[0]
    styles = {label: arts[0].get_linestyle() for label, arts in legend_entries(ax)}
    measured = [k for k in styles if "measured" in k]
    assert len(measured) == 2 and all(styles[k] == "-" for k in measured)
    assert "0" in [t.get_text() for t in ax.yaxis.get_majorticklabels()]


def test_the_area_increase_says_it_is_the_model_s(figures):
    ax = figures["area_increase"].axes[0]
    assert "model" in ax.get_ylabel()


def test_figures_are_written_at_85_mm(figures, tmp_path: Path):
    from evtribo.figures.plots import save_figure

    for stem, fig in figures.items():
        (png,) = save_figure(fig, tmp_path, stem, dpi=100, formats=("png",))
        assert fig.get_figwidth() == pytest.approx(85 / 25.4), stem
        assert png.stat().st_size > 0
