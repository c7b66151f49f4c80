"""Every figure's legend explains every line it draws, with handles drawn as the lines are
(colour and opacity, line style and width, marker and fill, hatch), in reading order, and
no entry explains nothing: the figures of a study with square and sine drives, of a
frequency sweep compared with several models, and the check of a trial. With the slips a
journal would print: no model-only sine figure for a square-only study, a labelled tick at
every step of a linear voltage axis, a lifted stretch shaded as lifted, hatches that differ
in more than their direction, the time axis labelled from 0."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, write_trial
from evtribo.acquisition.simulator.realism import human, realistic_rig
from evtribo.analysis.forces.conditions import ON
from evtribo.figures.frequency_plots import plot_frequency_response
from evtribo.figures.layout import reading_order
from evtribo.figures.registry import FigureContext, planned
from evtribo.figures.style import journal_style
from evtribo.figures.trial_plots import _HATCH, draw_trial_check
from evtribo.fit.fit import fit_study
from evtribo.fit.models import fit_models
from evtribo.fit.tables import read_results
from evtribo.model import TABLE_1
from evtribo.results.trial_view import excluded_stretches, view_trial
from legends import legend_entries, unexplained
from sweep_data import sweep_out
from synthetic import make_out


def _add_sine_rows(folder: Path) -> None:
    import pandas as pd

    path = folder / "electrostatic.csv"
    elec = pd.read_csv(path)
    rows = elec[elec["amplitude_V"].isin((100.0, 140.0))].copy()
    rows["waveform"] = "sine"
    for col in ("electrostatic_force_N", "electrostatic_force_ci_low_N",
                "electrostatic_force_ci_high_N"):
        rows[col] = rows[col] / 2.0
    pd.concat([elec, rows]).to_csv(path, index=False)


def _drawn(folder: Path) -> dict[str, object]:
    """compare's figures of the fits (those of the registry drawn once the subjects are
    fitted), by stem."""
    tables = read_results(folder)
    fits = fit_study(tables, TABLE_1, ("h_L",))
    with journal_style():
        return {f.stem: f.drawing.draw().figure
                for f in planned(FigureContext(tables, fits=fits), "fits")}


@pytest.fixture(scope="module")
def figures(tmp_path_factory) -> dict[str, object]:
    """compare's figures of two subjects driven by square and sine waves."""
    folder = make_out(tmp_path_factory.mktemp("legends") / "out", bootstrap=False)
    _add_sine_rows(folder)
    return _drawn(folder)


def test_every_line_of_compare_s_figures_is_in_its_legend(figures):
    assert {"electrostatic_force_all", "friction_time", "area_increase",
            "electrostatic_force_P01", "friction_normal_force_P01"} <= set(figures)
    for stem, fig in figures.items():
        [ax] = fig.axes
        fig.canvas.draw()
        missing, phantoms = unexplained(ax)
        assert (missing, phantoms) == ([], []), stem


def test_the_all_subjects_legend_names_each_line_in_order(figures):
    ax = figures["electrostatic_force_all"].axes[0]
    curves = [ln for ln in ax.lines if len(ln.get_xdata()) > 10]
    assert len(curves) == 4  # P01 and P02, square and sine
    labels = [label for label, _ in legend_entries(ax)]
    # the entries in the legend's columns, read row by row, are in the order drawn
    ncol = len(ax.get_legend()._legend_handle_box.get_children())
    assert reading_order(["P01, square", "P01, sine", "P02, square", "P02, sine"],
                         ["P01, square", "P01, sine", "P02, square", "P02, sine"],
                         ncol)[1] == labels
    # a sine's line is drawn lighter, and so is its handle; its markers open
    for label, arts in legend_entries(ax):
        line, marker = arts
        assert line.get_alpha() == (0.6 if "sine" in label else 1.0)
        assert (marker.get_markerfacecolor() == "white") == ("sine" in label)


def test_reading_order_fills_rows_first():
    h = list("abcdefg")
    handles, _ = reading_order(h, h, 3)
    # matplotlib fills columns: a d g | b e | c f reads a b c / d e f / g
    assert handles == ["a", "d", "g", "b", "e", "c", "f"]


def test_a_square_only_study_has_no_model_only_sine_figure(tmp_path):
    folder = make_out(tmp_path / "out", sine_trace=False, bootstrap=False)
    figures = _drawn(folder)
    assert "friction_time" not in figures
    assert "area_increase" in figures


def test_the_area_axis_has_a_labelled_tick_at_each_step_from_zero(figures):
    ax = figures["area_increase"].axes[0]
    ax.figure.canvas.draw()
    locs = list(ax.xaxis.get_majorticklocs())
    labels = [t.get_text() for t in ax.xaxis.get_majorticklabels()]
    assert locs[:4] == [0.0, 20.0, 40.0, 60.0]
    assert np.allclose(np.diff(locs), 20.0)
    assert all(labels), labels


