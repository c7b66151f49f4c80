"""The plotting functions draw what they say on the Axes they are given."""

import numpy as np
import pytest
from matplotlib.figure import Figure

from evtribo import model
from evtribo.figures import model_figures as figures


@pytest.mark.parametrize("plot", list(figures.MODEL_FIGURES.values()),
                         ids=list(figures.MODEL_FIGURES))
def test_draws_on_given_axes_with_units(plot):
    ax = Figure().add_subplot()
    assert plot(ax) is ax
    assert "(" in ax.get_xlabel() and "(" in ax.get_ylabel()
    assert ax.lines and ax.get_legend() is not None


@pytest.mark.parametrize("plot", list(figures.MODEL_FIGURES.values()),
                         ids=list(figures.MODEL_FIGURES))
def test_new_axes_without_pyplot(plot):
    ax = plot()
    assert isinstance(ax.get_figure(), Figure)


def test_figure_5_data():
    ax = figures.plot_paper_friction_time()
    ext, on, off = (line.get_ydata() for line in ax.lines[:3])
    assert np.all(ext == 0.5)
    assert np.all(on >= off - 1e-15) and on.max() == pytest.approx(
        model.friction_force(0.5, 140.0), rel=1e-4)


def test_figure_6_on_is_the_square_wave_average():
    ax = figures.plot_paper_friction_vs_load()
    off, on = ax.lines[0], ax.lines[1]
    x = on.get_xdata()
    assert np.allclose(on.get_ydata(), model.friction_force(x, 140.0))
    assert np.allclose(off.get_ydata(), 0.5 * x)


def test_figure_7_data():
    ax = figures.plot_paper_area_increase()
    assert [line.get_label() for line in ax.lines] == [
        "$F_\\mathrm{ext}$ = 0.1 N", "$F_\\mathrm{ext}$ = 0.5 N", "$F_\\mathrm{ext}$ = 2 N"]
    ends = [line.get_ydata()[-1] for line in ax.lines]
    assert ends[0] == pytest.approx(13.0, abs=0.5) and ends[2] == pytest.approx(3.0, abs=0.5)
