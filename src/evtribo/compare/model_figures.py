"""The model alone: Figures 5, 6 and 7 of the seed paper, the Maugis-Dugdale comparison it
leaves out, and F_el against the drive's frequency (``evtribo model --figures``).

Each ``plot_*`` function draws on the Axes it is given (or on a new one,
:func:`evtribo.compare.plots.new_axes`, without pyplot's global state) and returns the Axes.
:func:`save_model_figures` writes them all as PNG and SVG
(:func:`evtribo.compare.plots.save_figure`). The figures of a comparison with measured
results are :mod:`evtribo.compare.plots`'.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from evtribo.compare.plots import new_axes, save_figure
from evtribo.errors import OutputExistsError
from evtribo.model.circuit import electrostatic_force_drive, layer_elastances
from evtribo.model.contact import area_increase_pct, contact_area_jkr
from evtribo.model.friction import (
    friction_force,
    friction_time_series,
    sine_voltage,
    square_voltage,
)
from evtribo.model.maugis import contact_area_md, maugis_parameter, md_jkr_departure
from evtribo.model.params import TABLE_1, ModelParameters

__all__ = [
    "MODEL_FIGURES",
    "plot_frequency",
    "plot_maugis",
    "plot_paper_area_increase",
    "plot_paper_friction_time",
    "plot_paper_friction_vs_load",
    "save_model_figures",
]

log = logging.getLogger(__name__)

_FIGSIZE = (6.4, 4.2)


def plot_paper_friction_time(ax: Axes | None = None, *, normal_force: float = 0.5,
                             amplitude: float = 140.0, frequency: float = 10.0,
                             duration: float = 0.3,
                             params: ModelParameters = TABLE_1) -> Axes:
    """Figure 5: friction versus time for a sine voltage, ON and OFF, and the external force.

    Parameters
    ----------
    ax : Axes, optional
        Where to draw; a new figure's Axes by default.
    normal_force : float
        External normal force F_ext, N.
    amplitude : float
        Voltage amplitude, V.
    frequency : float
        Voltage frequency, Hz.
    duration : float
        Time shown, s.
    params : ModelParameters
        Table 1 by default.

    Returns
    -------
    Axes
    """
    ax = ax if ax is not None else new_axes(_FIGSIZE)
    t = np.linspace(0.0, duration, 3001)
    on = friction_time_series(t, normal_force, sine_voltage(t, amplitude, frequency), params)
    off = friction_time_series(t, normal_force, 0.0, params)
    ax.plot(t, np.full_like(t, normal_force), color="tab:green", label="external force")
    ax.plot(t, on, color="tab:red", label=f"friction, ON ({amplitude:g} V, {frequency:g} Hz)")
    ax.plot(t, off, color="tab:blue", label="friction, OFF")
    ax.set(xlabel="time t (s)", ylabel="force (N)", xlim=(0, duration), ylim=(0, None),
           title=f"Friction under a sine voltage (mu = {params.mu:g})")
    ax.legend(loc="lower right")
    return ax


def plot_paper_friction_vs_load(ax: Axes | None = None, *, amplitude: float = 140.0,
                                frequency: float = 10e3, max_force: float = 2.0,
                                params: ModelParameters = TABLE_1) -> Axes:
    """Figure 6: friction versus external force, OFF and ON under a square-wave voltage.

    The ON friction is the time average over one period of the square wave (steady, since
    U^2 is constant for an ideal square wave).

    Parameters
    ----------
    ax : Axes, optional
        Where to draw.
    amplitude : float
        Square-wave amplitude, V.
    frequency : float
        Square-wave frequency, Hz.
    max_force : float
        Largest external force shown, N.
    params : ModelParameters
        Table 1 by default.

    Returns
    -------
    Axes
    """
    ax = ax if ax is not None else new_axes(_FIGSIZE)
    forces = np.linspace(0.0, max_force, 201)
    t = np.linspace(0.0, 1.0 / frequency, 200, endpoint=False)
    u = square_voltage(t, amplitude, frequency)
    on = friction_force(forces[:, None], u[None, :], params).mean(axis=1)
    ax.plot(forces, friction_force(forces, 0.0, params), color="tab:green", label="OFF")
    ax.plot(forces, on, color="tab:orange",
            label=f"ON ({amplitude:g} V square, {frequency / 1e3:g} kHz)")
    ax.set(xlabel="external normal force F_ext (N)", ylabel="friction force F_R (N)",
           xlim=(0, max_force), ylim=(0, None), title="Friction versus external force")
    ax.legend(loc="upper left")
    return ax


def plot_paper_area_increase(ax: Axes | None = None, *,
                             normal_forces: Sequence[float] = (0.1, 0.5, 2.0),
                             max_voltage: float = 150.0,
                             params: ModelParameters = TABLE_1) -> Axes:
    """Figure 7: percentage increase of the contact area (JKR over Hertz) versus voltage.

    Parameters
    ----------
    ax : Axes, optional
        Where to draw.
    normal_forces : sequence of float
        External normal forces, N, one curve each.
    max_voltage : float
        Largest voltage amplitude shown, V.
    params : ModelParameters
        Table 1 by default.

    Returns
    -------
    Axes
    """
    ax = ax if ax is not None else new_axes(_FIGSIZE)
    u = np.linspace(0.0, max_voltage, 301)
    for f in normal_forces:
        ax.plot(u, area_increase_pct(f, u, params), label=f"F_ext = {f:g} N")
    ax.set(xlabel="voltage amplitude U (V)", ylabel="contact area increase (%)",
           xlim=(0, max_voltage), ylim=(0, None), title="Contact area increase, JKR vs Hertz")
    ax.legend(loc="upper left")
    return ax


def plot_maugis(ax: Axes | None = None, *, normal_forces: Sequence[float] = (0.1, 0.5, 2.0),
                max_voltage: float = 150.0, params: ModelParameters = TABLE_1) -> Axes:
    """Where Maugis-Dugdale departs from the JKR asymptote: percent differences versus voltage.

    Solid: electrostatic force sigma_0 pi c^2 over eq. (11); dashed: contact area
    pi a^2 over eq. (3). The Maugis parameter lambda (which grows as U^(4/3)) is on the
    right-hand axis.

    Parameters
    ----------
    ax : Axes, optional
        Where to draw.
    normal_forces : sequence of float
        External normal forces, N.
    max_voltage : float
        Largest voltage amplitude shown, V.
    params : ModelParameters
        Table 1 by default.

    Returns
    -------
    Axes
        The left (percent) Axes; the lambda axis is its twin.
    """
    ax = ax if ax is not None else new_axes(_FIGSIZE)
    u = np.linspace(max_voltage / 60, max_voltage, 60)
    for i, f in enumerate(normal_forces):
        color = f"C{i}"
        ax.plot(u, 100 * md_jkr_departure(f, u, params), color=color,
                label=f"force, F_ext = {f:g} N")
        area = 100 * (contact_area_md(f, u, params) / contact_area_jkr(f, u, params) - 1)
        ax.plot(u, area, color=color, linestyle="--", label=f"area, F_ext = {f:g} N")
    ax.axhline(0.0, color="0.5", linewidth=0.8)
    ax.set(xlabel="voltage amplitude U (V)", ylabel="Maugis-Dugdale vs JKR (%)",
           xlim=(0, max_voltage), title="Maugis-Dugdale departure from JKR")
    twin = ax.twinx()
    twin.plot(u, maugis_parameter(u, params), color="k", linestyle=":", label="lambda")
    twin.set_ylabel("Maugis parameter lambda (1)")
    twin.set_ylim(0, None)
    handles, labels = ax.get_legend_handles_labels()
    h2, l2 = twin.get_legend_handles_labels()
    # below the plot: inside, it would hide a curve whatever the corner
    ax.legend(handles + h2, labels + l2, loc="upper center", bbox_to_anchor=(0.5, -0.18),
              fontsize="small", ncol=3)
    return ax


def plot_frequency(ax: Axes | None = None, *, normal_force: float = 0.5,
                   amplitude: float = 100.0, corners_Hz: Sequence[float] = (20.0, 100.0, 300.0),
                   params: ModelParameters = TABLE_1) -> Axes:
    """The electrostatic force against the drive's frequency (:mod:`evtribo.model.circuit`):
    the paper's model (a perfectly insulating gap: no frequency dependence) and gaps that
    leak, with their corner frequencies, under a square and a sine drive.

    Parameters
    ----------
    ax : Axes, optional
        Where to draw.
    normal_force : float
        External normal force, N.
    amplitude : float
        Voltage amplitude, V.
    corners_Hz : sequence of float
        Corner frequencies of the leaky gaps shown, Hz: ``r_g`` is chosen so that
        ``2 pi f r_g (c_g + c_rest) = 1``, ``c_rest`` the other layers in series.
    params : ModelParameters
        Table 1 by default (its ``r_sc``, ``r_g`` for the first curve).

    Returns
    -------
    Axes
    """
    ax = ax if ax is not None else new_axes(_FIGSIZE)
    f = np.geomspace(1.0, 1e5, 121)
    for waveform, style in (("square", "-"), ("sine", "--")):
        ax.plot(f, 1e3 * electrostatic_force_drive(normal_force, amplitude, f, waveform,
                                                   params),
                color="k", linestyle=style, label=f"paper, r_g = inf ({waveform})")
    s_sc, s_g, s_i = layer_elastances(params)
    c_total = 1.0 / s_g + 1.0 / (s_sc + s_i)
    for i, corner in enumerate(corners_Hz):
        leaky = params.with_values(r_g=1.0 / (2.0 * np.pi * corner * c_total))
        for waveform, style in (("square", "-"), ("sine", "--")):
            ax.plot(f, 1e3 * electrostatic_force_drive(normal_force, amplitude, f, waveform,
                                                       leaky),
                    color=f"C{i}", linestyle=style,
                    label=f"leaky gap, corner {corner:g} Hz ({waveform})")
    ax.set(xscale="log", xlabel="drive frequency f (Hz)",
           ylabel="electrostatic force F_el (mN)", ylim=(0, None),
           title=f"F_el against frequency ({amplitude:g} V, F_ext = {normal_force:g} N)")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.18), fontsize="small", ncol=2)
    return ax


#: name -> plotting function, in the order :func:`save_model_figures` writes them.
MODEL_FIGURES: dict[str, Callable[..., Axes]] = {
    "fig5_friction_time": plot_paper_friction_time,
    "fig6_friction_vs_load": plot_paper_friction_vs_load,
    "fig7_area_increase": plot_paper_area_increase,
    "maugis_vs_jkr": plot_maugis,
    "frequency": plot_frequency,
}


def save_model_figures(directory: str | os.PathLike[str], *, force: bool = False,
                       formats: Sequence[str] = ("png", "svg"),
                       params: ModelParameters = TABLE_1) -> list[Path]:
    """Write every figure of :data:`MODEL_FIGURES` into *directory* (created if missing).

    Parameters
    ----------
    directory : path
        Output folder.
    force : bool
        Overwrite existing files; otherwise an existing file is an error and nothing is
        written.
    formats : sequence of str
        File suffixes understood by matplotlib.
    params : ModelParameters
        Table 1 by default.

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    OutputExistsError
        If a file exists and *force* is false.
    """
    out = Path(directory)
    paths = [out / f"{name}.{fmt}" for name in MODEL_FIGURES for fmt in formats]
    existing = [p for p in paths if p.exists()]
    if existing and not force:
        raise OutputExistsError(
            f"{len(existing)} figure file(s) already exist; use {{force}} to overwrite",
            path=existing[0])
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for name, plot in MODEL_FIGURES.items():
        ax = plot(params=params)
        fig = ax.get_figure()
        assert isinstance(fig, Figure)
        for path in save_figure(fig, out, name, dpi=150, formats=formats):
            written.append(path)
            log.info("wrote %s", path)
    return written
