"""The model alone: Figures 5, 6 and 7 of the seed paper, the Maugis-Dugdale comparison it
leaves out, and F_el against the drive's frequency (``evtribo model --figures``).

Each ``plot_*`` function draws on the Axes it is given (or on a new one in the journal style
of :mod:`evtribo.figures.style`, without pyplot's global state: a column wide, no title)
and returns the Axes. Forces are in N, as in the paper's figures (F_el in mN).
:func:`save_model_figures` writes them all as PNG (300 dpi) and SVG
(:func:`evtribo.figures.plots.save_figure`). The figures of a comparison with measured
results are :mod:`evtribo.figures.plots`'.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from evtribo.errors import OutputExistsError
from evtribo.figures.layout import place_legend, plain_log_axis
from evtribo.figures.plots import save_figure
from evtribo.figures.style import (
    DEFAULT_DPI,
    PALETTE,
    journal_style,
    new_axes,
    proxy,
    series_style,
    styled,
)
from evtribo.guard import refuse_input
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
from evtribo.store.names import check_new_path
from evtribo.store.owned import claim, refuse_foreign

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

@styled
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
    ax = ax if ax is not None else new_axes()
    t = np.linspace(0.0, duration, 3001)
    on = friction_time_series(t, normal_force, sine_voltage(t, amplitude, frequency), params)
    off = friction_time_series(t, normal_force, 0.0, params)
    ax.plot(t, np.full_like(t, normal_force), "-.", color=PALETTE[2], label="external force")
    ax.plot(t, on, "-", color=PALETTE[1],
            label=f"friction, ON ({amplitude:g} V, {frequency:g} Hz)")
    ax.plot(t, off, "--", color=PALETTE[0], label=f"friction, OFF ($\\mu$ = {params.mu:g})")
    ax.set(xlabel="time $t$ (s)", ylabel="force (N)", xlim=(0, duration), ylim=(0, None))
    place_legend(ax)
    return ax


@styled
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
    ax = ax if ax is not None else new_axes()
    forces = np.linspace(0.0, max_force, 201)
    t = np.linspace(0.0, 1.0 / frequency, 200, endpoint=False)
    u = square_voltage(t, amplitude, frequency)
    on = friction_force(forces[:, None], u[None, :], params).mean(axis=1)
    ax.plot(forces, friction_force(forces, 0.0, params), "-", color="k",
            label=f"OFF ($\\mu$ = {params.mu:g})")
    ax.plot(forces, on, "--", color=PALETTE[1],
            label=f"ON ({amplitude:g} V square, {frequency / 1e3:g} kHz)")
    ax.set(xlabel="external normal force $F_\\mathrm{ext}$ (N)",
           ylabel="friction force $F_R$ (N)", xlim=(0, max_force), ylim=(0, None))
    place_legend(ax)
    return ax


@styled
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
    ax = ax if ax is not None else new_axes()
    u = np.linspace(0.0, max_voltage, 301)
    for k, f in enumerate(normal_forces):
        style = series_style(k)
        ax.plot(u, area_increase_pct(f, u, params), color=style["color"],
                linestyle=style["linestyle"], label=f"$F_\\mathrm{{ext}}$ = {f:g} N")
    ax.set(xlabel="voltage amplitude $U$ (V)", ylabel="contact area increase (%)",
           xlim=(0, max_voltage), ylim=(0, None))
    place_legend(ax)
    return ax


@styled
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
    ax = ax if ax is not None else new_axes()
    keys: list[Any] = []
    u = np.linspace(max_voltage / 60, max_voltage, 60)
    for i, f in enumerate(normal_forces):
        color = PALETTE[i % len(PALETTE)]
        ax.plot(u, 100 * md_jkr_departure(f, u, params), color=color,
                label=f"force, $F_\\mathrm{{ext}}$ = {f:g} N")
        area = 100 * (contact_area_md(f, u, params) / contact_area_jkr(f, u, params) - 1)
        ax.plot(u, area, color=color, linestyle="--", label=f"area, $F_\\mathrm{{ext}}$ = {f:g} N")
        keys.append(proxy(f"$F_\\mathrm{{ext}}$ = {f:g} N", color=color))
    ax.axhline(0.0, color="0.5", linewidth=0.8)
    ax.set(xlabel="voltage amplitude $U$ (V)", ylabel="Maugis-Dugdale vs JKR (%)",
           xlim=(0, max_voltage))
    twin = ax.twinx()
    twin.spines["right"].set_visible(True)
    twin.plot(u, maugis_parameter(u, params), color="k", linestyle=":", label="$\\lambda$")
    twin.set_ylabel("Maugis parameter $\\lambda$ (1)")
    twin.set_ylim(0, None)
    keys += [proxy("force", color="0.4"), proxy("area", color="0.4", linestyle="--"),
             proxy("$\\lambda$ (right axis)", color="k", linestyle=":")]
    # above the plot: the twin's curve is not seen by the corner check
    place_legend(ax, keys, [str(h.get_label()) for h in keys], ncol_outside=3, inside=False)
    return ax


@styled
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
    ax = ax if ax is not None else new_axes()
    f = np.geomspace(1.0, 1e5, 121)
    styles = (("square", "-"), ("sine", "--"))
    for waveform, style in styles:
        ax.plot(f, 1e3 * electrostatic_force_drive(normal_force, amplitude, f, waveform,
                                                   params), color="k", linestyle=style)
    handles = [proxy("paper ($r_g = \\infty$)", color="k")]
    s_sc, s_g, s_i = layer_elastances(params)
    c_total = 1.0 / s_g + 1.0 / (s_sc + s_i)
    for i, corner in enumerate(corners_Hz):
        leaky = params.with_values(r_g=1.0 / (2.0 * np.pi * corner * c_total))
        color = PALETTE[i % len(PALETTE)]
        for waveform, style in styles:
            ax.plot(f, 1e3 * electrostatic_force_drive(normal_force, amplitude, f, waveform,
                                                       leaky), color=color, linestyle=style)
        handles.append(proxy(f"corner {corner:g} Hz", color=color))
    handles += [proxy(waveform, color="0.4", linestyle=style) for waveform, style in styles]
    ax.set_xscale("log")
    plain_log_axis(ax.xaxis, subs=(1.0,))
    ax.set(xlabel="drive frequency $f$ (Hz)",
           ylabel="electrostatic force $F_\\mathrm{el}$ (mN)", ylim=(0, None))
    place_legend(ax, handles, [str(h.get_label()) for h in handles], ncol_outside=3,
                 title=f"{amplitude:g} V, $F_\\mathrm{{ext}}$ = {normal_force:g} N")
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
        If a file exists and *force* is false, or is a study's input or a raw CAN log
        (*force* or not).
    """
    check_new_path(directory, key="--figures", folder=True)  # a name evtribo writes
    out = Path(directory)
    paths = [out / f"{name}.{fmt}" for name in MODEL_FIGURES for fmt in formats]
    for path in paths:  # a study's input or a raw log is never written over
        refuse_input(path, command="evtribo model", key="--figures")
    refuse_foreign(out, [p.name for p in paths], {"model"}, key="--figures")
    existing = [p for p in paths if p.exists()]
    if existing and not force:
        raise OutputExistsError(
            f"{len(existing)} figure file(s) already exist; use {{force}} to overwrite",
            path=existing[0])
    out.mkdir(parents=True, exist_ok=True)
    written = []
    with journal_style():
        for name, plot in MODEL_FIGURES.items():
            ax = plot(params=params)
            fig = ax.get_figure()
            assert isinstance(fig, Figure)
            for path in save_figure(fig, out, name, dpi=DEFAULT_DPI, formats=formats):
                claim(path, "model")
                written.append(path)
                log.info("wrote %s", path)
    return written