def test_every_drive_of_a_sweep_is_drawn_and_every_model_explained(tmp_path):
    folder = tmp_path / "out"
    sweep_out(folder, "circuit", seed=2)
    tables = read_results(folder)
    fits = fit_models(tables, ("paper", "circuit"), TABLE_1)
    rows = tables.electrostatic[tables.electrostatic["subject"] == tables.subjects[0]]
    mine = [f for f in fits if f.subject == tables.subjects[0]]
    with journal_style():
        ax = plot_frequency_response(rows, mine, subject=tables.subjects[0])
    drives = rows[["waveform", "amplitude_V"]].drop_duplicates()
    assert len(ax.containers) == len(drives) == 10  # every drive, not the first three
    missing, phantoms = unexplained(ax)
    assert (missing, phantoms) == ([], [])
    # ten drives: the amplitude on a colour bar, one legend entry per waveform and model
    labels = [label for label, _ in legend_entries(ax)]
    assert labels[0] == "square drive" and len(labels) == 1 + 2
    bar = ax.figure.axes[-1]
    assert sorted(bar.yaxis.get_majorticklocs()) == sorted(drives["amplitude_V"])
    few = rows[rows["amplitude_V"].isin(sorted(drives["amplitude_V"])[:4])]
    with journal_style():
        ax4 = plot_frequency_response(few, mine, subject=tables.subjects[0])
    assert len(ax4.figure.axes) == 1 and unexplained(ax4) == ([], [])
    assert {f"square {a:g} V" for a in sorted(drives["amplitude_V"])[:4]} <= {
        label for label, _ in legend_entries(ax4)}
    # the legend keeps the data's height: the figure grew by it
    box = ax.get_position()
    assert box.height * ax.figure.get_figheight() > 0.55 * 85 / 25.4 * 0.75


@pytest.fixture(scope="module")
def trial_check(tmp_path_factory):
    """A real rig's trial: a tare stretch, and a lift-off while the voltage is ON."""
    root = tmp_path_factory.mktemp("check") / "study"
    write_trial(root, "run-01", human(SubjectParams(), seed=2),
                realistic_rig(TrialConfig(duration_s=12.0, seed=2)))
    check = view_trial(root, "P01", "run-01")
    lifted = [s for s in excluded_stretches(check) if s.kind == "lifted"]
    t = check.pieces[0].forces.t - check.t0
    assert any((check.pieces[0].condition[(t > s.t_start) & (t < s.t_end)] == ON).any()
               for s in lifted)  # the case of the mixed colour
    with journal_style():
        ax = draw_trial_check(check)
    ax.figure.canvas.draw()
    return ax


def test_the_check_of_a_trial_explains_every_trace_window_and_stretch(trial_check):
    missing, phantoms = unexplained(trial_check)
    assert (missing, phantoms) == ([], [])
    labels = [label for label, _ in legend_entries(trial_check)]
    assert "finger lifted: zero read" in labels and "voltage ON" in labels


def test_the_check_of_a_trial_has_no_unexplained_colour_and_starts_at_zero(trial_check):
    ax = trial_check
    spans = [(p.get_x(), p.get_x() + p.get_width(), p.get_facecolor()) for p in ax.patches
             if not p.get_hatch()]
    lifted = [(a, b) for a, b, c in spans if c[2] > 0.8 and c[0] < 0.5]  # the blue
    on = [(a, b) for a, b, c in spans if c[2] < 0.5]  # the yellow
    assert lifted and on
    for a, b in lifted:  # no ON shading under a lifted stretch: no mixed colour
        assert all(b2 <= a + 1e-9 or a2 >= b - 1e-9 for a2, b2 in on)
    assert ax.get_xlim()[0] <= 0.0
    assert "0" in [t.get_text() for t in ax.xaxis.get_majorticklabels()]
    patterns = [frozenset(h) for h in _HATCH.values()]
    assert len(set(patterns)) == len(patterns)  # not the same strokes in another direction


def test_the_legend_check_sees_a_line_left_out_and_an_entry_of_nothing():
    from evtribo.figures.plots import new_axes
    from evtribo.figures.style import proxy

    with journal_style():
        ax = new_axes()
        ax.plot([0, 1], [0, 1], "--", color="C0")
        ax.plot([0, 1], [1, 0], "-", color="C1", alpha=0.6)  # the lighter line
        ax.legend(handles=[proxy("a", color="C0", linestyle="--"),
                           proxy("b", color="C1", linestyle="-"),  # drawn opaque
                           proxy("c", color="C2", marker="o", linestyle="none")])
        ax.figure.canvas.draw()
    missing, phantoms = unexplained(ax)
    assert len(missing) == 1 and phantoms == ["b", "c"]


@pytest.mark.parametrize("k", [4, 9])
def test_the_population_figure_explains_each_subject_and_the_bands(k):
    """Every subject named in its colour, marker and line style; the population's mean,
    the confidence band of that mean and the prediction band for a new subject each an
    entry of its own; nothing drawn unexplained, no entry without its drawing."""
    from evtribo.figures.population_plots import plot_population
    from evtribo.population.estimates import population
    from population_sim import hierarchical_tables

    tables, _ = hierarchical_tables(np.random.default_rng(3), k)
    pop = population(tables)
    with journal_style():
        ax = plot_population(tables.electrostatic, pop, next(iter(pop.lines)))
        ax.figure.canvas.draw()
    labels = [label for label, _ in legend_entries(ax)]  # column by column
    assert sorted(labels) == sorted(["population mean", "95 % CI of the mean",
                                     "95 % PI, new subject", *tables.subjects])
    assert unexplained(ax) == ([], [])
